#pragma once
// Small geometric helpers shared by the wrap algorithms, with the conventions of OpenSim's
// WrapMath and SimmMacros (a zero vector normalises to zero, DSIGN(0) = +1, lines given by a
// point and a direction that need not be unit) so that branch decisions agree with OpenSim's.

#include <cmath>

#include <Eigen/Core>

namespace kneesim::muscle::wrapmath {

using Vec3 = Eigen::Vector3d;

/// SIMM's ROUNDOFF_ERROR, the tolerance of EQUAL_WITHIN_ERROR.
constexpr double kRoundoff = 2e-13;

/// SIMM's DSIGN: +1 for a >= 0, else -1.
inline int dsign(double a) { return a >= 0.0 ? 1 : -1; }

/// Normalises @p v in place and returns its former length; a (near) zero vector becomes zero.
inline double normalizeOrZero(Vec3& v) {
  const double mag = v.norm();
  if (mag < 1e-15)
    v.setZero();
  else
    v /= mag;
  return mag;
}

/// @p v normalised, or zero.
inline Vec3 normalized(Vec3 v) {
  normalizeOrZero(v);
  return v;
}

/// The point of the line through @p line_point with direction @p line (any length) closest to
/// @p pt, and its parameter @p t in units of |line|.
inline Vec3 closestPointOnLine(const Vec3& pt, const Vec3& line_point, const Vec3& line, double& t) {
  Vec3 v1 = pt - line_point, v2 = line;
  const double mag = normalizeOrZero(v1);
  const double mag2 = normalizeOrZero(v2);
  t = v1.dot(v2) * mag;
  const Vec3 closest = line_point + t * v2;
  t = t / mag2;
  return closest;
}

/// Squared distance from @p point to the line through @p line_point with direction @p line.
inline double distanceSquaredToLine(const Vec3& point, const Vec3& line_point, const Vec3& line) {
  const Vec3 d = line_point - point;
  const Vec3 n = line.normalized();
  return (d - d.dot(n) * n).squaredNorm();
}

/// Closest points of the lines p1->p2 and p3->p4: @p int1 = p1 + s (p2 - p1) and
/// @p int2 = p3 + t (p4 - p3). Returns false (s = t = NaN, points untouched) for parallel lines.
bool intersectLines(const Vec3& p1, const Vec3& p2, const Vec3& p3, const Vec3& p4, Vec3& int1, double& s, Vec3& int2,
                    double& t);

/// Intersection @p inter of the segment pt1-pt2 with the plane n.x + d = 0; false if none.
bool intersectSegmentPlane(const Vec3& pt1, const Vec3& pt2, const Vec3& n, double d, Vec3& inter);

}  // namespace kneesim::muscle::wrapmath
