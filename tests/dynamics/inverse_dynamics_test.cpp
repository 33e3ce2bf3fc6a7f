// Inverse dynamics against closed forms (a pendulum on a pin, a block on a slider), its joint
// loads against the generalised forces Simbody computes independently, and the allocation-free
// frame loop on gait2354 with ground reactions.
#include "dynamics/inverse_dynamics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "dynamics/coordinate_smoothing.hpp"
#include "dynamics/external_loads.hpp"
#include "dynamics/trajectory.hpp"
#include "model/osim_reader.hpp"
#include "support/allocation_counter.hpp"
#include "support/test_data.hpp"
#include "pendulum_model.hpp"

namespace kneesim::dynamics {
namespace {

using test::g_allocations;
using test::g_count_allocations;

using model::Vec3;

constexpr double kMass = 2.5, kL = 0.4, kIzz = 0.03, kG = 9.81, kBlock = 1.5;

/// The bar on a pin at the origin with its mass centre at (kL, 0, 0), optionally with the block.
std::shared_ptr<model::Model> makePendulum(bool with_slider) {
  test::PendulumSpec s;
  s.mass = kMass;
  s.mass_center = Vec3(kL, 0, 0);
  s.inertia = Vec3(0.01, 0.02, kIzz);
  s.gravity = kG;
  s.block_mass = with_slider ? kBlock : 0.0;
  return test::makePendulum(s);
}

Eigen::VectorXd vec(std::initializer_list<double> v) {
  Eigen::VectorXd x(v.size());
  int i = 0;
  for (double d : v) x[i++] = d;
  return x;
}

TEST(InverseDynamics, PendulumMatchesClosedForm) {
  const InverseDynamics id(makePendulum(false));
  auto ws = id.createWorkspace();
  Eigen::VectorXd tau(1);
  for (double q : {-0.7, 0.0, 0.4, 2.0}) {
    const double qd = 1.3, qdd = -2.1;
    id.setState(*ws, vec({q}), vec({qd}));
    id.calcGeneralizedForces(*ws, vec({qdd}), tau);
    // Lagrange: (Izz + m L^2) qdd + m g L cos q (the mass centre is at L (cos q, sin q)).
    EXPECT_NEAR(tau[0], (kIzz + kMass * kL * kL) * qdd + kMass * kG * kL * std::cos(q), 1e-10) << q;
  }
  // A force F = (0, 10, 0) N at the bar's (0.3, 0, 0) adds -(r x F)_z = -0.3 cos(q) * 10.
  const double q = 0.4;
  id.setState(*ws, vec({q}), vec({0.0}));
  const Vec3 r = id.getSystem().getBodyPose(ws->getSimWorkspace(), 1).linear() * Vec3(0.3, 0, 0);
  ws->updAppliedForces().col(1) << r.cross(Vec3(0, 10, 0)), Vec3(0, 10, 0);
  id.calcGeneralizedForces(*ws, vec({0.0}), tau);
  EXPECT_NEAR(tau[0], kMass * kG * kL * std::cos(q) - 0.3 * std::cos(q) * 10, 1e-10);
}

TEST(InverseDynamics, PendulumJointLoadIsMassTimesAccelerationMinusGravity) {
  const InverseDynamics id(makePendulum(false));
  auto ws = id.createWorkspace();
  sim::SpatialColumns F(6, 2);
  const double q = 0.9, qd = 2.0, qdd = -3.0;
  id.setState(*ws, vec({q}), vec({qd}));
  id.calcJointLoads(*ws, vec({qdd}), F);
  // The pin (at the origin) supplies m (a_C - g): a_C = L qdd (-sin, cos) - L qd^2 (cos, sin).
  const Vec3 a_C = kL * qdd * Vec3(-std::sin(q), std::cos(q), 0) - kL * qd * qd * Vec3(std::cos(q), std::sin(q), 0);
  const Vec3 f = kMass * (a_C - Vec3(0, -kG, 0));
  EXPECT_LT((Vec3(F.col(1).tail<3>()) - f).norm(), 1e-10);
  // Its moment about the pin is the pin's generalised force along z (and nothing about x, y
  // beyond what holds the bar in its plane: zero here, the bar's x-y products of inertia are 0).
  Eigen::VectorXd tau(1);
  id.calcGeneralizedForces(*ws, vec({qdd}), tau);
  EXPECT_NEAR(F(2, 1), tau[0], 1e-10);
  EXPECT_NEAR(F(0, 1), 0.0, 1e-10);
  EXPECT_NEAR(F(1, 1), 0.0, 1e-10);
}

TEST(InverseDynamics, SliderCarriesTheBlockAndThePinCarriesBoth) {
  const InverseDynamics id(makePendulum(true));
  auto ws = id.createWorkspace();
  const double q = 0.3, s = 0.25;
  id.setState(*ws, vec({q, s}), vec({0.0, 0.0}));
  Eigen::VectorXd tau(2);
  id.calcGeneralizedForces(*ws, vec({0.0, 0.0}), tau);
  // Statics: the slider holds the block's weight along the bar, m2 g sin q; the pin holds both
  // moments, (m L + m2 s) g cos q.
  EXPECT_NEAR(tau[1], kBlock * kG * std::sin(q), 1e-10);
  EXPECT_NEAR(tau[0], (kMass * kL + kBlock * s) * kG * std::cos(q), 1e-10);
  sim::SpatialColumns F(6, 3);
  id.calcJointLoads(*ws, vec({0.0, 0.0}), F);
  EXPECT_LT((Vec3(F.col(2).tail<3>()) - Vec3(0, kBlock * kG, 0)).norm(), 1e-10);
  EXPECT_LT((Vec3(F.col(1).tail<3>()) - Vec3(0, (kBlock + kMass) * kG, 0)).norm(), 1e-10);
}

/// The generalised forces equal Simbody's (calcResidualForceIgnoringConstraints, what OpenSim
/// calls, an independent recursion), and the joint loads' work rates along finite-difference
/// motion axes are those forces: checked on gait2354 (CustomJoints with spline-coupled knee
/// translations) at random states with a load on the foot, so the sweep's shifts, inertias,
/// accelerations and projections are all exercised.
TEST(InverseDynamics, JointLoadsProjectOntoGeneralizedForces) {
  auto model = model::readOsim(test::dataPath("opensim-dynamics-tests/id/subject01.osim"));
  const InverseDynamics id(model);
  auto ws = id.createWorkspace();
  auto ws2 = id.getSystem().createWorkspace();
  const int n = id.getNumCoordinates();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  Eigen::VectorXd q(n), qd(n), qdd(n), tau(n);
  sim::SpatialColumns F(6, model->bodies.size());
  for (int trial = 0; trial < 3; ++trial) {
    for (int c = 0; c < n; ++c) {
      q[c] = u(rng);
      qd[c] = 3 * u(rng);
      qdd[c] = 10 * u(rng);
    }
    id.setState(*ws, q, qd);
    ws->updAppliedForces().col(model->findBody("calcn_r")) << 5, -3, 8, 40, 700, -20;
    id.calcGeneralizedForces(*ws, qdd, tau);
    id.calcJointLoads(*ws, qdd, F);
    Eigen::VectorXd tau_simbody(n);
    id.getSystem().calcResidualForces(ws->updSimWorkspace(), qdd, ws->getAppliedForces(), tau_simbody);
    EXPECT_LT((tau - tau_simbody).cwiseAbs().maxCoeff(), 1e-9 * (1 + tau_simbody.cwiseAbs().maxCoeff()));
    for (int c = 0; c < n; ++c) {
      const model::Coordinate& co = model->coordinates[c];
      const int b = model->joints[co.joint].child_body;
      // Generalised force of coordinate c = the joint load's power per unit rate: the child's
      // spatial velocity for a unit rate of c, (w, v_origin), dotted with (moment, force).
      const double h = 1e-6;
      Eigen::VectorXd qp = q, qm = q;
      qp[c] += h;
      qm[c] -= h;
      id.getSystem().realizePosition(*ws2, qp);
      const Eigen::Isometry3d Xp = id.getSystem().getBodyPose(*ws2, b);
      id.getSystem().realizePosition(*ws2, qm);
      const Eigen::Isometry3d Xm = id.getSystem().getBodyPose(*ws2, b);
      const Eigen::Matrix3d dR = (Xp.linear() - Xm.linear()) / (2 * h) * Xp.linear().transpose();
      const Vec3 w(dR(2, 1), dR(0, 2), dR(1, 0));
      const Vec3 v = (Xp.translation() - Xm.translation()) / (2 * h);
      // The parent moves too when c is not its joint's... c belongs to b's joint, so only b
      // and its subtree move; the load on b through its joint is what c's actuator balances.
      const double power = w.dot(Vec3(F.col(b).head<3>())) + v.dot(Vec3(F.col(b).tail<3>()));
      EXPECT_NEAR(power, tau[c], 1e-5 * (1 + std::abs(tau[c]))) << co.name;
    }
  }
}

/// The frame loop (coordinates from splines, external loads, inverse dynamics, joint loads)
/// allocates nothing once its workspace exists.
TEST(InverseDynamics, FrameLoopOnGait2354DoesNotAllocate) {
  KNEESIM_REQUIRE_DATA("opensim-dynamics-tests/id/subject01_walk1_grf.mot");
  const std::string dir = test::dataPath("opensim-dynamics-tests/id/");
  auto model = model::readOsim(dir + "subject01.osim");
  CoordinateSmoothingOptions so;
  so.cutoff_hz = 6;
  const CoordinateTrajectories traj(*model, io::readStorage(dir + "subject01_walk1_ik.mot"), "ik", so);
  const ExternalLoads loads(readExternalLoads(dir + "subject01_walk1_grf.xml"), *model);
  const InverseDynamics id(model);
  auto ws = id.createWorkspace();
  const int n = id.getNumCoordinates();
  Eigen::VectorXd q(n), qd(n), qdd(n), tau(n);
  sim::SpatialColumns F(6, model->bodies.size());
  const int knee = model->findJoint("knee_r");
  auto frame = [&](double t) {
    traj.calcAt(t, q, qd, qdd);
    id.setState(*ws, q, qd);
    loads.addBodyForces(id.getSystem(), ws->getSimWorkspace(), t, ws->updAppliedForces());
    id.calcGeneralizedForces(*ws, qdd, tau);
    id.calcJointLoads(*ws, qdd, F);
    return expressJointLoad(id.getSystem(), ws->getSimWorkspace(), knee, F, LoadOnBody::Child, LoadFrame::Child);
  };
  frame(0.5);  // first use: Simbody may set up lazily
  g_allocations = 0;
  g_count_allocations = true;
  double sum = 0;
  for (int f = 0; f < 50; ++f) sum += frame(0.6 + 0.01 * f).force.norm() + tau.norm();
  g_count_allocations = false;
  EXPECT_GT(sum, 1000.0);  // the loop did real work
  EXPECT_EQ(g_allocations, 0);
}

}  // namespace
}  // namespace kneesim::dynamics
