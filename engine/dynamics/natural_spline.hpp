#pragma once
// Interpolating natural splines of odd degree (linear, cubic, quintic, heptic): what OpenSim's
// GCVSpline computes when its error variance is 0, which is how OpenSim's InverseDynamicsTool
// differentiates coordinates (degree 5) and how its ExternalForce interpolates load data
// (degree 3).
//
// The natural spline of degree 2m-1 through (x_i, y_i) is the unique interpolant that minimises
// the integral of its m-th derivative squared (Woltring's GCVSPL with p = 0): a piecewise
// polynomial with knots at the data, 2m-2 continuous derivatives, and derivatives m..2m-2 zero
// at both end knots. It is computed here independently of GCVSPL (B-spline collocation solved
// with a sparse LU, then converted to one Taylor polynomial per interval), so any difference from
// OpenSim's values is rounding.

#include <memory>
#include <vector>

namespace kneesim::dynamics {

/// One interpolating natural spline, immutable once fitted; evaluation allocates nothing.
class NaturalSpline {
 public:
  NaturalSpline() = default;

  /// Value of the spline at @p x. Outside the data it continues as the polynomial of degree
  /// m-1 it is at the end knots (natural extrapolation).
  double calcValue(double x) const;
  /// Derivative of order @p order (0 = value) at @p x.
  double calcDerivative(double x, int order) const;
  /// Value and derivatives 0..@p max_order at @p x into @p out (max_order + 1 entries).
  void calcDerivatives(double x, int max_order, double* out) const;

  /// Degree 2m-1 of the spline.
  int getDegree() const { return order_ - 1; }
  /// First and last abscissa.
  double getMinX() const { return x_.front(); }
  double getMaxX() const { return x_.back(); }

 private:
  friend class NaturalSplineFitter;
  std::vector<double> x_;     // knots = data abscissae
  std::vector<double> coef_;  // per interval: Taylor coefficients at its left knot, order_ each
  int order_ = 0;             // 2m
  int half_order_ = 0;        // m
};

/// Fits natural splines of one degree on one set of abscissae: the collocation matrix is
/// factorised once and reused for every ordinate column.
class NaturalSplineFitter {
 public:
  /// Prepares splines of degree @p degree (1, 3, 5 or 7) through abscissae @p x, which must be
  /// strictly increasing with at least degree + 1 points. Throws std::invalid_argument
  /// otherwise (callers turn it into an InputError naming their file).
  NaturalSplineFitter(std::vector<double> x, int degree);
  ~NaturalSplineFitter();
  NaturalSplineFitter(const NaturalSplineFitter&) = delete;
  NaturalSplineFitter& operator=(const NaturalSplineFitter&) = delete;

  /// The interpolating natural spline through (x_i, y_i), @p y having one entry per abscissa.
  NaturalSpline fit(const std::vector<double>& y) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kneesim::dynamics
