#include "contact/condyle.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "contact/shapes.hpp"
#include "core/error.hpp"
#include "core/strings.hpp"
#include "support/test_data.hpp"

namespace kneesim::contact {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

// Unit direction of facing angle phi in the JW component frame (x posterior, y superior).
Vector2d facing(double phi) { return Vector2d(std::sin(phi), -std::cos(phi)); }

// A prism whose sagittal (x, y) profile is a tangent-continuous J-curve: radius r1 about the origin
// for facing angles -30..30 deg, radius r2 beyond, to 150 deg, closed by the chord; extruded along z
// over -10..10 mm with vertex rings at z = -10, 0, 10 mm. Returns the centre of the second arc.
io::TriangleMesh makeJCurvePrism(double r1, double r2, Vector2d& c2) {
  c2 = (r1 - r2) * facing(30 * kDegree);
  std::vector<Vector2d> profile;
  const double step = 0.5 * kDegree;
  for (int i = 0; i <= 120; ++i) profile.push_back(r1 * facing(-30 * kDegree + i * step));
  for (int i = 1; i <= 240; ++i) profile.push_back(c2 + r2 * facing(30 * kDegree + i * step));
  const int n = int(profile.size());
  io::TriangleMesh m;
  m.source_file = "j-curve prism";
  const double zs[3] = {-0.01, 0.0, 0.01};
  for (double z : zs)
    for (const auto& p : profile) m.vertices.emplace_back(p.x(), p.y(), z);
  Vector2d centroid = Vector2d::Zero();
  for (const auto& p : profile) centroid += p;
  centroid /= n;
  const int c_lo = int(m.vertices.size());
  m.vertices.emplace_back(centroid.x(), centroid.y(), zs[0]);
  m.vertices.emplace_back(centroid.x(), centroid.y(), zs[2]);
  auto V = [&](int ring, int i) { return ring * n + (i % n); };
  // The profile runs counter-clockwise seen from +z (facing angle grows from distal to posterior,
  // i.e. from -y to +x), so the +z cap is (centre, i, i+1) and the sides (i, i+1) go outward.
  for (int i = 0; i < n; ++i) {
    for (int ring = 0; ring < 2; ++ring) {
      m.triangles.emplace_back(V(ring, i), V(ring, i + 1), V(ring + 1, i + 1));
      m.triangles.emplace_back(V(ring, i), V(ring + 1, i + 1), V(ring + 1, i));
    }
    m.triangles.emplace_back(c_lo + 1, V(2, i), V(2, i + 1));
    m.triangles.emplace_back(c_lo, V(0, i + 1), V(0, i));
  }
  return m;
}

TEST(SagittalRadius, RecoversBothRadiiOfAJCurve) {
  const double r1 = 0.040, r2 = 0.020;
  Vector2d c2;
  const io::TriangleMesh prism = makeJCurvePrism(r1, r2, c2);
  ASSERT_EQ(prism.calcEdgeReport().open, 0);
  ASSERT_GT(prism.calcVolume(), 0);
  Cylinder hinge;  // the hinge through the posterior arc's centre, along z
  hinge.axis = Vector3d::UnitZ();
  hinge.point = Vector3d(c2.x(), c2.y(), 0);
  const ComponentDirections dirs;
  const SagittalFrame frame = SagittalFrame::fromHinge(hinge, dirs);
  EXPECT_NEAR(frame.axis.z(), -1.0, 1e-15);  // flexion sense: superior x posterior
  EXPECT_NEAR(frame.posterior.x(), 1.0, 1e-15);
  SagittalRadiusOptions opt;
  opt.profile_axial = 0.0;
  const SagittalRadiusTable t = calcSagittalRadii(prism, frame, dirs.medial, CondyleSide::both, opt);
  ASSERT_EQ(t.samples.size(), 25u);  // 0, 5, ..., 120 deg
  for (const auto& s : t.samples) {
    const double deg = s.flexion / kDegree;
    if (deg <= 20 + 1e-9) {  // window within the distal arc
      EXPECT_NEAR(s.radius, r1, 1e-12) << deg;
      EXPECT_NEAR((s.center - frame.calcProfileCoordinates(Vector3d::Zero())).norm(), 0.0, 1e-12) << deg;
    } else if (deg >= 40 - 1e-9) {  // window within the posterior arc
      EXPECT_NEAR(s.radius, r2, 1e-12) << deg;
      EXPECT_NEAR(s.center.norm(), 0.0, 1e-12) << deg;  // the hinge is the posterior centre
    } else {  // windows straddling the 30-degree transition see both radii
      EXPECT_GT(s.radius, r2) << deg;
      EXPECT_LT(s.radius, r1) << deg;
    }
    EXPECT_GE(s.errors.num_points, 8) << deg;
  }
}

TEST(Directions, RotationsAndValidation) {
  ComponentDirections a, b;
  b.posterior = Vector3d(0, 0, -1);  // a frame rotated 90 deg about y
  b.medial = Vector3d(1, 0, 0);
  const Eigen::Matrix3d R = a.calcRotationTo(b);
  EXPECT_NEAR((R * a.posterior - b.posterior).norm(), 0, 1e-15);
  EXPECT_NEAR((R * a.medial - b.medial).norm(), 0, 1e-15);
  EXPECT_NEAR(R.determinant(), 1, 1e-15);
  ComponentDirections left;
  left.medial = -Vector3d::UnitZ();
  EXPECT_THROW(a.calcRotationTo(left), InputError);
  EXPECT_NEAR((left.calcFlexionAxis() - a.calcFlexionAxis()).norm(), 0, 1e-15);  // same for both sides
  ComponentDirections skew;
  skew.superior = Vector3d(1, 0.1, 0);
  EXPECT_THROW(skew.validate("x.stl"), InputError);
  EXPECT_NO_THROW(a.validate("x.stl"));
  // Orthonormalised by hand: superior (0, 2, 0) -> y; posterior (1, 0.1, 0) loses its y part -> x;
  // medial (0.1, 0, -3) keeps its side -> -z, so this left knee's basis is left-handed.
  ComponentDirections tilted;
  tilted.posterior = Vector3d(1, 0.1, 0);
  tilted.superior = Vector3d(0, 2, 0);
  tilted.medial = Vector3d(0.1, 0, -3);
  Eigen::Matrix3d expected;
  expected << 1, 0, 0, 0, 1, 0, 0, 0, -1;
  EXPECT_NEAR((tilted.calcOrthonormalBasis() - expected).norm(), 0, 1e-15);
}

io::TriangleMesh readJwFemur() {
  return io::readStl(test::dataPath("kgc4-jw/implant/femoral_component.stl"), {1.0, true, 0.01, 0.5});
}

TEST(ArticularPoints, JwSelectionFollowsTheRule) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/implant/femoral_component.stl");
  const io::TriangleMesh fem = readJwFemur();
  ArticularSelection sel;
  sel.side = CondyleSide::medial;
  sel.max_points = 300;
  const std::vector<SurfacePoint> pts = selectArticularPoints(fem, sel);
  ASSERT_EQ(pts.size(), 300u);
  const SagittalFrame frame = SagittalFrame::fromDirections(sel.directions, Vector3d::Zero());
  for (const auto& s : pts) {
    EXPECT_GE(frame.calcFacingAngle(s.n), -1e-12);
    EXPECT_LE(frame.calcFacingAngle(s.n), 120 * kDegree + 1e-12);
    EXPECT_LE(frame.calcNormalTilt(s.n), 20 * kDegree + 1e-12);
    // On the medial condyle (z 15..29 mm), never in the intercondylar notch or on the pegs' axis band.
    EXPECT_GT(s.p.z(), 0.015);
    EXPECT_LT(s.p.z(), 0.030);
    // On the outer J-curve: below the distal arc (y < -20 mm) or behind the inner posterior cut (x > 28 mm).
    EXPECT_TRUE(s.p.y() < -0.020 || s.p.x() > 0.028) << s.p.transpose();
  }
  // max_points = 0 keeps every qualifying vertex.
  sel.max_points = 0;
  const size_t all = selectArticularPoints(fem, sel).size();
  EXPECT_GT(all, 600u);
  EXPECT_LT(all, 800u);
  // A box has only corner vertices, whose normals tilt at least 19 deg out of the sagittal plane.
  ArticularSelection crest;
  crest.max_normal_tilt = 10 * kDegree;
  EXPECT_THROW(selectArticularPoints(test::makeBox(Vector3d::Zero(), Vector3d::Constant(0.02)), crest), InputError);
  io::TriangleMesh empty;
  empty.source_file = "empty.stl";
  EXPECT_THROW(selectArticularPoints(empty, ArticularSelection{}), InputError);
}

