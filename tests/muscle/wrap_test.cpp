// The wrap algorithms against closed-form geodesics: a segment wrapping a circle (cylinder cross
// section, sphere great circle, torus tube section) is two tangents and an arc; on a cylinder a
// helix unrolls to a straight line; an ellipsoid cut by a symmetry plane is an ellipse arc,
// integrated here by Simpson's rule.
#include "muscle/wrap.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace kneesim;
using muscle::Vec3;
using muscle::WrapResult;
using muscle::WrapStatus;
using model::WrapMethod;

namespace {

/// Length of the shortest path from @p p1 to @p p2 (2-D, outside the circle of radius @p r at
/// @p c) that goes round the circle turning in direction @p turn (+1 counter-clockwise).
double circleWrapLength(const Eigen::Vector2d& p1, const Eigen::Vector2d& p2, const Eigen::Vector2d& c, double r,
                        int turn) {
  const Eigen::Vector2d d1 = p1 - c, d2 = p2 - c;
  const double a1 = std::atan2(d1.y(), d1.x()), a2 = std::atan2(d2.y(), d2.x());
  double span = turn * (a2 - a1);
  while (span < 0) span += 2 * M_PI;
  while (span >= 2 * M_PI) span -= 2 * M_PI;
  const double arc = span - std::acos(r / d1.norm()) - std::acos(r / d2.norm());
  return std::sqrt(d1.squaredNorm() - r * r) + std::sqrt(d2.squaredNorm() - r * r) + r * arc;
}

double totalLength(const Vec3& p1, const Vec3& p2, const WrapResult& w) {
  return (w.r1 - p1).norm() + w.length + (p2 - w.r2).norm();
}

}  // namespace

TEST(WrapCylinder, SegmentAcrossTheAxisIsTwoTangentsAndAnArc) {
  const double R = 0.02;
  const Vec3 p1(-0.1, 0.005, 0.0), p2(0.12, 0.008, 0.0);
  WrapResult w;
  ASSERT_EQ(muscle::wrapCylinder(R, 0.2, 0, 0, p1, p2, w), WrapStatus::Mandatory);
  // The segment passes above the axis (y > 0): the path turns clockwise over the top.
  const double expected = circleWrapLength({p1.x(), p1.y()}, {p2.x(), p2.y()}, {0, 0}, R, -1);
  EXPECT_NEAR(totalLength(p1, p2, w), expected, 1e-9);
  EXPECT_NEAR(std::hypot(w.r1.x(), w.r1.y()), R, 1e-12);
  EXPECT_GT(w.r1.y(), 0);
}

TEST(WrapCylinder, HelixUnrollsToAStraightLine) {
  // Points at different heights: the geodesic unrolls to the hypotenuse of the planar length
  // and the height difference. OpenSim slides the tangent points until the straight segments
  // meet the helix within 0.1 degree: the length agrees to 0.1 um (0.15 um without that adjustment).
  const double R = 0.02;
  const Vec3 p1(-0.08, 0.004, -0.03), p2(0.09, 0.006, 0.05);
  WrapResult w;
  ASSERT_EQ(muscle::wrapCylinder(R, 0.5, 0, 0, p1, p2, w), WrapStatus::Mandatory);
  const double planar = circleWrapLength({p1.x(), p1.y()}, {p2.x(), p2.y()}, {0, 0}, R, -1);
  EXPECT_NEAR(totalLength(p1, p2, w), std::hypot(planar, p2.z() - p1.z()), 1e-7);
}

TEST(WrapCylinder, QuadrantForcesTheLongWayRound) {
  // The segment misses the unit cylinder below it (y < 0), but only the +y half may be used:
  // OpenSim wraps round the +y side, clockwise from p1 (at 170 degrees) to p2 (at -49 degrees).
  const Vec3 p1(-3.0, 0.5, 0.0), p2(3.0, -3.5, 0.0);
  WrapResult w;
  EXPECT_EQ(muscle::wrapCylinder(1.0, 10.0, 0, 0, p1, p2, w), WrapStatus::NoWrap);
  ASSERT_EQ(muscle::wrapCylinder(1.0, 10.0, 1, 1, p1, p2, w), WrapStatus::Wrapped);
  EXPECT_NEAR(totalLength(p1, p2, w), circleWrapLength({-3, 0.5}, {3, -3.5}, {0, 0}, 1.0, -1), 1e-9);
  EXPECT_GT(w.r1.y(), 0);
}

TEST(WrapCylinder, EndPointInsideIsNotAWrap) {
  WrapResult w;
  EXPECT_EQ(muscle::wrapCylinder(0.02, 0.2, 0, 0, Vec3(0.01, 0, 0), Vec3(0.1, 0.1, 0), w), WrapStatus::InsideRadius);
  // Tangent points beyond both ends of the cylinder's length: no wrap.
  EXPECT_EQ(muscle::wrapCylinder(0.02, 0.02, 0, 0, Vec3(-0.1, 0.005, 0.3), Vec3(0.1, 0.005, 0.3), w),
            WrapStatus::NoWrap);
}

TEST(WrapSphere, GreatCircleInATiltedPlane) {
  // p1 and p2 span a plane through the centre; the geodesic is the great circle in it.
  const double R = 0.03;
  const Vec3 e1 = Vec3(1, 2, 0.5).normalized(), e2 = e1.cross(Vec3(0.3, -0.2, 1)).normalized();
  const Vec3 p1 = -0.09 * e1 + 0.01 * e2, p2 = 0.11 * e1 + 0.012 * e2;
  WrapResult w;
  ASSERT_EQ(muscle::wrapSphere(R, 0, 0, p1, p2, w), WrapStatus::Wrapped);
  const double expected = circleWrapLength({-0.09, 0.01}, {0.11, 0.012}, {0, 0}, R, -1);
  EXPECT_NEAR(totalLength(p1, p2, w), expected, 1e-9);
  EXPECT_NEAR(w.r1.norm(), R, 1e-12);
}

