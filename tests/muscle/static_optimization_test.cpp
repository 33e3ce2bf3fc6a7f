// Static optimisation against closed forms: two straight muscles and a reserve on a pendulum
// (p = 2 has the minimum-norm answer, with a bound active too), the solver alone on a problem
// whose answer is known, and the couplers' curvature term.
#include "muscle/static_optimization.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "dynamics/pendulum_model.hpp"
#include "muscle/so_solver.hpp"

using namespace kneesim;
using model::Vec3;

namespace {

constexpr double kMass = 2.5, kL = 0.4, kIzz = 0.03, kG = 9.81;

model::Muscle straightMuscle(const char* name, const Vec3& origin_in_ground, const Vec3& insertion_on_bar, double fmax) {
  model::Muscle m;
  m.name = name;
  m.type = "Thelen2003Muscle";
  m.max_isometric_force = fmax;
  m.optimal_fiber_length = 0.1;
  m.tendon_slack_length = 0.2;
  model::PathPoint a, b;
  a.name = "origin";
  a.body = 0;
  a.p_BP = origin_in_ground;
  b.name = "insertion";
  b.body = 1;
  b.p_BP = insertion_on_bar;
  m.path.points = {a, b};
  return m;
}

/// The bar of a pendulum on a pin about z, with its mass centre kL along x.
std::shared_ptr<model::Model> makeArm() {
  test::PendulumSpec s;
  s.mass = kMass;
  s.mass_center = Vec3(kL, 0, 0);
  s.inertia = Vec3(0.01, 0.02, kIzz);
  s.gravity = kG;
  return test::makePendulum(s);
}

/// Moment about the pin (z) of a unit pull from insertion p (on the bar, at angle q) toward o.
double momentArm(const Vec3& o, const Vec3& p_bar, double q) {
  const Vec3 p(p_bar.x() * std::cos(q) - p_bar.y() * std::sin(q), p_bar.x() * std::sin(q) + p_bar.y() * std::cos(q), 0);
  const Vec3 u = (o - p).normalized();
  return p.cross(u).z();
}

TEST(StaticOptimization, TwoMusclesOnAPinShareTheLoadAsTheMinimumNormAnswer) {
  auto m = makeArm();
  const Vec3 o1(0, 0.3, 0), p1(0.2, 0, 0), o2(0.1, 0.35, 0), p2(0.3, 0.02, 0);
  m->muscles.push_back(straightMuscle("flexor", o1, p1, 400));
  m->muscles.push_back(straightMuscle("helper", o2, p2, 150));
  auto id = std::make_shared<const dynamics::InverseDynamics>(std::shared_ptr<const model::Model>(m));
  muscle::SoOptions o;
  o.use_muscle_physiology = false;  // force = a * max_isometric_force
  o.convergence = 1e-10;
  const muscle::StaticOptimization so(id, o);
  auto ws = so.createWorkspace();
  const double q = 0.3, qddot = 2.0;
  const Eigen::VectorXd Q = Eigen::VectorXd::Constant(1, q), U = Eigen::VectorXd::Zero(1),
                        A = Eigen::VectorXd::Constant(1, qddot);
  const muscle::SoFrameStatus st = so.solveFrame(*ws, 0.0, Q, U, A, nullptr);
  ASSERT_TRUE(st.converged);
  // The pin needs I qddot + m g l cos q; each muscle gives a_i F_i r_i. Minimising a1^2 + a2^2:
  // a_i = tau F_i r_i / sum (F_j r_j)^2.
  const double tau = (kIzz + kMass * kL * kL) * qddot + kMass * kG * kL * std::cos(q);
  const double k1 = 400 * momentArm(o1, p1, q), k2 = 150 * momentArm(o2, p2, q);
  EXPECT_NEAR(ws->getActivations()[0], tau * k1 / (k1 * k1 + k2 * k2), 1e-7);
  EXPECT_NEAR(ws->getActivations()[1], tau * k2 / (k1 * k1 + k2 * k2), 1e-7);
  EXPECT_NEAR(ws->getForces()[0], 400 * ws->getActivations()[0], 1e-9);
  EXPECT_LT(st.max_violation, 1e-6);
}

TEST(StaticOptimization, AReserveTakesWhatTheBoundedMuscleCannot) {
  auto m = makeArm();
  const Vec3 o1(0, 0.3, 0), p1(0.2, 0, 0);
  m->muscles.push_back(straightMuscle("weak", o1, p1, 20));
  model::CoordinateActuator r;
  r.name = "reserve";
  r.coordinate = 0;
  r.optimal_force = 1;
  m->actuators.push_back(r);
  auto id = std::make_shared<const dynamics::InverseDynamics>(std::shared_ptr<const model::Model>(m));
  muscle::SoOptions o;
  o.use_muscle_physiology = false;
  o.convergence = 1e-10;
  const muscle::StaticOptimization so(id, o);
  ASSERT_EQ(so.getActuators().size(), 2u);
  auto ws = so.createWorkspace();
  const double q = 0.0;
  const Eigen::VectorXd Q = Eigen::VectorXd::Constant(1, q), Z = Eigen::VectorXd::Zero(1);
  so.solveFrame(*ws, 0.0, Q, Z, Z, nullptr);
  // tau = m g l = 9.81 N·m; the muscle (k = 20 r) is capped at a = 1, the reserve takes the rest.
  const double tau = kMass * kG * kL, k = 20 * momentArm(o1, p1, q);
  ASSERT_GT(tau * k / (k * k + 1), 1.0);  // the unbounded optimum would exceed the muscle's bound
  EXPECT_NEAR(ws->getActivations()[0], 1.0, 1e-6);
  EXPECT_NEAR(ws->getForces()[1], tau - k, 1e-5);
}

TEST(StaticOptimization, TooFewActuatorsIsAnInputError) {
  auto id = std::make_shared<const dynamics::InverseDynamics>(std::shared_ptr<const model::Model>(makeArm()));
  try {
    muscle::StaticOptimization so(id, {});
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("0 actuators for 1 coordinates"), std::string::npos) << e.what();
  }
}

