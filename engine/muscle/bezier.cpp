// Quintic Bezier curve sets (OpenSim's SmoothSegmentedFunction and the two Millard curves of
// SmoothSegmentedFunctionFactory that static optimisation evaluates).
#include "muscle/bezier.hpp"

#include <cmath>

#include "core/error.hpp"

namespace kneesim::muscle {

namespace {

/// Bernstein form of a quintic and its derivative in u.
double bezier(const std::array<double, 6>& p, double u) {
  const double v = 1.0 - u;
  const double u2 = u * u, v2 = v * v;
  return v2 * v2 * v * p[0] + 5 * u * v2 * v2 * p[1] + 10 * u2 * v2 * v * p[2] + 10 * u2 * u * v2 * p[3] +
         5 * u2 * u2 * v * p[4] + u2 * u2 * u * p[5];
}

double bezierDerivative(const std::array<double, 6>& p, double u) {
  const double v = 1.0 - u;
  const double u2 = u * u, v2 = v * v;
  return 5 * (v2 * v2 * (p[1] - p[0]) + 4 * u * v2 * v * (p[2] - p[1]) + 6 * u2 * v2 * (p[3] - p[2]) +
              4 * u2 * u * v * (p[4] - p[3]) + u2 * u2 * (p[5] - p[4]));
}

double scaleCurviness(double c) { return 0.1 + 0.8 * c; }

}  // namespace

void BezierCurve::addElbow(double x0, double y0, double dydx0, double x1, double y1, double dydx1, double curviness) {
  // The corner where the two tangent lines meet (their midpoint when they are parallel).
  const double xC = std::abs(dydx0 - dydx1) > std::sqrt(2.2e-16) ? (y1 - y0 - x1 * dydx1 + x0 * dydx0) / (dydx0 - dydx1)
                                                                 : (x1 + x0) / 2;
  const double yC = (xC - x1) * dydx1 + y1;
  const double x0m = x0 + curviness * (xC - x0), y0m = y0 + curviness * (yC - y0);
  const double x1m = x1 + curviness * (xC - x1), y1m = y1 + curviness * (yC - y1);
  segments_.push_back(Segment{{x0, x0m, x0m, x1m, x1m, x1}, {y0, y0m, y0m, y1m, y1m, y1}});
  x0_ = segments_.front().x[0];
  x1_ = segments_.back().x[5];
}

void BezierCurve::setExtrapolation(double y0, double dydx0, double y1, double dydx1) {
  y0_ = y0;
  dydx0_ = dydx0;
  y1_ = y1;
  dydx1_ = dydx1;
}

int BezierCurve::findSegment(double x) const {
  for (size_t i = 0; i + 1 < segments_.size(); ++i)
    if (x < segments_[i].x[5]) return int(i);
  return int(segments_.size()) - 1;
}

double BezierCurve::findU(const Segment& s, double x) {
  // x(u) increases monotonically on every elbow; Newton from the chord's guess, kept inside a
  // shrinking bracket.
  double lo = 0.0, hi = 1.0;
  double u = (x - s.x[0]) / (s.x[5] - s.x[0]);
  for (int it = 0; it < 60; ++it) {
    const double f = bezier(s.x, u) - x;
    if (std::abs(f) < 1e-15) break;
    if (f > 0)
      hi = u;
    else
      lo = u;
    const double df = bezierDerivative(s.x, u);
    double next = df > 0 ? u - f / df : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - u) < 1e-16) break;
    u = next;
  }
  return u;
}

double BezierCurve::calcValue(double x) const {
  KNEESIM_ASSERT(!segments_.empty());
  if (x < x0_) return y0_ + dydx0_ * (x - x0_);
  if (x > x1_) return y1_ + dydx1_ * (x - x1_);
  const Segment& s = segments_[findSegment(x)];
  return bezier(s.y, findU(s, x));
}

double BezierCurve::calcDerivative(double x) const {
  if (x < x0_) return dydx0_;
  if (x > x1_) return dydx1_;
  const Segment& s = segments_[findSegment(x)];
  const double u = findU(s, x);
  return bezierDerivative(s.y, u) / bezierDerivative(s.x, u);
}

BezierCurve BezierCurve::makeActiveForceLength(double x0, double x1, double x2, double x3, double ylow, double dydx,
                                               double curviness) {
  const double c = scaleCurviness(curviness);
  // The shoulder sits xDelta below the optimum; five elbows: ascending limb (two), plateau,
  // and descending limb (two).
  const double x_delta = 0.05 * x2;
  const double xs = x2 - x_delta;
  const double y0 = 0, dydx0 = 0;
  const double y1 = 1 - dydx * (xs - x1);
  const double dydx01 = 1.25 * (y1 - y0) / (x1 - x0);
  const double x01 = x0 + 0.5 * (x1 - x0), y01 = y0 + 0.5 * (y1 - y0);
  const double x1s = x1 + 0.5 * (xs - x1), y1s = y1 + 0.5 * (1 - y1), dydx1s = dydx;
  const double y2 = 1, dydx2 = 0, dydx3 = 0;
  const double x23 = (x2 + x_delta) + 0.5 * (x3 - (x2 + x_delta)), y23 = y2 + 0.5 * (0 - y2);
  const double dydx23 = (0 - y2) / ((x3 - x_delta) - (x2 + x_delta));
  BezierCurve curve;
  curve.addElbow(x0, ylow, dydx0, x01, y01, dydx01, c);
  curve.addElbow(x01, y01, dydx01, x1s, y1s, dydx1s, c);
  curve.addElbow(x1s, y1s, dydx1s, x2, y2, dydx2, c);
  curve.addElbow(x2, y2, dydx2, x23, y23, dydx23, c);
  curve.addElbow(x23, y23, dydx23, x3, ylow, dydx3, c);
  curve.setExtrapolation(ylow, 0, ylow, 0);
  return curve;
}

BezierCurve BezierCurve::makeForceVelocity(double fmax_ecc, double dydx_c, double dydx_near_c, double dydx_iso,
                                           double dydx_e, double dydx_near_e, double conc_curviness,
                                           double ecc_curviness) {
  const double cc = scaleCurviness(conc_curviness), ce = scaleCurviness(ecc_curviness);
  const double xc = -1, yc = 0, x_near_c = -0.9;
  const double y_near_c = yc + 0.5 * dydx_near_c * (x_near_c - xc) + 0.5 * dydx_c * (x_near_c - xc);
  const double x_iso = 0, y_iso = 1;
  const double xe = 1, ye = fmax_ecc, x_near_e = 0.9;
  const double y_near_e = ye + 0.5 * dydx_near_e * (x_near_e - xe) + 0.5 * dydx_e * (x_near_e - xe);
  BezierCurve curve;
  curve.addElbow(xc, yc, dydx_c, x_near_c, y_near_c, dydx_near_c, cc);
  curve.addElbow(x_near_c, y_near_c, dydx_near_c, x_iso, y_iso, dydx_iso, cc);
  curve.addElbow(x_iso, y_iso, dydx_iso, x_near_e, y_near_e, dydx_near_e, ce);
  curve.addElbow(x_near_e, y_near_e, dydx_near_e, xe, ye, dydx_e, ce);
  curve.setExtrapolation(yc, dydx_c, ye, dydx_e);
  return curve;
}

}  // namespace kneesim::muscle
