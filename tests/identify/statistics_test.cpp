#include "identify/statistics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace kneesim::identify {
namespace {

// Reference values: Wichura's AS 241 (Python's statistics.NormalDist), an independent algorithm.
TEST(Statistics, NormalQuantileMatchesAs241InAllThreeBranches) {
  EXPECT_NEAR(normalQuantile(1e-10), -6.361340902404056, 1e-12);   // lower tail
  EXPECT_NEAR(normalQuantile(0.01), -2.3263478740408408, 1e-13);
  EXPECT_NEAR(normalQuantile(0.2), -0.8416212335729142, 1e-13);    // central
  EXPECT_EQ(normalQuantile(0.5), 0.0);
  EXPECT_NEAR(normalQuantile(0.975), 1.9599639845400536, 1e-13);
  EXPECT_NEAR(normalQuantile(0.999), 3.090232306167813, 1e-13);    // upper tail
  EXPECT_NEAR(normalQuantile(0.001), -normalQuantile(0.999), 1e-13);
}

TEST(Statistics, NormalQuantileOutsideTheOpenIntervalIsInfinite) {
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(normalQuantile(0.0), -inf);
  EXPECT_EQ(normalQuantile(-0.5), -inf);
  EXPECT_EQ(normalQuantile(1.0), inf);
  EXPECT_EQ(normalQuantile(2.0), inf);
}

TEST(Statistics, NormalCdfMatchesAs241AndInvertsTheQuantile) {
  EXPECT_NEAR(normalCdf(-1.96), 0.024997895148220428, 1e-15);
  EXPECT_EQ(normalCdf(0.0), 0.5);
  EXPECT_NEAR(normalCdf(1.0), 0.8413447460685429, 1e-15);
  EXPECT_NEAR(normalCdf(3.0), 0.9986501019683699, 1e-15);
  for (double p : {1e-6, 0.03, 0.3, 0.7, 0.97, 1 - 1e-6}) EXPECT_NEAR(normalCdf(normalQuantile(p)), p, 1e-14 + 1e-12 * p);
}

}  // namespace
}  // namespace kneesim::identify
