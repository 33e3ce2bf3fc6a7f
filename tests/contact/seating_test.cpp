#include "contact/seating.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "contact/shapes.hpp"
#include "core/error.hpp"
#include "core/strings.hpp"
#include "support/test_data.hpp"

namespace kneesim::contact {
namespace {

using Eigen::Vector3d;

// Points of a sphere (centre c, radius r) on a grid of facing angle beta (-20..60 deg about the
// hinge axis z) and tilt gamma (-30..30 deg toward z), in steps of whole degrees, exact normals.
// At a flexion of whole degrees and a tilt of whole degrees the sphere's lowest point is one of them.
std::vector<SurfacePoint> spherePoints(const Vector3d& c, double r, int step_deg) {
  std::vector<SurfacePoint> out;
  for (int b = -20; b <= 60; b += step_deg)
    for (int g = -30; g <= 30; g += step_deg) {
      const double beta = b * kDegree, gamma = g * kDegree;
      // distal -y, posterior +x, axis z (the frame's axis is -z; the tilt's sign does not matter).
      const Vector3d n(std::cos(gamma) * std::sin(beta), -std::cos(gamma) * std::cos(beta), std::sin(gamma));
      out.push_back({c + r * n, n});
    }
  return out;
}

// Two spherical "condyles" centred on the hinge axis z at z = +-25 mm (medial +z), radii r_m, r_l.
SeatingSetup sphereCondyles(double r_m, double r_l, io::TriangleMesh insert, int step_deg = 1) {
  SeatingSetup s;
  const Vector3d cm(0, 0, 0.025), cl(0, 0, -0.025);
  s.femur = test::makeSphere(cm, r_m, 90, 180);
  test::appendMesh(s.femur, test::makeSphere(cl, r_l, 90, 180));
  s.hinge_F.axis = Vector3d::UnitZ();
  s.hinge_F.point = Vector3d::Zero();
  s.femur_medial_F = spherePoints(cm, r_m, step_deg);
  s.femur_lateral_F = spherePoints(cl, r_l, step_deg);
  // Insert points for the two-sided check: the top vertices up to 0.5 mm above y = 0 (a box's
  // top corners, the bottoms of the dishes).
  for (const auto& v : insert.vertices)
    if (v.y() >= -1e-12 && v.y() <= 0.5e-3)
      (v.z() >= 0 ? s.insert_medial_I : s.insert_lateral_I).push_back({v, Vector3d::UnitY()});
  s.insert = std::move(insert);
  return s;
}

TEST(Seating, SpheresOnAPlaneTouchExactly) {
  // Flat insert top at y = 0. Equal spheres: hinge point at height r, no tilt, at any flexion
  // (the spheres are centred on the hinge), and the position is free: the start (the insert's
  // bounding-box centre, x = 2 mm, z = 0) is kept.
  const double r = 0.02;
  SeatingOptions opt;
  opt.tolerance = 1e-11;
  Seater seater(sphereCondyles(r, r, test::makeBox(Vector3d(-0.038, -0.01, -0.05), Vector3d(0.042, 0, 0.05))), opt);
  for (double deg : {0.0, 30.0}) {
    const SeatingResult res = seater.calcSeating(deg * kDegree);
    EXPECT_TRUE(res.converged) << deg;
    EXPECT_NEAR(res.q.p_IH.y(), r, 1e-11) << deg;
    EXPECT_NEAR(res.q.varus, 0.0, 1e-9) << deg;
    EXPECT_NEAR(res.q.p_IH.x(), 0.002, 1e-12) << deg;
    EXPECT_NEAR(res.q.p_IH.z(), 0.0, 1e-12) << deg;
    EXPECT_LE(std::abs(res.gap_medial), 1e-11);
    EXPECT_LE(std::abs(res.gap_lateral), 1e-11);
    // Contact patch: the sphere points within 10 um of the plane, centred under the sphere.
    EXPECT_NEAR(res.contact_medial_I.z(), 0.025, 1e-9);
    EXPECT_NEAR(res.contact_lateral_I.z(), -0.025, 1e-9);
    EXPECT_NEAR(res.contact_medial_I.x(), 0.002, 1e-4);
    EXPECT_GT(res.contact_medial_I.y(), 0.0);
    EXPECT_LT(res.contact_medial_I.y(), 1e-5);
    // The pose turns F by the flexion about -z (superior toward posterior).
    const Vector3d up_F = res.X_IF.linear() * Vector3d::UnitY();
    EXPECT_NEAR(up_F.x(), std::sin(deg * kDegree), 1e-9);
    EXPECT_GT(res.inner_iterations, 0);
  }
}

TEST(Seating, UnequalSpheresTiltInVarusValgus) {
  // Medial sphere 20 mm, lateral 20 mm - 50 sin(2 deg) mm: both touch the plane when the axis
  // through their centres (50 mm apart) tilts by exactly 2 deg, the medial side up, with the
  // hinge point (midway) at the mean radius.
  const double r_m = 0.02, r_l = 0.02 - 0.05 * std::sin(2 * kDegree);
  SeatingOptions opt;
  opt.tolerance = 1e-11;
  Seater seater(sphereCondyles(r_m, r_l, test::makeBox(Vector3d(-0.04, -0.01, -0.05), Vector3d(0.04, 0, 0.05))), opt);
  const SeatingResult res = seater.calcSeating(10 * kDegree);
  EXPECT_TRUE(res.converged);
  EXPECT_NEAR(res.q.varus, -2 * kDegree, 1e-9);  // femur's superior direction tilts laterally
  EXPECT_NEAR(res.q.p_IH.y(), 0.5 * (r_m + r_l), 1e-11);
  EXPECT_LE(std::max(std::abs(res.gap_medial), std::abs(res.gap_lateral)), 1e-11);
}

TEST(Seating, SpheresSettleIntoSphericalDishes) {
  // Insert: a block whose top (y = 8 mm) holds two spherical dishes of radius 25 mm, centres of
  // their spheres at (3, 25, +-25) mm, so the dish bottoms are at (3, 0, +-25) mm. Spheres of
  // radius 20 mm settle with their centres 5 mm above... below the dish centres: hinge point at
  // (3, 20, 0) mm, from a start 5 mm anterior and 1.5 mm medial. The dishes are tessellated at
  // 0.25 mm; the faceted bowl lifts the sphere by about r (1 - cos(0.25 mm / 25 mm / 2 ...)),
  // i.e. < 1 um, and makes the bottom of the potential flat to ~0.05 mm.
  const double Rd = 0.025, r = 0.02, x0 = 0.003;
  const auto top = [&](double x, double z) {
    double y = 0.008;
    for (double zc : {0.025, -0.025}) {
      const double rho2 = (x - x0) * (x - x0) + (z - zc) * (z - zc);
      if (rho2 < Rd * Rd) y = std::min(y, Rd - std::sqrt(Rd * Rd - rho2));
    }
    return y;
  };
  // Grid: 0.25 mm cells within 6 mm of the dish centres (which are nodes), 1 mm cells elsewhere
  // (where the bowl stays 0.18 mm or more below the spheres).
  std::vector<double> xs, zs;
  test::appendNodes(xs, -0.022, x0 - 0.006, 1e-3);
  test::appendNodes(xs, x0 - 0.006, x0 + 0.006, 0.25e-3);
  test::appendNodes(xs, x0 + 0.006, 0.028, 1e-3);
  test::appendNodes(zs, -0.045, -0.031, 1e-3);
  test::appendNodes(zs, -0.031, -0.019, 0.25e-3);
  test::appendNodes(zs, -0.019, 0.019, 1e-3);
  test::appendNodes(zs, 0.019, 0.031, 0.25e-3);
  test::appendNodes(zs, 0.031, 0.045, 1e-3);
  SeatingOptions opt;
  Seater seater(sphereCondyles(r, r, test::makeHeightField(xs, zs, -0.005, top), 2), opt);
  SeatingCoordinates start;
  start.p_IH = Vector3d(x0 - 0.005, 0.03, 0.0015);
  for (double deg : {0.0, 20.0}) {
    const SeatingResult res = seater.calcSeating(deg * kDegree, &start);
    std::printf("[ dish     ] %2.0f deg: hinge (%.4f %.5f %.4f) mm, varus %.5f deg, gaps %.1e %.1e m, %d/%d iterations, "
                "%d distance evaluations\n",
                deg, res.q.p_IH.x() * 1e3, res.q.p_IH.y() * 1e3, res.q.p_IH.z() * 1e3, res.q.varus / kDegree,
                res.gap_medial, res.gap_lateral, res.inner_iterations, res.outer_iterations, res.distance_evaluations);
    EXPECT_TRUE(res.converged) << deg;
    EXPECT_NEAR(res.q.p_IH.y(), r, 1e-6) << deg;
    EXPECT_GE(res.q.p_IH.y(), r - 1e-7) << deg;  // facets lie above the true bowl, never below
    EXPECT_NEAR(res.q.p_IH.x(), x0, 0.05e-3) << deg;
    EXPECT_NEAR(res.q.p_IH.z(), 0.0, 0.05e-3) << deg;
    EXPECT_NEAR(res.q.varus, 0.0, 0.01 * kDegree) << deg;
    EXPECT_LE(std::max(std::abs(res.gap_medial), std::abs(res.gap_lateral)), opt.tolerance) << deg;
  }
  // With internal rotation free, a start rotated by 3 deg turns back: rotating about the vertical
  // through the hinge point moves the two spheres up opposite sides of their dishes, raising the
  // hinge by (25 mm psi)^2 / (2 * 5 mm), only 0.2 um at 0.1 deg, which bounds the precision.
  opt.free_internal_rotation = true;
  Seater free_seater(sphereCondyles(r, r, test::makeHeightField(xs, zs, -0.005, top), 2), opt);
  start.internal = 3 * kDegree;
  const SeatingResult res = free_seater.calcSeating(0.0, &start);
  std::printf("[ dish     ] internal rotation free: %.4f deg, hinge (%.4f %.5f %.4f) mm, %d/%d iterations\n",
              res.q.internal / kDegree, res.q.p_IH.x() * 1e3, res.q.p_IH.y() * 1e3, res.q.p_IH.z() * 1e3,
              res.inner_iterations, res.outer_iterations);
  EXPECT_TRUE(res.converged);
  EXPECT_NEAR(res.q.internal, 0.0, 0.2 * kDegree);
  EXPECT_NEAR(res.q.p_IH.x(), x0, 0.05e-3);
  EXPECT_NEAR(res.q.p_IH.y(), r, 1e-6);
}

TEST(Seating, BadSetupsAreInputErrors) {
  SeatingSetup s = sphereCondyles(0.02, 0.02, test::makeBox(Vector3d(-0.04, -0.01, -0.05), Vector3d(0.04, 0, 0.05)));
  SeatingSetup no_lateral = s;
  no_lateral.femur_lateral_F.clear();
  EXPECT_THROW(Seater{no_lateral}, InputError);
  SeatingSetup zero_axis = s;
  zero_axis.hinge_F.axis.setZero();
  EXPECT_THROW(Seater{zero_axis}, InputError);
  SeatingSetup left = s;
  left.insert_directions.medial = -Vector3d::UnitZ();  // insert of a left knee, femur of a right
  EXPECT_THROW(Seater{left}, InputError);
}

// JW's components. The seated neutral pose puts each condyle's lowest point into its dish: the
// contact lies within ~1 mm (antero-posterior and medio-lateral) of the dish's lowest vertex at
// (6.09, 5.995, +-22.10) mm, and the hinge point sits at the dish bottom's height plus the
// femur's lowest point's depth below the hinge (25.97 mm) plus a few hundredths of a millimetre
// (the contact is beside the exact bottom). With the lowest-potential position, the contact stays
// at the dish bottom at every flexion angle: the femur rolls so its flexion-dependent lowest point
// (distal radius 38.4 mm to 30 deg, posterior 21.8 mm beyond) sits in the dishes; the hinge point
// moves 8 mm antero-posteriorly (x 10.7 mm at 0 deg, 4.7 at 30, 6.4 at 90, 8.1 at 120) and its
// height follows the two radii (32.0, 30.9, 31.6, 30.5 mm).
TEST(Seating, JwImplantNeutralAndHingeKinematics) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/implant/femoral_component.stl");
  const std::string dir = "kgc4-jw/implant/";
  io::TriangleMesh fem = io::readStl(test::dataPath(dir + "femoral_component.stl"), {1.0, true, 0.01, 0.5});
  io::TriangleMesh ins = io::readStl(test::dataPath(dir + "tibial_insert.stl"), {1.0, true, 0.01, 0.5});
  const CondyleFits fits = fitCondyles(fem, ArticularSelection{});

