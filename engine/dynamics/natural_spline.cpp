#include "dynamics/natural_spline.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Sparse>
#include <Eigen/SparseLU>

#include "core/error.hpp"

namespace kneesim::dynamics {

namespace {

constexpr int kMaxOrder = 8;  // heptic

/// B-spline basis functions of degree p and their derivatives up to order n at u in knot span
/// `span` (U[span] <= u < U[span+1]): ders[d][r] is the d-th derivative of N_{span-p+r}.
/// The algorithm of Piegl & Tiller, The NURBS Book (2nd ed.), A2.3.
void calcBasisDerivatives(int span, double u, int p, int n, const std::vector<double>& U,
                          double ders[kMaxOrder][kMaxOrder]) {
  double ndu[kMaxOrder][kMaxOrder], left[kMaxOrder], right[kMaxOrder], a[2][kMaxOrder];
  ndu[0][0] = 1.0;
  for (int j = 1; j <= p; ++j) {
    left[j] = u - U[span + 1 - j];
    right[j] = U[span + j] - u;
    double saved = 0.0;
    for (int r = 0; r < j; ++r) {
      ndu[j][r] = right[r + 1] + left[j - r];
      const double temp = ndu[r][j - 1] / ndu[j][r];
      ndu[r][j] = saved + right[r + 1] * temp;
      saved = left[j - r] * temp;
    }
    ndu[j][j] = saved;
  }
  for (int j = 0; j <= p; ++j) ders[0][j] = ndu[j][p];
  for (int r = 0; r <= p; ++r) {
    int s1 = 0, s2 = 1;
    a[0][0] = 1.0;
    for (int k = 1; k <= n; ++k) {
      double d = 0.0;
      const int rk = r - k, pk = p - k;
      if (r >= k) {
        a[s2][0] = a[s1][0] / ndu[pk + 1][rk];
        d = a[s2][0] * ndu[rk][pk];
      }
      const int j1 = rk >= -1 ? 1 : -rk;
      const int j2 = (r - 1 <= pk) ? k - 1 : p - r;
      for (int j = j1; j <= j2; ++j) {
        a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][rk + j];
        d += a[s2][j] * ndu[rk + j][pk];
      }
      if (r <= pk) {
        a[s2][k] = -a[s1][k - 1] / ndu[pk + 1][r];
        d += a[s2][k] * ndu[r][pk];
      }
      ders[k][r] = d;
      std::swap(s1, s2);
    }
  }
  double f = p;
  for (int k = 1; k <= n; ++k) {
    for (int j = 0; j <= p; ++j) ders[k][j] *= f;
    f *= (p - k);
  }
}

}  // namespace

struct NaturalSplineFitter::Impl {
  std::vector<double> x;
  int m = 0, p = 0;  // half order, degree
  std::vector<double> U;
  int nb = 0;  // number of B-spline coefficients
  Eigen::SparseLU<Eigen::SparseMatrix<double>> lu;
  /// Per interval i: derivatives 0..p of the p+1 basis functions nonzero on it, at x_i.
  std::vector<double> ders;
};

NaturalSplineFitter::~NaturalSplineFitter() = default;

NaturalSplineFitter::NaturalSplineFitter(std::vector<double> x, int degree) : impl_(std::make_unique<Impl>()) {
  Impl& d = *impl_;
  if (degree < 1 || degree > 7 || degree % 2 == 0)
    throw std::invalid_argument("spline degree: expected 1, 3, 5 or 7, got " + std::to_string(degree));
  d.m = (degree + 1) / 2;
  d.p = degree;
  const int N = int(x.size()), k = d.p + 1;
  if (N < k)
    throw std::invalid_argument("expected at least " + std::to_string(k) + " samples for a spline of degree " +
                                std::to_string(degree) + ", got " + std::to_string(N));
  for (int i = 0; i < N; ++i) {
    if (!std::isfinite(x[i])) throw std::invalid_argument("expected finite abscissae, got " + std::to_string(x[i]));
    if (i > 0 && !(x[i] > x[i - 1]))
      throw std::invalid_argument("expected strictly increasing abscissae, got " + std::to_string(x[i - 1]) +
                                  " then " + std::to_string(x[i]));
  }
  d.x = std::move(x);
  // Clamped knot vector: end knots of multiplicity p+1, the interior data as simple knots.
  d.U.assign(k, d.x.front());
  d.U.insert(d.U.end(), d.x.begin() + 1, d.x.end() - 1);
  d.U.insert(d.U.end(), k, d.x.back());
  d.nb = N + 2 * d.m - 2;

  // Collocation: N interpolation rows, then derivatives m..2m-2 zero at both ends.
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(size_t(d.nb) * k);
  d.ders.assign(size_t(N - 1) * k * k, 0.0);
  double ders[kMaxOrder][kMaxOrder];
  for (int i = 0; i < N; ++i) {
    const int span = i < N - 1 ? d.p + i : d.nb - 1;  // U[span] <= x_i < U[span+1] (last: closed)
    calcBasisDerivatives(span, d.x[i], d.p, d.p, d.U, ders);
    for (int r = 0; r <= d.p; ++r) triplets.emplace_back(i, span - d.p + r, ders[0][r]);
    if (i < N - 1)
      for (int o = 0; o <= d.p; ++o)
        for (int r = 0; r <= d.p; ++r) d.ders[(size_t(i) * k + o) * k + r] = ders[o][r];
    if (i == 0 || i == N - 1) {
      int row = N + (i == 0 ? 0 : d.m - 1);
      for (int o = d.m; o <= 2 * d.m - 2; ++o, ++row)
        for (int r = 0; r <= d.p; ++r) triplets.emplace_back(row, span - d.p + r, ders[o][r]);
    }
  }
  Eigen::SparseMatrix<double> A(d.nb, d.nb);
  A.setFromTriplets(triplets.begin(), triplets.end());
  d.lu.compute(A);
  if (d.lu.info() != Eigen::Success)
    throw std::invalid_argument("the spline's collocation matrix is singular (abscissae too close together?)");
}

