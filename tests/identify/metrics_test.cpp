#include "identify/metrics.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace kneesim::identify {
namespace {

TEST(Metrics, HandComputedValues) {
  // measured 100, 200, 300, 400; predicted 110, 190, 330, 400 -> residuals 10, -10, 30, 0.
  const std::vector<double> t{0, 0.1, 0.2, 0.3, 0.4};
  const std::vector<double> meas{999, 100, 200, 300, 400}, pred{0, 110, 190, 330, 400};
  MetricsAccumulator acc(50.0);
  acc.add("walk", t, pred.data(), meas.data(), {1, 2, 3, 4});
  const FitMetrics m = acc.calc();
  EXPECT_EQ(m.n_frames, 4);
  EXPECT_NEAR(m.rmse, std::sqrt(1100.0 / 4), 1e-12);         // (100 + 100 + 900 + 0) / 4
  EXPECT_NEAR(m.rmse_bw, std::sqrt(275.0) / (50 * 9.80665), 1e-12);
  EXPECT_NEAR(m.r2, 1 - 1100.0 / 50000.0, 1e-12);           // SST = 150^2 + 50^2 + 50^2 + 150^2
  EXPECT_EQ(m.max_abs_error, 30);
  EXPECT_EQ(m.time_of_max_error, 0.3);
  EXPECT_EQ(m.trial_of_max_error, "walk");
  EXPECT_NEAR(m.bias, 7.5, 1e-12);
  EXPECT_EQ(m.mean_measured, 250);
  EXPECT_EQ(m.peak_measured, 400);
  EXPECT_NEAR(m.nrmse_peak, std::sqrt(275.0) / 400, 1e-12);
}

TEST(Metrics, PoolsTrialsAndHandlesEmptyAndConstant) {
  MetricsAccumulator none;
  EXPECT_EQ(none.calc().n_frames, 0);
  EXPECT_TRUE(std::isnan(none.calc().rmse));
  const std::vector<double> t{0, 1}, meas{5, 5}, pred{5, 7};
  MetricsAccumulator acc;
  acc.add("a", t, pred.data(), meas.data(), {0});
  acc.add("b", t, pred.data(), meas.data(), {0, 1});
  const FitMetrics m = acc.calc();
  EXPECT_EQ(m.n_frames, 3);
  EXPECT_TRUE(std::isnan(m.r2));  // constant measurement
  EXPECT_TRUE(std::isnan(m.rmse_bw));
  EXPECT_EQ(m.trial_of_max_error, "b");
  EXPECT_EQ(m.time_of_max_error, 1);
}

}  // namespace
}  // namespace kneesim::identify