  // Independent references: each dish's lowest upward-facing vertex above y = 4 mm (below it lie
  // the ledges of the insert's rim and locking features), the femur's lowest vertex.
  Vector3d dish[2] = {Vector3d::Constant(1), Vector3d::Constant(1)};
  const auto normals = ins.calcVertexNormals();
  for (int v = 0; v < ins.getNumVertices(); ++v) {
    const Vector3d& p = ins.vertices[v];
    if (normals[v].y() < 0.9 || p.y() < 4e-3) continue;
    Vector3d& d = dish[p.z() >= 0 ? 0 : 1];
    if (p.y() < d.y()) d = p;
  }
  double femur_low = 1;
  for (const auto& p : fem.vertices) femur_low = std::min(femur_low, p.y());
  std::printf("[ JW seat  ] dish bottoms (%.2f %.3f %.2f) and (%.2f %.3f %.2f) mm; femur lowest y %.3f mm\n",
              dish[0].x() * 1e3, dish[0].y() * 1e3, dish[0].z() * 1e3, dish[1].x() * 1e3, dish[1].y() * 1e3,
              dish[1].z() * 1e3, femur_low * 1e3);

  SeatingSetup setup = makeSeatingSetup(std::move(fem), std::move(ins), fits.both.cylinder);
  std::printf("[ JW seat  ] %zu + %zu femoral and %zu + %zu insert articular points\n", setup.femur_medial_F.size(),
              setup.femur_lateral_F.size(), setup.insert_medial_I.size(), setup.insert_lateral_I.size());
  Seater seater(std::move(setup));
  const SeatingResult neutral = seater.calcNeutralSeating();
  const auto report = [](const SeatingResult& r) {
    std::printf("[ JW seat  ] %5.1f deg: hinge (%.3f %.4f %.3f) mm, varus %.4f deg, gaps %.1e / %.1e m, contacts "
                "(%.2f %.3f %.2f) / (%.2f %.3f %.2f) mm, %d+%d iterations, %d evaluations, converged %d\n",
                r.flexion / kDegree, r.q.p_IH.x() * 1e3, r.q.p_IH.y() * 1e3, r.q.p_IH.z() * 1e3, r.q.varus / kDegree,
                r.gap_medial, r.gap_lateral, r.contact_medial_I.x() * 1e3, r.contact_medial_I.y() * 1e3,
                r.contact_medial_I.z() * 1e3, r.contact_lateral_I.x() * 1e3, r.contact_lateral_I.y() * 1e3,
                r.contact_lateral_I.z() * 1e3, r.inner_iterations, r.outer_iterations, r.distance_evaluations,
                r.converged);
  };
  report(neutral);
  EXPECT_TRUE(neutral.converged);
  EXPECT_LE(std::abs(neutral.gap_medial), 1e-7);
  EXPECT_LE(std::abs(neutral.gap_lateral), 1e-7);
  const double depth = fits.both.cylinder.point.y() - femur_low;  // lowest point below the hinge
  EXPECT_NEAR(neutral.q.p_IH.y(), 0.5 * (dish[0].y() + dish[1].y()) + depth, 0.05e-3);
  EXPECT_NEAR(neutral.q.p_IH.z(), 0.0, 0.5e-3);  // a symmetric design sits centred
  EXPECT_NEAR(neutral.q.varus, 0.0, 0.05 * kDegree);
  const Vector3d* contact[2] = {&neutral.contact_medial_I, &neutral.contact_lateral_I};
  for (int s = 0; s < 2; ++s) {
    EXPECT_NEAR(contact[s]->x(), dish[s].x(), 1.5e-3) << s;
    EXPECT_NEAR(contact[s]->z(), dish[s].z(), 1.5e-3) << s;
    EXPECT_NEAR(contact[s]->y(), dish[s].y(), 0.1e-3) << s;
  }

