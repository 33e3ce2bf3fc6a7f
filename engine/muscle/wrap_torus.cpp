// Wrapping over a torus as OpenSim's WrapTorus computes it: find the point of the torus's centre
// circle nearest the segment (searched from each end), then wrap over a long cylinder of the
// tube's radius tangent to the circle there, restricted to the half facing the torus's centre.
#include <cmath>

#include <Eigen/Geometry>

#include "muscle/wrap.hpp"
#include "muscle/wrap_math.hpp"

namespace kneesim::muscle {

using namespace wrapmath;

namespace {

constexpr double kCylinderLength = 10000.0;

/// OpenSim's residual (WrapTorus::calcCircleResids) at line parameter @p u from @p p along the
/// unit direction @p n. As written there, its last term is twice the derivative of the distance
/// to the circle of radius @p r; it is reproduced so the same point is found.
double circleResidual(const Vec3& p, const Vec3& n, double r, double u) {
  const double c2 = 2.0 * p.dot(n);
  const double c3 = p.x() * n.x() + p.y() * n.y();
  const double c4 = n.x() * n.x() + n.y() * n.y();
  const double c5 = p.x() * p.x() + p.y() * p.y();
  return c2 + 2.0 * u - 2.0 * r * (2.0 * c4 * u + 2.0 * c3) / std::sqrt(u * u * c4 + 2.0 * c3 * u + c5);
}

/// A zero of circleResidual() near u = 0 (OpenSim uses MINPACK's lmdif from 0 with tolerance
/// 1e-4; a safeguarded Newton iteration converges to the same zero more tightly).
double findResidualZero(const Vec3& p, const Vec3& n, double r) {
  double u = 0.0;
  double f = circleResidual(p, n, r, u);
  for (int it = 0; it < 500 && std::isfinite(f); ++it) {
    const double h = 1e-7 * (1.0 + std::abs(u));
    const double df = (circleResidual(p, n, r, u + h) - circleResidual(p, n, r, u - h)) / (2 * h);
    if (!(std::abs(df) > 0)) break;
    double step = -f / df, fn = 0;
    for (int k = 0; k < 30; ++k, step *= 0.5) {
      fn = circleResidual(p, n, r, u + step);
      if (std::abs(fn) < std::abs(f)) break;
    }
    u += step;
    const bool done = std::abs(step) < 1e-13 * (1.0 + std::abs(u));
    f = fn;
    if (done || f == 0.0) break;
  }
  return u;
}

/// OpenSim's WrapTorus::findClosestPoint: the circle point (radius @p r, plane z = 0) nearest the
/// line p1-p2; false when the quadrant excludes both candidates.
bool findClosestCirclePoint(double r, const Vec3& p1, const Vec3& p2, int axis, int sign, Vec3& closest) {
  const double mag = (p2 - p1).norm();
  const Vec3 n12 = (p2 - p1) / mag;
  const Vec3 a1 = p1 + findResidualZero(p1, n12, r) * n12;
  const Vec3 a2 = p2 + findResidualZero(p2, -n12, r) * (-n12);
  auto distance = [r](const Vec3& a) {
    return std::sqrt(a.squaredNorm() + r * r - 2.0 * r * std::sqrt(a.x() * a.x() + a.y() * a.y()));
  };
  const double d1 = distance(a1), d2 = distance(a2);
  bool first;
  if (sign != 0) {
    const bool ok1 = dsign(a1[axis]) == sign, ok2 = dsign(a2[axis]) == sign;
    if (!ok1 && !ok2) return false;
    first = ok1 && ok2 ? d1 < d2 : ok1;
  } else {
    first = d1 < d2;
  }
  const Vec3& a = first ? a1 : a2;
  const double m = std::sqrt(a.x() * a.x() + a.y() * a.y());
  closest = Vec3(a.x() * r / m, a.y() * r / m, 0.0);
  return true;
}

}  // namespace

WrapStatus wrapTorus(double inner_radius, double outer_radius, int axis, int sign, const Vec3& p1, const Vec3& p2,
                     WrapResult& result) {
  Vec3 closest;
  if (!findClosestCirclePoint(outer_radius, p1, p2, axis, sign, closest)) return WrapStatus::NoWrap;
  // Cylinder frame C: origin at the circle point, x towards the torus centre, y = -z of the
  // torus, z along the circle's tangent; p_C = R (p_T - closest).
  const Vec3 x = normalized(-closest), y(0.0, 0.0, -1.0), z = x.cross(y);
  Eigen::Matrix3d R;
  R.row(0) = x;
  R.row(1) = y;
  R.row(2) = z;
  const Vec3 q1 = R * (p1 - closest), q2 = R * (p2 - closest);
  const WrapStatus status = wrapCylinder(inner_radius, kCylinderLength, 0, 1, q1, q2, result);
  // OpenSim reports every torus wrap as "wrapped" (never mandatory); a cylinder that does not
  // wrap is reported here as such rather than with stale tangent points.
  if (status != WrapStatus::Wrapped && status != WrapStatus::Mandatory) return status;
  result.r1 = R.transpose() * result.r1 + closest;
  result.r2 = R.transpose() * result.r2 + closest;
  return WrapStatus::Wrapped;
}

}  // namespace kneesim::muscle
