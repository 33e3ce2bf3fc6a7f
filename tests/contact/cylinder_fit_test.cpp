#include "contact/cylinder_fit.hpp"

#include <gtest/gtest.h>

#include <random>

#include "contact/condyle.hpp"
#include "core/error.hpp"
#include "support/test_data.hpp"

namespace kneesim::contact {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

struct Sample {
  std::vector<Vector3d> points, normals;
};

// Points on a patch of the cylinder (axis a through c, radius R): polar angle 0..arc about the
// axis, axial coordinate -len/2..len/2, deterministic pseudo-random positions, optional radial noise.
Sample cylinderPatch(const Vector3d& a, const Vector3d& c, double R, double arc, double len, int n, double noise,
                     unsigned seed) {
  Vector3d e1 = a.unitOrthogonal(), e2 = a.cross(e1);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g(0, noise > 0 ? noise : 1);
  Sample s;
  for (int i = 0; i < n; ++i) {
    const double t = arc * u(rng), h = len * (u(rng) - 0.5);
    const Vector3d radial = std::cos(t) * e1 + std::sin(t) * e2;
    s.points.push_back(c + h * a + (R + (noise > 0 ? g(rng) : 0.0)) * radial);
    s.normals.push_back(radial);
  }
  return s;
}

double distanceToLine(const Vector3d& p, const Cylinder& c) {
  const Vector3d d = p - c.point;
  return (d - d.dot(c.axis) * c.axis).norm();
}

TEST(CylinderFit, RecoversExactCylinderFromPointsAlone) {
  const Vector3d a = Vector3d(0.2, -0.3, 0.93).normalized(), c(0.01, -0.02, 0.005);
  const double R = 0.037;
  for (double arc : {M_PI / 2, 150 * M_PI / 180, 2 * M_PI}) {
    const Sample s = cylinderPatch(a, c, R, arc, 0.045, 1024, 0, 1);
    const CylinderFit f = fitCylinder(s.points);
    EXPECT_NEAR(f.cylinder.radius, R, 1e-12) << arc;
    EXPECT_NEAR(std::abs(f.cylinder.axis.dot(a)), 1.0, 1e-14) << arc;
    EXPECT_LT(distanceToLine(c, f.cylinder), 1e-12) << arc;
    EXPECT_LT(f.errors.max_abs, 1e-12);
    EXPECT_EQ(f.errors.num_points, 1024);
    // The axis point is the one nearest the points' centroid.
    Vector3d centroid = Vector3d::Zero();
    for (const auto& p : s.points) centroid += p;
    centroid /= 1024;
    EXPECT_NEAR(f.cylinder.calcAxialCoordinate(centroid), 0.0, 1e-12);
  }
}

TEST(CylinderFit, RecoversExactCylinderFromNormalsStartAndHonoursAxisGuess) {
  const Vector3d a = Vector3d(-0.1, 0.05, -1).normalized(), c(0.003, 0.004, 0.0);
  const Sample s = cylinderPatch(a, c, 0.025, 120 * M_PI / 180, 0.06, 500, 0, 2);
  const CylinderFit f = fitCylinder(s.points, s.normals);
  EXPECT_NEAR(f.cylinder.radius, 0.025, 1e-12);
  EXPECT_NEAR(f.cylinder.axis.dot(a), -1.0, 1e-14);  // sign rule: largest component (z) positive
  CylinderFitOptions o;
  o.axis_guess = a + Vector3d(0.05, 0.02, 0);  // a rough guess decides the sign
  const CylinderFit g = fitCylinder(s.points, o);
  EXPECT_NEAR(g.cylinder.axis.dot(a), 1.0, 1e-14);
  EXPECT_NEAR(g.cylinder.radius, 0.025, 1e-12);
}

TEST(CylinderFit, NoisyPointsGiveRadiusWithinStatisticalError) {
  // sigma = 0.1 mm radial noise on 1024 points of a 37 mm, 150-degree patch: the radius is
  // determined to a few micrometres and the RMS residual is sigma (less the 5 fitted parameters).
  const Vector3d a = Vector3d::UnitZ(), c(0.002, -0.01, 0);
  const double sigma = 1e-4;
  const Sample s = cylinderPatch(a, c, 0.037, 150 * M_PI / 180, 0.04, 1024, sigma, 3);
  const CylinderFit f = fitCylinder(s.points);
  EXPECT_NEAR(f.cylinder.radius, 0.037, 3e-5);
  EXPECT_NEAR(f.cylinder.axis.z(), 1.0, 1e-4);
  EXPECT_LT(distanceToLine(c, f.cylinder), 5e-5);
  EXPECT_NEAR(f.errors.rms, sigma, 0.1 * sigma);
  EXPECT_NEAR(f.errors.mean_abs, sigma * std::sqrt(2 / M_PI), 0.1 * sigma);
  EXPECT_GT(f.errors.max_abs, 2 * sigma);
}

std::string messageOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(CylinderFit, DegeneratePointSetsGiveOneLineErrors) {
  CylinderFitOptions o;
  o.source = "condyle.stl";
  std::vector<Vector3d> few(3, Vector3d::Zero());
  EXPECT_EQ(messageOf([&] { fitCylinder(few, o); }),
            "condyle.stl: cylinder fit: expected at least 6 points, got 3");
  std::vector<Vector3d> line;
  for (int i = 0; i < 20; ++i) line.push_back(Vector3d(1, 2, 3) * 0.001 * i);
  EXPECT_NE(messageOf([&] { fitCylinder(line, o); }).find("collinear"), std::string::npos);
  std::vector<Vector3d> same(10, Vector3d(0.01, 0.02, 0.03));
  EXPECT_NE(messageOf([&] { fitCylinder(same, o); }).find("coincident"), std::string::npos);
  std::vector<Vector3d> plane;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.02, 0.02);
  for (int i = 0; i < 200; ++i) plane.push_back(Vector3d(u(rng), 0.3 * u(rng), 0.01));
  const std::string flat = messageOf([&] { fitCylinder(plane, o); });
  EXPECT_NE(flat.find("nearly planar"), std::string::npos) << flat;
  EXPECT_EQ(flat.find('\n'), std::string::npos);
  std::vector<Vector3d> bad = cylinderPatch(Vector3d::UnitZ(), Vector3d::Zero(), 0.03, 2, 0.02, 50, 0, 4).points;
  bad[7].x() = std::nan("");
  EXPECT_NE(messageOf([&] { fitCylinder(bad, o); }).find("index 7"), std::string::npos);
  std::vector<Vector3d> normals(5, Vector3d::UnitX());
  EXPECT_NE(messageOf([&] { fitCylinder(plane, normals, o); }).find("one normal per point"), std::string::npos);
}