// JW's component is a two-radius design: R = 38.4 mm over the distal arc and 21.8 mm over the
// posterior arc, alike on both condyles; the transition lies between 30 and 40 deg. Windows that
// catch only a few tessellation lines of the posterior arc scatter by a few tenths of a mm.
TEST(SagittalRadius, JwTwoRadiusCondyles) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/implant/femoral_component.stl");
  const io::TriangleMesh fem = readJwFemur();
  const CondyleFits fits = fitCondyles(fem, ArticularSelection{});
  const ComponentDirections dirs;
  const SagittalFrame frame = SagittalFrame::fromHinge(fits.both.cylinder, dirs);
  std::vector<SagittalRadiusTable> tables;
  for (CondyleSide side : {CondyleSide::medial, CondyleSide::lateral}) {
    tables.push_back(calcSagittalRadii(fem, frame, dirs.medial, side));
    const SagittalRadiusTable& t = tables.back();
    std::printf("[ JW R(th) ] %s condyle, profile plane %.2f mm from the hinge point along the flexion axis\n",
                toString(side), t.profile_axial * 1e3);
    for (const auto& s : t.samples)
      std::printf("[ JW R(th) ]   %5.1f deg  R = %7.3f mm  centre (%.2f, %.2f) mm  rms %.4f mm  n = %d\n",
                  s.flexion / kDegree, s.radius * 1e3, s.center.x() * 1e3, s.center.y() * 1e3, s.errors.rms * 1e3,
                  s.errors.num_points);
    // The crest of each condyle lies about 22 mm from the midplane (the flexion axis is -z).
    EXPECT_NEAR(std::abs(t.profile_axial), 21.7e-3, 0.5e-3);
    EXPECT_EQ(t.profile_axial < 0, side == CondyleSide::medial);
    ASSERT_EQ(t.samples.size(), 25u);
    for (const auto& s : t.samples) {
      const double deg = s.flexion / kDegree;
      if (deg <= 25 + 1e-9) {
        EXPECT_NEAR(s.radius, 38.3e-3, 0.4e-3) << deg;
      }
      if (deg >= 45 - 1e-9) {
        EXPECT_NEAR(s.radius, 21.8e-3, 0.5e-3) << deg;
      }
      EXPECT_LT(s.errors.rms, 0.05e-3) << deg;  // residuals of 10..35 micrometres: the profile is smooth
    }
  }
  const std::string dir = test::scratchDir("sagittal_radius");
  writeSagittalRadiusTable(dir + "/r.csv", tables);
  std::ifstream in(dir + "/r.csv");
  std::string header, first;
  std::getline(in, header);
  std::getline(in, first);
  EXPECT_EQ(header,
            "flexion_deg,R_medial_m,cx_medial_m,cy_medial_m,rms_medial_m,n_medial,R_lateral_m,cx_lateral_m,cy_lateral_m,"
            "rms_lateral_m,n_lateral");
  const auto fields = splitOn(first, ',');
  ASSERT_EQ(fields.size(), 11u);
  EXPECT_EQ(fields[0], "0");
  double r0;
  ASSERT_TRUE(tryParseDouble(fields[1], r0));
  // Ten significant digits of a 38 mm radius: the last one is 1e-11 m.
  EXPECT_NEAR(r0, tables[0].samples[0].radius, 1e-11);
}

}  // namespace
}  // namespace kneesim::contact