TEST(SoSolver, ActivationExponentThreeMatchesItsClosedForm) {
  // min sum x^3 (x >= 0) s.t. r . x = b: x_i = sqrt(lambda r_i) with lambda from r . x = b.
  const Eigen::Vector3d r(1.0, 2.0, 0.5);
  const double b = 2.0;
  Eigen::MatrixXd A = r.transpose();
  Eigen::VectorXd B = Eigen::VectorXd::Constant(1, b), lo = Eigen::VectorXd::Zero(3), hi = Eigen::VectorXd::Ones(3),
                  x = Eigen::VectorXd::Zero(3);
  muscle::SoSolver solver(3, 1, 3.0, 1e-12, 200);
  int it = 0;
  ASSERT_TRUE(solver.solve(A, B, lo, hi, x, it));
  const double s = b / (r.array() * r.array().sqrt()).sum();  // x_i = s sqrt(r_i)
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(x[i], s * std::sqrt(r[i]), 1e-6);
}

}  // namespace

namespace {

TEST(SoSolver, TheDedicatedQpAgreesWithIpoptOnRandomBoundedProblems) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 12, m = 4;
    Eigen::MatrixXd A(m, n);
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < n; ++j) A(i, j) = 50 * u(rng);
    Eigen::VectorXd lo = Eigen::VectorXd::Constant(n, 0.01), hi = Eigen::VectorXd::Ones(n);
    lo.tail(4).setConstant(-1e30);  // four reserves without bounds: always feasible
    hi.tail(4).setConstant(1e30);
    Eigen::VectorXd feasible(n);
    for (int j = 0; j < n; ++j) feasible[j] = j < n - 4 ? 0.5 + 0.45 * u(rng) : u(rng);
    const Eigen::VectorXd b = A * feasible * 1.5;  // pushes several activations onto their bounds
    Eigen::VectorXd x_qp = Eigen::VectorXd::Zero(n), x_ip = Eigen::VectorXd::Zero(n);
    int it = 0;
    muscle::SoSolver qp(n, m, 2.0, 1e-10, 500), ip(n, m, 2.0, 1e-10, 500, false);
    ASSERT_TRUE(qp.solve(A, b, lo, hi, x_qp, it));
    ASSERT_TRUE(ip.solve(A, b, lo, hi, x_ip, it));
    EXPECT_LT((x_qp - x_ip).cwiseAbs().maxCoeff(), 1e-6) << "trial " << trial;
    EXPECT_LT((A * x_qp - b).cwiseAbs().maxCoeff(), 1e-10 * (1 + b.cwiseAbs().maxCoeff()));
    EXPECT_TRUE((x_qp.array() >= lo.array() - 1e-12).all() && (x_qp.array() <= hi.array() + 1e-12).all());
  }
}

TEST(SoSolver, TheDedicatedQpWithoutBoundsIsTheMinimumNormSolution) {
  Eigen::MatrixXd A(2, 3);
  A << 1, 2, 3, -1, 0.5, 2;
  const Eigen::Vector2d b(1.0, 0.3);
  const Eigen::VectorXd lo = Eigen::VectorXd::Constant(3, -1e30), hi = Eigen::VectorXd::Constant(3, 1e30);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(3);
  int it = 0;
  muscle::SoSolver qp(3, 2, 2.0, 1e-12, 100);
  ASSERT_TRUE(qp.solve(A, b, lo, hi, x, it));
  const Eigen::Vector3d expected = A.transpose() * (A * A.transpose()).inverse() * b;
  EXPECT_LT((x - expected).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LE(it, 2);
}

}  // namespace
