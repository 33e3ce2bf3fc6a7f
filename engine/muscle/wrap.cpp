// Dispatch of a segment to its wrap object's algorithm, the shared line helpers, and the sphere.
#include "muscle/wrap.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "muscle/wrap_math.hpp"

namespace kneesim::muscle {

namespace wrapmath {

bool intersectLines(const Vec3& p1, const Vec3& p2, const Vec3& p3, const Vec3& p4, Vec3& int1, double& s, Vec3& int2,
                    double& t) {
  Vec3 vec1 = p2 - p1, vec2 = p4 - p3;
  const double mag1 = normalizeOrZero(vec1);
  const double mag2 = normalizeOrZero(vec2);
  const Vec3 cross = vec1.cross(vec2);
  const double denom = cross.squaredNorm();
  if (std::abs(denom) <= kRoundoff) {
    s = t = std::numeric_limits<double>::quiet_NaN();
    return false;
  }
  // Determinants of the rows (p3 - p1, vec, cross), as OpenSim's CALC_DETERMINANT.
  const Vec3 d = p3 - p1;
  t = d.dot(vec1.cross(cross)) / denom;
  int2 = p3 + t * vec2;
  s = d.dot(vec2.cross(cross)) / denom;
  int1 = p1 + s * vec1;
  s /= mag1;
  t /= mag2;
  return true;
}

bool intersectSegmentPlane(const Vec3& pt1, const Vec3& pt2, const Vec3& n, double d, Vec3& inter) {
  constexpr double kLineEpsilon = 0.00001;
  const Vec3 vec = pt2 - pt1;
  const double dot = vec.dot(n);
  if (std::abs(dot) < kLineEpsilon) return false;
  const double t = (-d - n.dot(pt1)) / dot;
  if (t < -kLineEpsilon || t > 1.0 + kLineEpsilon) return false;
  inter = pt1 + t * vec;
  return true;
}

}  // namespace wrapmath

using namespace wrapmath;

WrapStatus wrapSegment(const model::WrapObject& o, model::WrapMethod method, const Vec3& p1, const Vec3& p2,
                       WrapResult& result) {
  const int axis = o.quadrant_axis, sign = o.quadrant_sign;
  switch (o.shape) {
    case model::WrapShape::Sphere:
      return wrapSphere(o.dimensions.x(), axis, sign, p1, p2, result);
    case model::WrapShape::Cylinder:
      return wrapCylinder(o.dimensions.x(), o.dimensions.y(), axis, sign, p1, p2, result);
    case model::WrapShape::Ellipsoid:
      return wrapEllipsoid(o.dimensions, method, axis, sign, p1, p2, result);
    case model::WrapShape::Torus:
      return wrapTorus(o.dimensions.x(), o.dimensions.y(), axis, sign, p1, p2, result);
  }
  return WrapStatus::NoWrap;
}

namespace {

/// OpenSim's two tangent-point candidates from an outside point @p p of a sphere of radius
/// @p radius centred on the origin, in the plane of normal @p n.
void sphereTangentCandidates(const Vec3& p, const Vec3& n, double radius, Vec3& ra, Vec3& rb) {
  const Vec3 y = normalized(-p);
  const Vec3 z = n.cross(y);
  const double dist = p.norm();
  const double a = std::asin(radius / dist);
  // Column 1 of [n y z] times SIMM's direction cosine matrix about x by +a and -a.
  const double reach = dist * std::cos(a);
  ra = p + (std::cos(a) * y - std::sin(a) * z) * reach;
  rb = p + (std::cos(a) * y + std::sin(a) * z) * reach;
}

}  // namespace

WrapStatus wrapSphere(double radius, int axis, int sign, const Vec3& p1, const Vec3& p2, WrapResult& result) {
  const Vec3 ri = p1 - p2, mp = -p2;
  Vec3 p1p2 = p1 - p2;
  WrapStatus code = WrapStatus::Wrapped;
  bool far_side_wrap = false;
  if (p1.norm() < radius || p2.norm() < radius) return WrapStatus::InsideRadius;

  const double a = ri.dot(ri), b = -2.0 * mp.dot(ri), c = mp.dot(mp) - radius * radius;
  const double disc = b * b - 4.0 * a * c;
  if (disc < 0.0) return WrapStatus::NoWrap;
  const double l1 = (-b + std::sqrt(disc)) / (2.0 * a), l2 = (-b - std::sqrt(disc)) / (2.0 * a);
  if (!(0.0 < l1 && l1 < 1.0) || !(0.0 < l2 && l2 < 1.0) || l1 < l2) return WrapStatus::NoWrap;

  normalizeOrZero(p1p2);
  const Vec3 hp2 = p1p2.cross(normalized(p2));
  if (hp2.norm() < 0.00001) {
    // The line passes (nearly) through the centre: OpenSim keeps the previous tangent points.
    if (!result.has_previous) return WrapStatus::NoWrap;
  } else {
    const Vec3 n = normalized(hp2);
    Vec3 r1a, r1b, r2a, r2b;
    sphereTangentCandidates(p1, n, radius, r1a, r1b);
    sphereTangentCandidates(p2, n, radius, r2a, r2b);
    const Vec3 r1am = normalized(r1a), r1bm = normalized(r1b), r2am = normalized(r2a), r2bm = normalized(r2b);
    const double j1 = r1am.dot(r2am), j2 = r1am.dot(r2bm), j3 = r1bm.dot(r2am), j4 = r1bm.dot(r2bm);
    Vec3 r11, r22;  // the candidates not chosen
    if (j1 > j2 && j1 > j3 && j1 > j4) {
      result.r1 = r1a, result.r2 = r2a, r11 = r1b, r22 = r2b;
    } else if (j2 > j3 && j2 > j4) {
      result.r1 = r1a, result.r2 = r2b, r11 = r1b, r22 = r2a;
    } else if (j3 > j4) {
      result.r1 = r1b, result.r2 = r2a, r11 = r1a, r22 = r2b;
    } else {
      result.r1 = r1b, result.r2 = r2b, r11 = r1a, r22 = r2a;
    }
    if (sign != 0) {
      if (dsign(p1[axis]) == sign || dsign(p2[axis]) == sign) {
        double tt;
        const Vec3 mm = closestPointOnLine(Vec3::Zero(), p1, p1p2, tt);
        tt = -tt;  // OpenSim compares this distance (in metres) with 0 and 1, as written
        if (mm.squaredNorm() < radius * radius && tt > 0.0 && tt < 1.0)
          code = WrapStatus::Mandatory;
        else if (dsign(p1[axis]) != dsign(p2[axis]) && dsign(mm[axis]) != sign)
          code = WrapStatus::Wrapped;
        else
          return WrapStatus::NoWrap;
      }
      if (dsign(p1[axis]) != sign || dsign(p2[axis]) != sign) {
        Vec3 wrapaxis = Vec3::Zero();
        wrapaxis[axis] = sign;
        Vec3 sum_musc = normalized(-p1 - p2);
        if (r1am.dot(sum_musc) > r1bm.dot(sum_musc))
          result.r1 = r1a, r11 = r1b;
        else
          result.r1 = r1b, r11 = r1a;
        if (r2am.dot(sum_musc) > r2bm.dot(sum_musc))
          result.r2 = r2a, r22 = r2b;
        else
          result.r2 = r2b, r22 = r2a;
        sum_musc = normalized((result.r1 - p1) + (result.r2 - p2));
        if (sum_musc.dot(wrapaxis) < 0.0) result.r1 = r11, result.r2 = r22;
        sum_musc = (result.r1 - p1) + (result.r2 - p2);
        if ((result.r1 + result.r2).dot(sum_musc) < 0.0) far_side_wrap = true;
      }
    }
  }
  double angle = std::acos(std::clamp(normalized(result.r1).dot(normalized(result.r2)), -1.0, 1.0));
  // OpenSim stores -(2 pi - angle) for the long way round; the length is its magnitude.
  if (far_side_wrap) angle = 2.0 * M_PI - angle;
  result.length = radius * angle;
  return code;
}

}  // namespace kneesim::muscle
