#include "identify/statistics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <tuple>

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

// Wilson's interval, 95 %. At k = 0 and k = n its far ends are closed forms: z^2 / (n + z^2) and
// n / (n + z^2) with z = 1.959964 (z^2 = 3.841459). 17 of 20: from the score formula by hand
// (centre (0.85 + z^2/40) / (1 + z^2/20) = 0.79361, half-width 0.15402).
TEST(Statistics, WilsonIntervalOfABinomialProportion) {
  const double z2 = 1.959963984540054 * 1.959963984540054;
  auto [lo, hi] = calcWilsonInterval(20, 20, 0.95);
  EXPECT_NEAR(lo, 20 / (20 + z2), 1e-12);
  EXPECT_EQ(hi, 1.0);
  std::tie(lo, hi) = calcWilsonInterval(0, 20, 0.95);
  EXPECT_EQ(lo, 0.0);
  EXPECT_NEAR(hi, z2 / (20 + z2), 1e-12);
  std::tie(lo, hi) = calcWilsonInterval(17, 20, 0.95);
  EXPECT_NEAR(lo, 0.6395811352592431, 1e-12);
  EXPECT_NEAR(hi, 0.9476312541037835, 1e-12);
  EXPECT_TRUE(std::isnan(calcWilsonInterval(3, 2, 0.95).first));
  EXPECT_TRUE(std::isnan(calcWilsonInterval(0, 0, 0.95).second));
}

}  // namespace
}  // namespace kneesim::identify
