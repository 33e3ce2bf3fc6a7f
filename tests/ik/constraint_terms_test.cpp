// The constraint equations IK uses: their values against Simbody's own constraints (Ball,
// PointOnLine, Rod, Weld built by sim::System), their Jacobians against central differences,
// and the violations a user reads against hand-computed distances and angles.
#include "ik/constraint_terms.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "model/osim_reader.hpp"
#include "sim/system.hpp"
#include "support/test_data.hpp"

namespace kneesim::ik {
namespace {

using Vec3 = Eigen::Vector3d;

model::ModelPtr loadFixture() { return model::readOsim(test::fixturePath("fixtures/constraints40000.osim")); }

std::vector<Vec3> stationsAt(const sim::System& sys, sim::Workspace& ws, const ConstraintTerms& t,
                             const Eigen::VectorXd& q) {
  sys.realizePosition(ws, q);
  std::vector<Vec3> p;
  for (int i = 0; i < t.getNumStations(); ++i)
    p.push_back(sys.findStationLocation(ws, t.getStationBodies()[i], t.getStations()[i]));
  return p;
}

/// The fixture, its Simbody system and its equations at an unassembled pose (every coordinate
/// away from its default), with the stations' positions there.
struct Skewed {
  model::ModelPtr m = loadFixture();
  sim::System sys{m};
  std::unique_ptr<sim::Workspace> ws = sys.createWorkspace();
  ConstraintTerms t{*m};
  Eigen::VectorXd q;
  std::vector<Vec3> p;
  Skewed() {
    q = sys.getDefaultCoordinates();
    for (int c = 0; c < q.size(); ++c) q[c] += 0.1 * std::sin(1.0 + 2.0 * c);
    p = stationsAt(sys, *ws, t, q);
  }
};

TEST(ConstraintTerms, ReadsTheFixturesFourConstraints) {
  const auto m = loadFixture();
  ASSERT_EQ(m->constraints.size(), 4u);
  EXPECT_EQ(m->constraints[0].type, model::ConstraintType::Point);
  EXPECT_EQ(m->constraints[1].type, model::ConstraintType::PointOnLine);
  EXPECT_EQ(m->constraints[2].type, model::ConstraintType::Weld);
  EXPECT_EQ(m->constraints[3].type, model::ConstraintType::ConstantDistance);
  const ConstraintTerms t(*m);
  EXPECT_EQ(t.getNumEquations(), 3 + 2 + 6 + 1);
  EXPECT_EQ(t.getNumStations(), 2 + 4 + 8 + 2);
}

// Simbody's constraints are the reference: the same equations (up to the choice of the two
// directions across a PointOnLine's line, which only the sum of squares is independent of).
TEST(ConstraintTerms, ValuesAreSimbodysPositionErrors) {
  Skewed f;
  const sim::System& sys = f.sys;
  const sim::Workspace* ws = f.ws.get();
  const ConstraintTerms& t = f.t;
  const auto& p = f.p;
  Eigen::VectorXd c(t.getNumEquations());
  t.calcErrors(p, c);
  const Eigen::VectorXd ball = sys.calcConstraintPositionErrors(*ws, 0);
  const Eigen::VectorXd line = sys.calcConstraintPositionErrors(*ws, 1);
  const Eigen::VectorXd weld = sys.calcConstraintPositionErrors(*ws, 2);
  const Eigen::VectorXd rod = sys.calcConstraintPositionErrors(*ws, 3);
  ASSERT_EQ(ball.size(), 3);
  ASSERT_EQ(line.size(), 2);
  ASSERT_EQ(weld.size(), 6);
  ASSERT_EQ(rod.size(), 1);
  EXPECT_GT(ball.norm(), 1e-3);  // the pose really is unassembled
  EXPECT_LT((c.segment<3>(0) - ball).norm(), 1e-12);
  EXPECT_NEAR(c.segment<2>(3).norm(), line.norm(), 1e-12);
  EXPECT_LT((c.segment<6>(5) - weld).norm(), 1e-12) << c.segment<6>(5).transpose() << "\n" << weld.transpose();
  EXPECT_NEAR(c[11], rod[0], 1e-12);
}

TEST(ConstraintTerms, JacobianMatchesCentralDifferences) {
  Skewed f;
  const model::Model& mm = *f.m;
  const sim::System& sys = f.sys;
  sim::Workspace* ws = f.ws.get();
  const ConstraintTerms& t = f.t;
  const Eigen::VectorXd q = f.q;
  const int nq = int(q.size());
  const auto& p = f.p;
  Eigen::MatrixXd Js(3 * t.getNumStations(), nq);
  sys.calcStationJacobian(*ws, t.getStationBodies(), t.getStations(), Js);
  Eigen::MatrixXd C(t.getNumEquations(), nq);
  t.calcJacobian(p, Js, C);
  const double h = 1e-6;
  for (int k = 0; k < nq; ++k) {
    Eigen::VectorXd qp = q, qm = q;
    qp[k] += h;
    qm[k] -= h;
    Eigen::VectorXd cp(t.getNumEquations()), cm(t.getNumEquations());
    t.calcErrors(stationsAt(sys, *ws, t, qp), cp);
    t.calcErrors(stationsAt(sys, *ws, t, qm), cm);
    EXPECT_LT(((cp - cm) / (2 * h) - C.col(k)).cwiseAbs().maxCoeff(), 1e-7) << "coordinate " << mm.coordinates[k].name;
  }
}

// Violations a user reads, against distances worked out by hand on the stations.
TEST(ConstraintTerms, ViolationsAreDistancesAndAngles) {
  const auto m = loadFixture();
  const ConstraintTerms t(*m);
  std::vector<Vec3> p(t.getNumStations(), Vec3::Zero());
  // Point: 0.3 m apart.
  p[0] = Vec3(1, 2, 3);
  p[1] = Vec3(1, 2.3, 3);
  // PointOnLine: line through (0,0,0); across-directions end at (0,1,0) and (0,0,1); follower
  // (5, 0.3, 0.4) is 0.5 m from the x axis.
  p[2] = Vec3(0, 0, 0);
  p[3] = Vec3(0, 1, 0);
  p[4] = Vec3(0, 0, 1);
  p[5] = Vec3(5, 0.3, 0.4);
  // Weld: F2 = F1 turned 0.2 rad about z, origin 0.01 m away: the angle is the larger.
  p[6] = Vec3(0, 0, 0);
  p[7] = Vec3(1, 0, 0);
  p[8] = Vec3(0, 1, 0);
  p[9] = Vec3(0, 0, 1);
  p[10] = Vec3(0.01, 0, 0);
  p[11] = p[10] + Vec3(std::cos(0.2), std::sin(0.2), 0);
  p[12] = p[10] + Vec3(-std::sin(0.2), std::cos(0.2), 0);
  p[13] = p[10] + Vec3(0, 0, 1);
  // ConstantDistance 1.5 m; the points are 1.6 m apart.
  p[14] = Vec3(0, 0, 0);
  p[15] = Vec3(0, 1.6, 0);
  EXPECT_NEAR(t.calcViolation(p, 0), 0.3, 1e-12);
  EXPECT_NEAR(t.calcViolation(p, 1), 0.5, 1e-12);
  EXPECT_NEAR(t.calcViolation(p, 2), 0.2, 1e-12);
  EXPECT_NEAR(t.calcViolation(p, 3), 0.1, 1e-12);
}

}  // namespace
}  // namespace kneesim::ik