TEST(WrapEllipsoid, EqualRadiiMatchTheSphere) {
  const double R = 0.03;
  const Vec3 e1 = Vec3(1, 2, 0.5).normalized(), e2 = e1.cross(Vec3(0.3, -0.2, 1)).normalized();
  const Vec3 p1 = -0.09 * e1 + 0.01 * e2, p2 = 0.11 * e1 + 0.012 * e2;
  const double expected = circleWrapLength({-0.09, 0.01}, {0.11, 0.012}, {0, 0}, R, -1);
  for (WrapMethod method : {WrapMethod::Hybrid, WrapMethod::Midpoint, WrapMethod::Axial}) {
    WrapResult w;
    ASSERT_EQ(muscle::wrapEllipsoid(Vec3(R, R, R), method, 0, 0, p1, p2, w), WrapStatus::Mandatory);
    // 1 mm chords on a 30 mm radius shorten the arc by about R theta^3 / 24 per chord.
    EXPECT_NEAR(totalLength(p1, p2, w), expected, 2e-6) << int(method);
  }
}

TEST(WrapEllipsoid, SymmetryPlaneSectionIsAnEllipseArc) {
  // Segment in the plane z = 0 of an ellipsoid: the path stays in that plane and follows the
  // ellipse (x/a)^2 + (y/b)^2 = 1 between the tangent points.
  const double a = 0.04, b = 0.025, c = 0.03;
  const Eigen::Vector2d P1(-0.09, 0.012), P2(0.1, 0.004);
  // Tangent point from P: a cos t Px / a^2 + b sin t Py / b^2 = 1, on the side y > 0.
  auto tangentAngle = [&](const Eigen::Vector2d& P, int pick) {
    const double A = P.x() / a, B = P.y() / b;
    return std::atan2(B, A) + pick * std::acos(1.0 / std::hypot(A, B));
  };
  auto point = [&](double t) { return Eigen::Vector2d(a * std::cos(t), b * std::sin(t)); };
  double t1 = tangentAngle(P1, -1), t2 = tangentAngle(P2, 1);
  if (point(t1).y() < 0) t1 = tangentAngle(P1, 1);
  if (point(t2).y() < 0) t2 = tangentAngle(P2, -1);
  while (t1 < t2) t1 -= 2 * M_PI;
  while (t1 - t2 > 2 * M_PI) t1 -= 2 * M_PI;
  // Arc length from t2 to t1 by Simpson's rule.
  const int n = 20000;
  double s = 0;
  for (int i = 0; i <= n; ++i) {
    const double t = t2 + (t1 - t2) * i / n;
    const double f = std::hypot(a * std::sin(t), b * std::cos(t));
    s += f * (i == 0 || i == n ? 1 : (i % 2 ? 4 : 2));
  }
  const double arc = s * (t1 - t2) / n / 3;
  const double expected = (point(t1) - P1).norm() + arc + (P2 - point(t2)).norm();
  const Vec3 p1(P1.x(), P1.y(), 0), p2(P2.x(), P2.y(), 0);
  for (WrapMethod method : {WrapMethod::Hybrid, WrapMethod::Midpoint}) {
    WrapResult w;
    ASSERT_EQ(muscle::wrapEllipsoid(Vec3(a, b, c), method, 0, 0, p1, p2, w), WrapStatus::Mandatory);
    EXPECT_NEAR(w.r1.z(), 0.0, 1e-9);
    EXPECT_NEAR(totalLength(p1, p2, w), expected, 2e-6) << int(method);
  }
}

TEST(WrapEllipsoid, MissingSegmentAndInsidePoint) {
  WrapResult w;
  const Vec3 radii(0.04, 0.025, 0.03);
  EXPECT_EQ(muscle::wrapEllipsoid(radii, WrapMethod::Hybrid, 0, 0, Vec3(-0.1, 0.05, 0), Vec3(0.1, 0.05, 0), w),
            WrapStatus::NoWrap);
  EXPECT_EQ(muscle::wrapEllipsoid(radii, WrapMethod::Hybrid, 0, 0, Vec3(0.01, 0, 0), Vec3(0.1, 0.05, 0), w),
            WrapStatus::InsideRadius);
}

TEST(WrapTorus, SegmentThroughTheTubeWrapsItsInnerSide) {
  // Torus: tube radius r round the circle of radius R in z = 0. A vertical segment at x0
  // between R - r and R, in the plane y = 0, wraps the tube's circle of centre (R, 0, 0) on its
  // side towards the torus's axis.
  const double r = 0.01, R = 0.05, x0 = 0.045;
  const Vec3 p1(x0, 0, 0.06), p2(x0, 0, -0.05);
  WrapResult w;
  ASSERT_EQ(muscle::wrapTorus(r, R, 0, 0, p1, p2, w), WrapStatus::Wrapped);
  // In the (x, z) plane: from (x0, 0.06) round the left of (R, 0) to (x0, -0.05), counter-clockwise.
  const double expected = circleWrapLength({x0, 0.06}, {x0, -0.05}, {R, 0}, r, 1);
  EXPECT_NEAR(totalLength(p1, p2, w), expected, 1e-6);
  EXPECT_LT(w.r1.x(), R);
}