NaturalSpline NaturalSplineFitter::fit(const std::vector<double>& y) const {
  const Impl& d = *impl_;
  const int N = int(d.x.size()), k = d.p + 1;
  KNEESIM_CHECK(int(y.size()) == N, "spline ordinates do not match the abscissae");
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(d.nb);
  for (int i = 0; i < N; ++i) rhs[i] = y[i];
  const Eigen::VectorXd c = d.lu.solve(rhs);
  NaturalSpline s;
  s.x_ = d.x;
  s.order_ = k;
  s.half_order_ = d.m;
  s.coef_.assign(size_t(N - 1) * k, 0.0);
  for (int i = 0; i < N - 1; ++i) {
    const int first = i;  // span p+i: basis functions i..i+p
    double factorial = 1.0;
    for (int o = 0; o <= d.p; ++o) {
      if (o > 0) factorial *= o;
      double v = 0.0;
      for (int r = 0; r <= d.p; ++r) v += d.ders[(size_t(i) * k + o) * k + r] * c[first + r];
      s.coef_[size_t(i) * k + o] = v / factorial;
    }
  }
  return s;
}

void NaturalSpline::calcDerivatives(double x, int max_order, double* out) const {
  KNEESIM_ASSERT(!x_.empty() && max_order >= 0);
  const int n = int(x_.size());
  int interval;
  double dx;
  int degree = order_ - 1;
  if (x <= x_.front()) {
    interval = 0;
    dx = x - x_.front();
    if (dx < 0) degree = half_order_ - 1;  // natural extrapolation: degree m-1
  } else if (x >= x_.back()) {
    // Taylor expansion at the last knot, from the last interval's polynomial.
    const double* c = &coef_[size_t(n - 2) * order_];
    const double h = x_.back() - x_[n - 2];
    double at_end[kMaxOrder];
    for (int o = 0; o < order_; ++o) {
      double v = 0.0;
      for (int j = order_ - 1; j >= o; --j) {
        double f = 1.0;
        for (int t = 0; t < o; ++t) f *= (j - t);
        v = v * h + c[j] * f;
      }
      at_end[o] = v;
    }
    const double e = x - x_.back();
    const int deg = half_order_ - 1;
    for (int o = 0; o <= max_order; ++o) {
      double v = 0.0, term = 1.0;
      // sum_{j=o..deg} at_end[j] e^(j-o) / (j-o)!
      for (int j = o; j <= deg; ++j) {
        v += at_end[j] * term;
        term *= e / (j - o + 1);
      }
      out[o] = o <= deg ? v : 0.0;
    }
    return;
  } else {
    interval = int(std::upper_bound(x_.begin(), x_.end(), x) - x_.begin()) - 1;
    dx = x - x_[interval];
  }
  const double* c = &coef_[size_t(interval) * order_];
  for (int o = 0; o <= max_order; ++o) {
    if (o > degree) {
      out[o] = 0.0;
      continue;
    }
    // d^o/dx^o sum_j c_j dx^j = sum_{j>=o} c_j j!/(j-o)! dx^(j-o), by Horner.
    double v = 0.0;
    for (int j = degree; j >= o; --j) {
      double f = 1.0;
      for (int t = 0; t < o; ++t) f *= (j - t);
      v = v * dx + c[j] * f;
    }
    out[o] = v;
  }
}

double NaturalSpline::calcValue(double x) const {
  double out[1];
  calcDerivatives(x, 0, out);
  return out[0];
}

double NaturalSpline::calcDerivative(double x, int order) const {
  double out[kMaxOrder + 1];
  if (order >= kMaxOrder) return 0.0;
  calcDerivatives(x, order, out);
  return out[order];
}

}  // namespace kneesim::dynamics
