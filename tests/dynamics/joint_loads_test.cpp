// A joint's load expressed on either body and in any frame, against the statics of a pendulum
// held still on an offset pin.
#include "dynamics/joint_loads.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "dynamics/inverse_dynamics.hpp"
#include "pendulum_model.hpp"

namespace kneesim::dynamics {
namespace {

using model::Vec3;

constexpr double kMass = 3.0, kG = 9.81, kL = 0.4;

/// The bar on a pin at ground (0, 1, 0) and at the bar's (-0.1, 0, 0); the bar's mass centre is
/// at its (kL, 0, 0), so 0.5 m from the pin.
model::ModelPtr makeOffsetPendulum() {
  test::PendulumSpec s;
  s.mass = kMass;
  s.mass_center = Vec3(kL, 0, 0);
  s.inertia = Vec3::Constant(0.02);
  s.gravity = kG;
  s.pin_in_ground = Vec3(0, 1, 0);
  s.pin_in_bar = Vec3(-0.1, 0, 0);
  return test::makePendulum(s);
}

TEST(JointLoads, StaticPendulumOnEitherBodyInEveryFrame) {
  const InverseDynamics id(makeOffsetPendulum());
  auto ws = id.createWorkspace();
  const double q = 0.6;
  Eigen::VectorXd x(1), zero = Eigen::VectorXd::Zero(1);
  x << q;
  id.setState(*ws, x, zero);
  sim::SpatialColumns F(6, 2);
  id.calcJointLoads(*ws, zero, F);
  const sim::System& sys = id.getSystem();
  const auto& sws = ws->getSimWorkspace();
  // Held still: the pin pushes up with the weight and resists the weight's moment about it.
  const Vec3 weight_up(0, kMass * kG, 0);
  const double moment = kMass * kG * 0.5 * std::cos(q);
  const JointLoad g = expressJointLoad(sys, sws, 0, F, LoadOnBody::Child, LoadFrame::Ground);
  EXPECT_LT((g.force - weight_up).norm(), 1e-10);
  EXPECT_LT((g.moment - Vec3(0, 0, moment)).norm(), 1e-10);
  EXPECT_LT((g.point - Vec3(0, 1, 0)).norm(), 1e-12);
  // In the bar's frame (rotated by q about z): the same vectors turned by -q; the point is the
  // pin's place on the bar.
  const JointLoad c = expressJointLoad(sys, sws, 0, F, LoadOnBody::Child, LoadFrame::Child);
  EXPECT_LT((c.force - kMass * kG * Vec3(std::sin(q), std::cos(q), 0)).norm(), 1e-10);
  EXPECT_NEAR(c.moment.z(), moment, 1e-10);
  EXPECT_LT((c.point - Vec3(-0.1, 0, 0)).norm(), 1e-12);
  // On the parent: the opposite load at the parent's joint frame, here the same point.
  const JointLoad p = expressJointLoad(sys, sws, 0, F, LoadOnBody::Parent, LoadFrame::Parent);
  EXPECT_LT((p.force + weight_up).norm(), 1e-10);
  EXPECT_NEAR(p.moment.z(), -moment, 1e-10);
  EXPECT_LT((p.point - Vec3(0, 1, 0)).norm(), 1e-12);
  EXPECT_EQ(getLoadBodyName(sys.getModel(), 0, LoadOnBody::Parent), "ground");
  EXPECT_EQ(getLoadFrameName(sys.getModel(), 0, LoadFrame::Child), "bar");
}

TEST(JointLoads, ParsesItsWords) {
  EXPECT_EQ(parseLoadOnBody(" Parent "), LoadOnBody::Parent);
  EXPECT_EQ(parseLoadFrame("GROUND"), LoadFrame::Ground);
  EXPECT_THROW(parseLoadFrame("tibia"), std::invalid_argument);
  EXPECT_THROW(parseLoadOnBody("both"), std::invalid_argument);
}

}  // namespace
}  // namespace kneesim::dynamics
