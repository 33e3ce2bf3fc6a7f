// ExternalLoads: reading OpenSim's file, where the loads act (hand-derived moments), the
// interpolation, and one-line errors for bad input.
#include "dynamics/external_loads.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "model/osim_reader.hpp"
#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim::dynamics {
namespace {

using model::Vec3;

const std::string kDir = test::dataPath("opensim-dynamics-tests/id/");

TEST(ExternalLoads, ReadsOpenSimsFile) {
  const ExternalLoadsSpec s = readExternalLoads(kDir + "subject01_walk1_grf.xml");
  ASSERT_EQ(s.forces.size(), 2u);
  EXPECT_EQ(s.forces[0].name, "RightForce");
  EXPECT_EQ(s.forces[0].applied_to_body, "calcn_r");
  EXPECT_EQ(s.forces[1].force_identifier, "l_ground_force_v");
  EXPECT_EQ(s.forces[1].torque_identifier, "l_ground_torque");
  EXPECT_EQ(s.datafile, kDir + "subject01_walk1_grf.mot");
  // The formatted file reads back the same.
  const std::string out = test::scratchDir("external_loads_format") + "/grf.xml";
  std::ofstream(out) << formatExternalLoads(s, "subject01_walk1_grf.mot");
  const ExternalLoadsSpec r = readExternalLoads(out);
  ASSERT_EQ(r.forces.size(), 2u);
  EXPECT_EQ(r.forces[1].point_identifier, "l_ground_force_p");
  EXPECT_EQ(r.forces[0].point_expressed_in_body, "ground");
}

/// A row of force data: time, force (3), point (3), torque (3).
io::Storage oneForce(const std::vector<std::array<double, 10>>& rows) {
  io::Storage s;
  s.labels = {"time", "f_vx", "f_vy", "f_vz", "f_px", "f_py", "f_pz", "f_tx", "f_ty", "f_tz"};
  s.data.resize(rows.size(), 10);
  for (size_t r = 0; r < rows.size(); ++r)
    for (int c = 0; c < 10; ++c) s.data(r, c) = rows[r][c];
  return s;
}

ExternalLoadsSpec specOn(const std::string& body, const std::string& point_in = "ground") {
  ExternalLoadsSpec s;
  s.datafile = "grf.mot";
  ExternalForceSpec f;
  f.name = "F";
  f.applied_to_body = body;
  f.point_expressed_in_body = point_in;
  f.force_identifier = "f_v";
  f.point_identifier = "f_p";
  f.torque_identifier = "f_t";
  s.forces.push_back(f);
  return s;
}

TEST(ExternalLoads, ActsAtItsPointWithItsTorque) {
  auto model = model::readOsim(kDir + "subject01.osim");
  sim::System sys(model);
  auto ws = sys.createWorkspace();
  const int calcn = model->findBody("calcn_r");
  const ExternalLoads loads(specOn("calcn_r"), *model, oneForce({{0, 10, 700, -5, 0.4, 0.0, 0.1, 0, 3, 0}}));
  sys.realizePosition(*ws, sys.getDefaultCoordinates());
  sim::SpatialColumns F = sim::SpatialColumns::Zero(6, model->bodies.size());
  loads.addBodyForces(sys, *ws, 0.0, F);
  const Vec3 p_B = sys.getBodyPose(*ws, calcn).translation();
  const Vec3 f(10, 700, -5);
  EXPECT_LT((Vec3(F.col(calcn).tail<3>()) - f).norm(), 1e-12);
  EXPECT_LT((Vec3(F.col(calcn).head<3>()) - ((Vec3(0.4, 0, 0.1) - p_B).cross(f) + Vec3(0, 3, 0))).norm(), 1e-12);
  EXPECT_EQ(F.leftCols(calcn).norm() + F.rightCols(F.cols() - calcn - 1).norm(), 0.0);
}

TEST(ExternalLoads, PointInABodyMovesWithIt) {
  auto model = model::readOsim(kDir + "subject01.osim");
  sim::System sys(model);
  auto ws = sys.createWorkspace();
  const int tibia = model->findBody("tibia_r"), calcn = model->findBody("calcn_r");
  const ExternalLoads loads(specOn("calcn_r", "tibia_r"), *model, oneForce({{0, 0, 100, 0, 0.01, -0.3, 0.02, 0, 0, 0}}));
  Eigen::VectorXd q = sys.getDefaultCoordinates();
  q[model->findCoordinate("knee_angle_r")] = -0.8;
  sys.realizePosition(*ws, q);
  Vec3 force, point, torque;
  loads.calcForceInGround(sys, *ws, 0, 0.0, force, point, torque);
  EXPECT_LT((point - sys.getBodyPose(*ws, tibia) * Vec3(0.01, -0.3, 0.02)).norm(), 1e-12);
  sim::SpatialColumns F = sim::SpatialColumns::Zero(6, model->bodies.size());
  loads.addBodyForces(sys, *ws, 0.0, F);
  EXPECT_LT((Vec3(F.col(calcn).head<3>()) - (point - sys.getBodyPose(*ws, calcn).translation()).cross(force)).norm(), 1e-12);
}

TEST(ExternalLoads, InterpolatesWithNaturalCubicSplines) {
  auto model = model::readOsim(kDir + "subject01.osim");
  sim::System sys(model);
  auto ws = sys.createWorkspace();
  // Force y = t^2 sampled at 0..5: a natural cubic spline is exact only where its end
  // conditions hold; halfway between knots in the middle it is within 1e-2 of t^2, and exact
  // at the knots. With 2 rows the force is linear between them.
  std::vector<std::array<double, 10>> rows;
  for (int i = 0; i <= 5; ++i) rows.push_back({double(i), 0, double(i * i), 0, 0, 0, 0, 0, 0, 0});
  const ExternalLoads loads(specOn("calcn_r"), *model, oneForce(rows));
  Vec3 f, p, m;
  loads.calcForceInGround(sys, *ws, 0, 3.0, f, p, m);
  EXPECT_NEAR(f.y(), 9.0, 1e-12);
  loads.calcForceInGround(sys, *ws, 0, 2.5, f, p, m);
  EXPECT_NEAR(f.y(), 6.25, 2e-2);
  EXPECT_NE(f.y(), 6.25);
  const ExternalLoads two(specOn("calcn_r"), *model, oneForce({{0, 0, 0, 0, 0, 0, 0, 0, 0, 0}, {1, 0, 10, 0, 0, 0, 0, 0, 0, 0}}));
  two.calcForceInGround(sys, *ws, 0, 0.3, f, p, m);
  EXPECT_NEAR(f.y(), 3.0, 1e-12);
}

TEST(ExternalLoads, BadInputIsOneLine) {
  auto model = model::readOsim(kDir + "subject01.osim");
  const io::Storage data = oneForce({{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}, {1, 1, 2, 3, 4, 5, 6, 7, 8, 9}});
  // A body the model lacks.
  EXPECT_NE(test::inputErrorOf([&] { ExternalLoads(specOn("calcn_x"), *model, data); })
                .find("expected a body of model " + kDir + "subject01.osim, got 'calcn_x'"),
            std::string::npos);
  // A missing column.
  io::Storage missing = data;
  missing.labels[3] = "fz_other";
  EXPECT_NE(test::inputErrorOf([&] { ExternalLoads(specOn("calcn_r"), *model, missing); })
                .find("expected 3 columns of grf.mot starting with 'f_v', got 2 (f_vx, f_vy)"),
            std::string::npos);
  // NaN.
  io::Storage nan = data;
  nan.data(1, 5) = std::nan("");
  EXPECT_NE(test::inputErrorOf([&] { ExternalLoads(specOn("calcn_r"), *model, nan); })
                .find("grf.mot: f_py: expected finite force data, got nan at t = 1 s"),
            std::string::npos);
  // Files.
  const std::string dir = test::scratchDir("external_loads_bad");
  std::ofstream(dir + "/a.xml") << "<OpenSimDocument><ExternalLoads><objects><PrescribedForce name=\"x\"/></objects>"
                                   "<datafile>g.mot</datafile></ExternalLoads></OpenSimDocument>";
  EXPECT_NE(test::inputErrorOf([&] { readExternalLoads(dir + "/a.xml"); }).find("unknown force type <PrescribedForce>"),
            std::string::npos);
  std::ofstream(dir + "/b.xml") << "<ExternalLoads><objects><ExternalForce name=\"x\"><applied_to_body>calcn_r"
                                   "</applied_to_body></ExternalForce></objects><datafile>g.mot</datafile></ExternalLoads>";
  const std::string msg = test::inputErrorOf([&] { readExternalLoads(dir + "/b.xml"); });
  EXPECT_NE(msg.find(dir + "/b.xml:1: "), std::string::npos) << msg;
  EXPECT_NE(msg.find("expected a <force_identifier> or a <torque_identifier>, got neither"), std::string::npos) << msg;
  std::ofstream(dir + "/c.xml") << "<ExternalLoads><objects><ExternalForce name=\"x\"><applied_to_body>calcn_r"
                                   "</applied_to_body><force_identifier>f_v</force_identifier></ExternalForce></objects>"
                                   "<datafile>nowhere.mot</datafile></ExternalLoads>";
  EXPECT_NE(test::inputErrorOf([&] { ExternalLoads(readExternalLoads(dir + "/c.xml"), *model); }).find("force data file not found"),
            std::string::npos);
}

}  // namespace
}  // namespace kneesim::dynamics