TEST(CircleFit, ExactArcAndDegenerateSets) {
  std::vector<Vector2d> arc;
  for (int i = 0; i <= 20; ++i) {
    const double t = 0.3 + 0.02 * i;  // a 23-degree arc
    arc.push_back(Vector2d(0.004, -0.007) + 0.0218 * Vector2d(std::cos(t), std::sin(t)));
  }
  const CircleFit f = fitCircle(arc, "profile");
  EXPECT_NEAR(f.circle.radius, 0.0218, 1e-13);
  EXPECT_NEAR((f.circle.center - Vector2d(0.004, -0.007)).norm(), 0.0, 1e-13);
  EXPECT_LT(f.errors.max_abs, 1e-14);
  std::vector<Vector2d> line = {{0, 0}, {1, 1}, {2, 2}, {3, 3}};
  EXPECT_NE(messageOf([&] { fitCircle(line, "profile"); }).find("collinear"), std::string::npos);
  EXPECT_NE(messageOf([&] { fitCircle({{0, 0}, {1, 0}}, "profile"); }).find("at least 3"), std::string::npos);
}

// JW's femoral component (Dao & Pouletaut 2015, section 3.1: R = 37 mm, mean error 1.652 mm from
// 1024 points). Our figures differ because the component is a two-radius (J-curve) design: the
// sagittal profile has R ~ 38.4 mm over the distal arc (facing 0..30 deg) and R ~ 21.8 mm over the
// posterior arc (45..120 deg) (see condyle_test.cpp). One cylinder through both arcs therefore
// lands between them, where the selection weights it:
//  - default rule (facing 0..120 deg, crest normals within 20 deg of the sagittal plane, 1024
//    points, 512 per condyle): R = 24.98 mm, mean error 0.449 mm, max 1.48 mm. The narrow crest
//    band of the distal arc (it is curved medio-laterally) gives few points; the posterior arc,
//    flat medio-laterally, gives many, so R is near the posterior radius;
//  - the distal region at full condyle width (facing -30..60 deg, any tilt): R = 35.8 mm, close
//    to the paper's 37 mm, with mean error 0.76 mm. The paper's larger error (1.652 mm) suggests
//    even more of the surface (flanks, anterior or posterior arcs), which the paper does not state.
// The radius moves by ~0.2 mm with the sampled subset (512 vs 713 points per condyle), so the
// tolerances below are 0.1-0.3 mm.
TEST(CylinderFit, JwFemoralComponent) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/implant/femoral_component.stl");
  const io::TriangleMesh fem =
      io::readStl(test::dataPath("kgc4-jw/implant/femoral_component.stl"), {1.0, true, 0.01, 0.5});
  ArticularSelection sel;  // defaults: 1024 points, facing 0..120 deg, tilt <= 20 deg
  const CondyleFits f = fitCondyles(fem, sel);
  const auto report = [](const char* name, const CylinderFit& c) {
    std::printf("[ JW fit   ] %-8s R = %.3f mm, axis (%.4f %.4f %.4f), point (%.3f %.3f %.3f) mm, mean %.3f, max %.3f, "
                "rms %.3f mm, %d points, %d iterations\n",
                name, c.cylinder.radius * 1e3, c.cylinder.axis.x(), c.cylinder.axis.y(), c.cylinder.axis.z(),
                c.cylinder.point.x() * 1e3, c.cylinder.point.y() * 1e3, c.cylinder.point.z() * 1e3,
                c.errors.mean_abs * 1e3, c.errors.max_abs * 1e3, c.errors.rms * 1e3, c.errors.num_points, c.iterations);
  };
  report("both", f.both);
  report("medial", f.medial);
  report("lateral", f.lateral);
  EXPECT_EQ(f.both.errors.num_points, 1024);
  EXPECT_EQ(f.medial.errors.num_points, 512);
  EXPECT_NEAR(f.both.cylinder.radius, 24.98e-3, 0.1e-3);
  EXPECT_NEAR(f.both.errors.mean_abs, 0.449e-3, 0.03e-3);
  EXPECT_NEAR(f.both.errors.max_abs, 1.48e-3, 0.1e-3);
  // The hinge is the medial-lateral axis (flexion sense: superior x posterior = -z) through the
  // posterior condyles' region, behind and above the distal arc's centre.
  EXPECT_GT(-f.both.cylinder.axis.z(), std::cos(0.2 * kDegree));
  EXPECT_NEAR(f.both.cylinder.point.x(), 9.25e-3, 0.3e-3);
  EXPECT_NEAR(f.both.cylinder.point.y(), -10.53e-3, 0.3e-3);
  EXPECT_NEAR(f.both.cylinder.point.z(), 0.0, 0.5e-3);
  // The condyles are alike (a symmetric design): same radius, coaxial within a degree.
  for (const CylinderFit* c : {&f.medial, &f.lateral}) {
    EXPECT_NEAR(c->cylinder.radius, 24.98e-3, 0.15e-3);
    EXPECT_GT(-c->cylinder.axis.z(), std::cos(1.0 * kDegree));
    EXPECT_LT(distanceToLine(c->cylinder.point, f.both.cylinder), 0.3e-3);
  }
  EXPECT_GT(f.medial.cylinder.point.z(), 0.02);  // medial condyle at +z
  EXPECT_LT(f.lateral.cylinder.point.z(), -0.02);

  ArticularSelection distal = sel;
  distal.min_facing_angle = -30 * kDegree;
  distal.max_facing_angle = 60 * kDegree;
  distal.max_normal_tilt = 90 * kDegree;
  const CondyleFits d = fitCondyles(fem, distal);
  report("distal", d.both);
  EXPECT_NEAR(d.both.cylinder.radius, 35.8e-3, 0.3e-3);
  EXPECT_NEAR(d.both.errors.mean_abs, 0.76e-3, 0.05e-3);
}

}  // namespace
}  // namespace kneesim::contact
