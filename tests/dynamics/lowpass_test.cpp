// OpenSim's padding and third-order Butterworth against hand-computed values and the filter's
// closed-form frequency response.
#include "dynamics/lowpass.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace kneesim::dynamics {
namespace {

TEST(Lowpass, PadsByOddReflection) {
  const std::vector<double> p = padOddReflection({1, 2, 4, 7}, 2);
  // Before: 2*1 - x[2], 2*1 - x[1]; after: 2*7 - x[2], 2*7 - x[1].
  const std::vector<double> expected = {-2, 0, 1, 2, 4, 7, 10, 12};
  EXPECT_EQ(p, expected);
}

/// Amplitude of a sine of @p f Hz through the filter (sampled at 600 Hz, cut-off 6 Hz), measured
/// in the middle of a long signal.
double gain(double f) {
  const double dt = 1.0 / 600;
  std::vector<double> x;
  for (int i = 0; i < 12000; ++i) x.push_back(std::sin(2 * M_PI * f * i * dt));
  const std::vector<double> y = lowpassIIR(x, dt, 6.0);
  double ax = 0, ay = 0;
  for (int i = 5000; i < 7000; ++i) {
    ax = std::max(ax, std::abs(x[i]));
    ay = std::max(ay, std::abs(y[i]));
  }
  return ay / ax;
}

TEST(Lowpass, ButterworthResponseForwardsAndBackwards) {
  // A third-order Butterworth by the bilinear transform has |H|^2 = 1 / (1 + (tan(pi f T) /
  // tan(pi fc T))^6); run twice, the gain is |H|^2.
  const double T = 1.0 / 600;
  for (double f : {2.0, 6.0, 12.0}) {
    const double r = std::tan(M_PI * f * T) / std::tan(M_PI * 6.0 * T);
    EXPECT_NEAR(gain(f), 1.0 / (1.0 + std::pow(r, 6)), 2e-3) << f;
  }
  // A constant passes unchanged (unit DC gain), the copied first samples included.
  const std::vector<double> c = lowpassIIR(std::vector<double>(50, 3.5), T, 6.0);
  for (double v : c) EXPECT_NEAR(v, 3.5, 1e-9);
}

TEST(Lowpass, ResamplesUnevenTimesAtTheSmallestStep) {
  SampledTable t;
  for (int i = 0; i < 200; ++i) t.time.push_back(i * 0.01 + (i % 3 == 0 ? 0.0 : 1e-9 * i));
  t.time[10] += 0.002;  // one step of 12 ms, one of 8 ms
  t.columns.push_back(std::vector<double>(200));
  for (int i = 0; i < 200; ++i) t.columns[0][i] = 2.0 + 0.5 * t.time[i];
  lowpassTable(t, 5.0);
  ASSERT_GE(t.time.size(), 200u);
  const double dt = t.time[1] - t.time[0];
  EXPECT_NEAR(dt, 0.008, 1e-6);
  for (size_t i = 1; i < t.time.size(); ++i) EXPECT_NEAR(t.time[i] - t.time[i - 1], dt, 1e-12);
  // A straight line survives resampling and filtering away from the ends' transients.
  for (size_t i = 60; i + 60 < t.time.size(); ++i) EXPECT_NEAR(t.columns[0][i], 2.0 + 0.5 * t.time[i], 2e-5);
}

TEST(Lowpass, RejectsTooFewOrUnorderedSamples) {
  SampledTable t{{0, 0.1, 0.2}, {{1, 2, 3}}};
  EXPECT_THROW(lowpassTable(t, 6), std::invalid_argument);
  SampledTable u{{0, 0.1, 0.1, 0.3, 0.4}, {{1, 2, 3, 4, 5}}};
  EXPECT_THROW(lowpassTable(u, 6), std::invalid_argument);
}

}  // namespace
}  // namespace kneesim::dynamics
