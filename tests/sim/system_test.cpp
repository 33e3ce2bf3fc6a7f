// Kinematics of the Simbody builder against positions derived by hand.
#include "sim/system.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.hpp"
#include "support/chain_model.hpp"

namespace kneesim::sim {
namespace {

using test::makeChain;

using model::Pose;
using model::Vec3;

Vec3 rotZ(double a, const Vec3& v) { return Vec3(std::cos(a) * v.x() - std::sin(a) * v.y(), std::sin(a) * v.x() + std::cos(a) * v.y(), v.z()); }

TEST(System, ChainMatchesHandDerivedKinematics) {
  auto model = makeChain(false, 40000);
  System sys(model);
  auto ws = sys.createWorkspace();
  const double q0 = 0.3, q1 = -0.07, q2 = 0.6;
  Eigen::VectorXd q(3);
  q << q0, q1, q2;
  sys.realizePosition(*ws, q);
  const Vec3 base(0, 1, 0);
  // mA: (0,1,0) + Rz(q0)(0.5,0,0)
  EXPECT_LT((sys.findStationLocation(*ws, 1, Vec3(0.5, 0, 0)) - (base + rotZ(q0, Vec3(0.5, 0, 0)))).norm(), 1e-12);
  // mB: B's (0,0,0.2) is A's (0.2,0,0); B's origin is A's (0.5,0,-q1).
  EXPECT_LT((sys.findStationLocation(*ws, 2, Vec3(0, 0, 0.2)) - (base + rotZ(q0, Vec3(0.7, 0, -q1)))).norm(), 1e-12);
  // mC in B: (0.1 q2 + 0.05 + 0.1 cos q2, 0.1 sin q2, 0) =: (a, b, 0); B's (a,b,0) is A's (0.5, b, -q1 - a).
  const double a = 0.1 * q2 + 0.05 + 0.1 * std::cos(q2), b = 0.1 * std::sin(q2);
  EXPECT_LT((sys.findStationLocation(*ws, 3, Vec3(0.1, 0, 0)) - (base + rotZ(q0, Vec3(0.5, b, -q1 - a)))).norm(), 1e-12);
}

TEST(System, ReversedCustomJointOfOpenSim3InvertsTheTransform) {
  // OpenSim 3.x `reverse`: X_FM = T(q)^-1. C's origin in B is -R(q2)^T t with t = (0.1 q2 + 0.05, 0, 0).
  const double q2 = 0.6;
  Eigen::VectorXd q(3);
  q << 0.0, 0.0, q2;
  {
    System sys(makeChain(true, 30000));
    auto ws = sys.createWorkspace();
    sys.realizePosition(*ws, q);
    const Vec3 c_in_B = -rotZ(-q2, Vec3(0.1 * q2 + 0.05, 0, 0));
    // B's (x,y,0) is A's (0.5, y, -x) when q1 = 0.
    const Vec3 expected = Vec3(0, 1, 0) + Vec3(0.5, c_in_B.y(), -c_in_B.x());
    EXPECT_LT((sys.findStationLocation(*ws, 3, Vec3::Zero()) - expected).norm(), 1e-12);
  }
  {
    // Format 40000 keeps the joint's meaning: same as forward.
    System fwd(makeChain(false, 40000)), rev(makeChain(true, 40000));
    auto w1 = fwd.createWorkspace(), w2 = rev.createWorkspace();
    fwd.realizePosition(*w1, q);
    rev.realizePosition(*w2, q);
    EXPECT_LT((fwd.findStationLocation(*w1, 3, Vec3(0.1, 0.2, 0.3)) - rev.findStationLocation(*w2, 3, Vec3(0.1, 0.2, 0.3))).norm(), 1e-14);
  }
}

TEST(System, StationJacobianMatchesFiniteDifferences) {
  System sys(makeChain(true, 30000));
  auto ws = sys.createWorkspace();
  Eigen::VectorXd q(3);
  q << 0.4, 0.1, -0.8;
  const std::vector<int> bodies = {1, 2, 3};
  const std::vector<Vec3> stations = {Vec3(0.5, 0, 0), Vec3(0, 0.1, 0.2), Vec3(0.1, -0.05, 0.02)};
  Eigen::MatrixXd J(9, 3);
  sys.realizePosition(*ws, q);
  sys.calcStationJacobian(*ws, bodies, stations, J);
  const double h = 1e-6;
  for (int c = 0; c < 3; ++c) {
    Eigen::VectorXd qp = q, qm = q;
    qp[c] += h;
    qm[c] -= h;
    for (int i = 0; i < 3; ++i) {
      sys.realizePosition(*ws, qp);
      const Vec3 pp = sys.findStationLocation(*ws, bodies[i], stations[i]);
      sys.realizePosition(*ws, qm);
      const Vec3 pm = sys.findStationLocation(*ws, bodies[i], stations[i]);
      EXPECT_LT((J.block<3, 1>(3 * i, c) - (pp - pm) / (2 * h)).norm(), 1e-8) << "coordinate " << c << " station " << i;
    }
  }
}

}  // namespace
}  // namespace kneesim::sim