  const std::vector<double> flexions = {0.0, 30 * kDegree, 60 * kDegree, 90 * kDegree, 120 * kDegree};
  const std::vector<SeatingResult> series = seater.calcHingeKinematics(flexions);
  ASSERT_EQ(series.size(), flexions.size());
  for (const auto& r : series) {
    report(r);
    EXPECT_TRUE(r.converged);
    EXPECT_LE(std::max(std::abs(r.gap_medial), std::abs(r.gap_lateral)), 1e-7);
    for (const Vector3d* c : {&r.contact_medial_I, &r.contact_lateral_I}) {
      const Vector3d& d = dish[c->z() >= 0 ? 0 : 1];
      EXPECT_NEAR(c->x(), d.x(), 1.5e-3) << r.flexion / kDegree;
      EXPECT_NEAR(c->z(), d.z(), 1.5e-3) << r.flexion / kDegree;
    }
    EXPECT_NEAR(r.q.varus, 0.0, 0.05 * kDegree);
    // The pose is the hinge: F's axis point lands on p_IH and F is turned by the flexion.
    EXPECT_NEAR((r.X_IF * fits.both.cylinder.point - r.q.p_IH).norm(), 0.0, 1e-12);
    EXPECT_NEAR(std::acos((r.X_IF.linear() * Vector3d::UnitY()).y()), r.flexion, 0.1 * kDegree);
  }
  EXPECT_NEAR(series[0].q.p_IH.x(), neutral.q.p_IH.x(), 0.1e-3);  // warm start or not, same pose
  EXPECT_NEAR(series[0].q.p_IH.y(), neutral.q.p_IH.y(), 1e-6);
  // The hinge point's height follows the condyle radii: lower once the posterior arc is in contact.
  EXPECT_NEAR(series[0].q.p_IH.y() - series[1].q.p_IH.y(), 1.1e-3, 0.1e-3);
  EXPECT_NEAR(series[4].q.p_IH.y(), 30.46e-3, 0.05e-3);

  const std::string out = test::scratchDir("hinge_kinematics") + "/hinge.csv";
  writeHingeKinematics(out, series);
  std::ifstream in(out);
  std::string header, line;
  std::getline(in, header);
  EXPECT_TRUE(startsWith(header, "flexion_deg,p_IH_x_m,p_IH_y_m,p_IH_z_m,varus_deg,internal_deg,gap_medial_m"));
  int rows = 0;
  while (std::getline(in, line)) {
    const auto f = splitOn(line, ',');
    ASSERT_EQ(f.size(), 29u);
    double flex;
    ASSERT_TRUE(tryParseDouble(f[0], flex));
    EXPECT_NEAR(flex, flexions[rows] / kDegree, 1e-9);
    ++rows;
  }
  EXPECT_EQ(rows, 5);
}

}  // namespace
}  // namespace kneesim::contact
