// Wrapping over a cylinder as OpenSim's WrapCylinder computes it: tangent-point candidates from
// each end point, quadrant rules, the apex plane that slides them along the axis, then a helix
// whose end points are nudged until the straight segments meet it within 0.1 degree.
#include <cmath>

#include "muscle/wrap.hpp"
#include "muscle/wrap_math.hpp"

namespace kneesim::muscle {

using namespace wrapmath;

namespace {

const Vec3 kAxisPoint(0.0, 0.0, -1.0);  // OpenSim's p0: a point on the axis
const Vec3 kAxis(0.0, 0.0, 1.0);        // OpenSim's dn: the axis direction
constexpr int kMaxIterations = 100;
constexpr double kTangencyThreshold = 0.1 * M_PI / 180.0;

/// The two candidate tangent points from @p p, and p's foot on the axis and distance to it.
void tangentCandidates(const Vec3& p, double radius, Vec3& foot, double& foot_dist, Vec3& ra, Vec3& rb) {
  double t;
  foot = closestPointOnLine(p, kAxisPoint, kAxis, t);
  Vec3 vv = p - foot;
  foot_dist = normalizeOrZero(vv);
  const double sin_theta = radius / foot_dist;
  double dist = radius * sin_theta;
  const Vec3 pp = foot + dist * vv;
  dist = std::sqrt(radius * radius - dist * dist);
  const Vec3 uu = kAxis.cross(vv);
  ra = pp + dist * uu;
  rb = pp - dist * uu;
}

/// The helix point at fraction @p t of the way from r1a's radial direction @p uu.
Vec3 spiralPoint(const Vec3& r1a, const Vec3& axial_vec, const Vec3& uu, const Vec3& ax, double radius, double sense,
                 double t, double theta) {
  const double angle = sense * t * theta;
  // uu rotated by angle about ax (uu is perpendicular to ax).
  const Vec3 radial = std::cos(angle) * uu + std::sin(angle) * ax.cross(uu);
  return r1a + radius * radial + t * axial_vec;
}

/// Slides tangent point @p r1 along the axis when the line from @p pt1 meets the helix at an
/// angle above the threshold (OpenSim's _adjust_tangent_point). Returns whether it moved.
bool adjustTangentPoint(const Vec3& pt1, Vec3& r1, const Vec3& w1) {
  const Vec3 pr = normalized(r1 - pt1), rw = normalized(w1 - r1);
  const double alpha = std::acos(pr.dot(kAxis)), omega = std::acos(rw.dot(kAxis));
  if (!(std::abs(alpha - omega) > kTangencyThreshold)) return false;
  double t;
  const Vec3 p1a = closestPointOnLine(pt1, r1, kAxis, t);
  const Vec3 w1a = closestPointOnLine(w1, r1, kAxis, t);
  Vec3 p1w1_int = Vec3::Constant(NAN), p1aw1a_int = Vec3::Constant(NAN);
  double s;
  intersectLines(pt1, w1, p1a, w1a, p1w1_int, s, p1aw1a_int, t);
  r1 += 1.5 * (p1aw1a_int - r1);
  return true;
}

/// OpenSim's _make_spiral_path: the helix from r1 to r2 and its length, adjusting r1 and r2.
void makeSpiralPath(const Vec3& p1, const Vec3& p2, double radius, bool far_side_wrap, WrapResult& result) {
  const double sense = far_side_wrap ? -1.0 : 1.0;
  for (int iterations = 0;; ++iterations) {
    double t;
    const Vec3 r1a = closestPointOnLine(result.r1, kAxisPoint, kAxis, t);
    const Vec3 r2a = closestPointOnLine(result.r2, kAxisPoint, kAxis, t);
    const Vec3 axial_vec = r2a - r1a;
    const double axial_dist = axial_vec.norm();
    const Vec3 uu = (result.r1 - r1a) / radius;
    Vec3 vv = (result.r2 - r2a) / radius;
    double theta = std::acos(uu.dot(vv) / (uu.norm() * vv.norm()));
    if (far_side_wrap) theta = 2.0 * M_PI - theta;
    const double x = radius * theta, y = axial_dist;
    result.length = std::sqrt(x * x + y * y);
    const Vec3 ax = normalized(uu.cross(vv));
    // OpenSim samples the helix every 2 mm and checks tangency at the second sample.
    int segments = int(result.length / 0.002);
    if (segments < 1) segments = 1;
    if (segments < 2 || iterations >= kMaxIterations) return;
    const double ts = 1.0 / segments;
    const Vec3 w1 = spiralPoint(r1a, axial_vec, uu, ax, radius, sense, ts, theta);
    const Vec3 w2 = spiralPoint(r1a, axial_vec, uu, ax, radius, sense, 1.0 - ts, theta);
    const bool moved1 = adjustTangentPoint(p1, result.r1, w1);
    const bool moved2 = adjustTangentPoint(p2, result.r2, w2);
    if (!moved1 && !moved2) return;
  }
}

// Quadrant-constrained: the tangent candidates on the active half of @p axis (the a/b pairs as
// OpenSim pairs them); sets whether the wrap goes round the far side and the long way.
void chooseConstrainedTangents(int axis, int sign, const Vec3& p1, const Vec3& p2, const Vec3& p11, const Vec3& p22,
                               const Vec3& r1a, const Vec3& r1b, const Vec3& r2a, const Vec3& r2b, WrapResult& result,
                               bool& far_side_wrap, bool& long_wrap) {
  const Vec3 r1am = r1a - p11, r1bm = r1b - p11, r2am = r2a - p22, r2bm = r2b - p22;
  const double alpha = std::acos(r1am.dot(r2bm) / (r1am.norm() * r2bm.norm()));
  const double beta = std::acos(r1bm.dot(r2am) / (r1bm.norm() * r2am.norm()));
  const bool on1a = dsign(r1a[axis]) == sign, on1b = dsign(r1b[axis]) == sign;
  const bool on2a = dsign(r2a[axis]) == sign, on2b = dsign(r2b[axis]) == sign;
  bool use_ab;  // r1 = r1a, r2 = r2b (else r1 = r1b, r2 = r2a)
  if (on1a && on1b)
    use_ab = !on2a;
  else if (on1a != on1b)
    use_ab = on1a;
  else if (on2a)
    use_ab = false;
  else if (on2b)
    use_ab = true;
  else
    use_ab = alpha > beta;
  result.r1 = use_ab ? r1a : r1b;
  result.r2 = use_ab ? r2b : r2a;
  // With no candidate on the active half OpenSim always takes the far side.
  far_side_wrap = (!on1a && !on1b && !on2a && !on2b) || (use_ab == (alpha > beta));
  const Vec3 sum_musc = (result.r1 - p1) + (result.r2 - p2);
  const Vec3 sum_r = (result.r1 - p11) + (result.r2 - p22);
  if (sum_r.dot(sum_musc) < 0.0) long_wrap = true;
}

// Unconstrained: the pair of candidates whose directions from the feet agree best.
void chooseTangents(const Vec3& p11, const Vec3& p22, const Vec3& r1a, const Vec3& r1b, const Vec3& r2a,
                    const Vec3& r2b, WrapResult& result) {
  const Vec3 r1am = normalized(r1a - p11), r1bm = normalized(r1b - p11);
  const Vec3 r2am = normalized(r2a - p22), r2bm = normalized(r2b - p22);
  const double dot1 = r1am.dot(r2am), dot2 = r1am.dot(r2bm), dot3 = r1bm.dot(r2am), dot4 = r1bm.dot(r2bm);
  if (dot1 > dot2 && dot1 > dot3 && dot1 > dot4)
    result.r1 = r1a, result.r2 = r2a;
  else if (dot2 > dot3 && dot2 > dot4)
    result.r1 = r1a, result.r2 = r2b;
  else if (dot3 > dot4)
    result.r1 = r1b, result.r2 = r2a;
  else
    result.r1 = r1b, result.r2 = r2b;
}

// Slides the tangent points along the axis into the plane through p1, p2 and the apex: the
// cylinder's edge nearest (or, far side, farthest from) the muscle line.
void slideIntoApexPlane(const Vec3& p1, const Vec3& p2, const Vec3& p11, const Vec3& p22, double p11_dist,
                        double p22_dist, double radius, bool far_side_wrap, WrapResult& result) {
  // The apex sits at the axis point under the line point that splits it in the ratio of the end
  // points' distances.
  const Vec3 mpt = p1 + (p11_dist / (p11_dist + p22_dist)) * (p2 - p1);
  double t;
  const Vec3 axispt = closestPointOnLine(mpt, kAxisPoint, kAxis, t);
  const Vec3 plane_normal = normalized(normalized(p1 - axispt).cross(normalized(p2 - axispt)));
  const Vec3 vert1 = normalized(kAxis.cross(plane_normal)), vert2 = normalized(plane_normal.cross(kAxis));
  const Vec3 apex1 = axispt + radius * vert1, apex2 = axispt + radius * vert2;
  const bool first_nearer = (mpt - apex1).squaredNorm() < (mpt - apex2).squaredNorm();
  const Vec3 apex = (first_nearer != far_side_wrap) ? apex1 : apex2;

  const Vec3 n = normalized(normalized(p1 - apex).cross(normalized(p2 - apex)));
  const double d = -p1.dot(n);
  Vec3 r1p, r2p;
  if (intersectSegmentPlane(result.r1 - 10.0 * kAxis, result.r1 + 10.0 * kAxis, n, d, r1p)) {
    const Vec3 foot = closestPointOnLine(r1p, p11, p22, t);  // OpenSim passes p22 as the direction
    if ((foot - p22).squaredNorm() < (p11 - p22).squaredNorm()) result.r1 = r1p;
  }
  if (intersectSegmentPlane(result.r2 - 10.0 * kAxis, result.r2 + 10.0 * kAxis, n, d, r2p)) {
    const Vec3 foot = closestPointOnLine(r2p, p22, p11, t);
    if ((foot - p11).squaredNorm() < (p22 - p11).squaredNorm()) result.r2 = r2p;
  }
}

}  // namespace

WrapStatus wrapCylinder(double radius, double length, int axis, int sign, const Vec3& p1, const Vec3& p2,
                        WrapResult& result) {
  const double r_squared = radius * radius;
  const bool constrained = sign != 0;
  bool far_side_wrap = false, long_wrap = false;
  WrapStatus code = WrapStatus::Wrapped;
  if (distanceSquaredToLine(p1, kAxisPoint, kAxis) < r_squared ||
      distanceSquaredToLine(p2, kAxisPoint, kAxis) < r_squared)
    return WrapStatus::InsideRadius;

  // Closest approach of the segment to the cylinder's (finite) axis.
  const Vec3 cyl_start(0.0, 0.0, -0.5 * length), cyl_end(0.0, 0.0, 0.5 * length);
  Vec3 near12 = Vec3::Constant(NAN), near00 = Vec3::Constant(NAN);
  double t12, t00;
  intersectLines(p1, p2, cyl_start, cyl_end, near12, t12, near00, t00);
  const bool crosses = (near12 - near00).squaredNorm() < r_squared && t12 > 0.0 && t12 < 1.0;
  if (!constrained) {
    if (!crosses) return WrapStatus::NoWrap;
    code = WrapStatus::Mandatory;
  }

  Vec3 p11, p22, r1a, r1b, r2a, r2b;
  double p11_dist, p22_dist;
  tangentCandidates(p1, radius, p11, p11_dist, r1a, r1b);
  tangentCandidates(p2, radius, p22, p22_dist, r2a, r2b);

  if (constrained) {
    if (dsign(p1[axis]) == sign || dsign(p2[axis]) == sign) {
      if (crosses)
        code = WrapStatus::Mandatory;
      else if (dsign(p1[axis]) != dsign(p2[axis]) && dsign(near12[axis]) != sign)
        code = WrapStatus::Wrapped;
      else
        return WrapStatus::NoWrap;
    }
    chooseConstrainedTangents(axis, sign, p1, p2, p11, p22, r1a, r1b, r2a, r2b, result, far_side_wrap, long_wrap);
  } else {
    chooseTangents(p11, p22, r1a, r1b, r2a, r2b, result);
  }
  slideIntoApexPlane(p1, p2, p11, p22, p11_dist, p22_dist, radius, far_side_wrap, result);

  // No wrap when both tangent points lie beyond the cylinder's ends.
  const double half = length / 2.0;
  if ((result.r1.z() < -half || result.r1.z() > half) && (result.r2.z() < -half || result.r2.z() > half))
    return WrapStatus::NoWrap;
  makeSpiralPath(p1, p2, radius, long_wrap, result);
  return code;
}

}  // namespace kneesim::muscle
