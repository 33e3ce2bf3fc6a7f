// Simbody's interior-point optimizer with OpenSim StaticOptimization's settings against closed-form
// minimum-norm solutions, stopping where its tolerance says, and failing in one line.
#include "sim/interior_point.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace kneesim::sim {
namespace {

// min x1^2 + x2^2 + x3^2 with x1 + 2 x2 + 3 x3 = 1.4: x = A^T (A A^T)^-1 b = (0.1, 0.2, 0.3); with
// x3 <= 0.2 the bound holds and the rest is (x1, x2) = (1.4 - 0.6) (1, 2) / 5 = (0.16, 0.32).
TEST(InteriorPoint, MinimumNormSolutionsWithinItsTolerance) {
  Eigen::MatrixXd A(1, 3);
  A << 1, 2, 3;
  Eigen::VectorXd b(1), lower = Eigen::VectorXd::Zero(3), upper = Eigen::VectorXd::Ones(3);
  b << 1.4;
  SimbodyOptimizerSettings tight;
  tight.tolerance = 1e-10;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(3);
  std::string status;
  ASSERT_TRUE(minimizePowerSumWithSimbody(A, b, lower, upper, 2.0, tight, x, status)) << status;
  EXPECT_NEAR(x[0], 0.1, 1e-7);
  EXPECT_NEAR(x[1], 0.2, 1e-7);
  EXPECT_NEAR(x[2], 0.3, 1e-7);
  upper[2] = 0.2;
  x.setZero();
  ASSERT_TRUE(minimizePowerSumWithSimbody(A, b, lower, upper, 2.0, tight, x, status)) << status;
  EXPECT_NEAR(x[0], 0.16, 1e-7);
  EXPECT_NEAR(x[1], 0.32, 1e-7);
  EXPECT_NEAR(x[2], 0.2, 1e-7);
  // At OpenSim's 1e-4 it stops short of the optimum, on the feasible side of the equality.
  x.setZero();
  ASSERT_TRUE(minimizePowerSumWithSimbody(A, b, lower, upper, 2.0, SimbodyOptimizerSettings{}, x, status));
  EXPECT_NEAR(A.row(0).dot(x), 1.4, 1e-4);
  EXPECT_GT(x.squaredNorm(), 0.16 * 0.16 + 0.32 * 0.32 + 0.04 - 1e-9);
}

TEST(InteriorPoint, AnInfeasibleProblemFailsWithSimbodysMessage) {
  Eigen::MatrixXd A(1, 2);
  A << 1, 1;
  Eigen::VectorXd b(1), lower = Eigen::VectorXd::Zero(2), upper = Eigen::VectorXd::Ones(2);
  b << 3.0;  // beyond 1 + 1
  Eigen::VectorXd x = Eigen::VectorXd::Zero(2);
  std::string status;
  EXPECT_FALSE(minimizePowerSumWithSimbody(A, b, lower, upper, 2.0, SimbodyOptimizerSettings{}, x, status));
  EXPECT_NE(status.find("Ipopt"), std::string::npos) << status;
  EXPECT_EQ(x, Eigen::VectorXd::Zero(2));
}

}  // namespace
}  // namespace kneesim::sim
