#pragma once
// Curves made of quintic Bezier segments joined with continuous slope, as OpenSim's
// SmoothSegmentedFunctionFactory builds Millard2012EquilibriumMuscle's force-length and
// force-velocity curves (M. Millard et al., J Biomech Eng 135(2):021005, 2013): each segment is
// an "elbow" between two points with given slopes, its control points placed on the two tangent
// lines by a curviness factor; outside its domain the curve continues as a straight line.

#include <array>
#include <vector>

namespace kneesim::muscle {

/// A curve y(x) of quintic Bezier segments. Immutable once built; evaluation allocates nothing.
class BezierCurve {
 public:
  BezierCurve() = default;

  /// Adds the elbow from (x0, y0) with slope dydx0 to (x1, y1) with slope dydx1, OpenSim's
  /// calcQuinticBezierCornerControlPoints with @p curviness already scaled (0.1 + 0.8 c).
  void addElbow(double x0, double y0, double dydx0, double x1, double y1, double dydx1, double curviness);

  /// Sets the straight continuations: y = y0 + dydx0 (x - x0) left of the first segment's start
  /// x0, y = y1 + dydx1 (x - x1) right of the last one's end x1.
  void setExtrapolation(double y0, double dydx0, double y1, double dydx1);

  /// y(x).
  double calcValue(double x) const;

  /// dy/dx at x.
  double calcDerivative(double x) const;

  /// Millard's active force-length curve: zero below x0 (OpenSim's default 0.4441), a shallow plateau
  /// ascending from x1 to the optimum x2 = 1, zero beyond x3, with minimum value ylow.
  static BezierCurve makeActiveForceLength(double x0, double x1, double x2, double x3, double ylow, double dydx,
                                           double curviness);

  /// Millard's force-velocity curve over normalised velocity -1 (maximum shortening) to 1.
  static BezierCurve makeForceVelocity(double fmax_eccentric, double dydx_conc, double dydx_near_conc, double dydx_iso,
                                       double dydx_ecc, double dydx_near_ecc, double conc_curviness,
                                       double ecc_curviness);

 private:
  struct Segment {
    std::array<double, 6> x, y;
  };
  int findSegment(double x) const;
  static double findU(const Segment& s, double x);
  std::vector<Segment> segments_;
  double x0_ = 0, x1_ = 0, y0_ = 0, y1_ = 0, dydx0_ = 0, dydx1_ = 0;
};

}  // namespace kneesim::muscle
