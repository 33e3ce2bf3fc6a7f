#include "gap/signals.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace kneesim::gap {
namespace {

// A second-order Butterworth run forwards and backwards has gain 1 / (1 + (w / wc)^4) with the
// bilinear transform's pre-warped frequencies w = tan(pi f / fs).
double filtfiltGain(double f, double fs, double fc) {
  const double r = std::tan(M_PI * f / fs) / std::tan(M_PI * fc / fs);
  return 1 / (1 + std::pow(r, 4));
}

TEST(Signals, LowPassGainMatchesTheButterworthResponse) {
  const double fs = 120, fc = 6;
  for (double f : {1.0, 6.0, 20.0}) {
    std::vector<double> x;
    for (int i = 0; i < 1200; ++i) x.push_back(std::sin(2 * M_PI * f * i / fs));
    const std::vector<double> y = lowPass(x, fs, fc);
    double amp = 0;  // amplitude away from the ends
    for (int i = 300; i < 900; ++i) amp = std::max(amp, std::abs(y[i]));
    EXPECT_NEAR(amp, filtfiltGain(f, fs, fc), 2e-3) << f << " Hz";
  }
}

TEST(Signals, IsotonicRegressionByHandAndAgainstBruteForce) {
  // Pool-adjacent-violators by hand: 1 3 2 4 -> 1 2.5 2.5 4, SSE 0.5.
  const IsotonicFit f = fitIsotonic({1, 2, 3, 4}, {1, 3, 2, 4});
  EXPECT_EQ(f.x, (std::vector<double>{1, 2, 3, 4}));
  EXPECT_EQ(f.y, (std::vector<double>{1, 2.5, 2.5, 4}));
  EXPECT_NEAR(f.sse, 0.5, 1e-12);
  EXPECT_DOUBLE_EQ(f.evaluate(0), 1);
  EXPECT_DOUBLE_EQ(f.evaluate(1.5), 1.75);
  EXPECT_DOUBLE_EQ(f.evaluate(2.7), 2.5);
  // Ties pool before anything else: y = 3 and 1 at x = 2 make one block of 2.
  const IsotonicFit t = fitIsotonic({1, 2, 2, 3}, {0, 3, 1, 5});
  EXPECT_EQ(t.y, (std::vector<double>{0, 2, 5}));
  // Random data: the fit is monotone and no monotone step function on the same points does better
  // (brute force over every assignment to 4 levels of 7 points is too many; compare with the best
  // of 20000 random monotone fits and with the constant fit).
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0, 1);
  std::vector<double> x, y;
  for (int i = 0; i < 7; ++i) x.push_back(i), y.push_back(0.3 * i + g(rng));
  const IsotonicFit h = fitIsotonic(x, y);
  for (size_t k = 1; k < h.y.size(); ++k) EXPECT_GE(h.y[k], h.y[k - 1]);
  double best = 1e300;
  std::uniform_real_distribution<double> u(-3, 5);
  for (int trial = 0; trial < 20000; ++trial) {
    std::vector<double> v(7);
    for (auto& a : v) a = u(rng);
    std::sort(v.begin(), v.end());
    double sse = 0;
    for (int i = 0; i < 7; ++i) sse += (y[i] - v[i]) * (y[i] - v[i]);
    best = std::min(best, sse);
  }
  EXPECT_LE(h.sse, best);
  double sse_fit = 0;
  for (int i = 0; i < 7; ++i) sse_fit += (y[i] - h.evaluate(x[i])) * (y[i] - h.evaluate(x[i]));
  EXPECT_NEAR(sse_fit, h.sse, 1e-9);
}

TEST(Signals, DistributionsAgainstTables) {
  EXPECT_NEAR(normalQuantile(0.975), 1.959964, 1e-6);
  EXPECT_NEAR(studentQuantile(0.975, 5), 2.570582, 1e-6);
  EXPECT_NEAR(studentQuantile(0.95, 1), 6.313752, 1e-5);
  EXPECT_NEAR(studentCdf(0, 3), 0.5, 1e-12);
  EXPECT_NEAR(chiSquareSurvival(3.841459, 1), 0.05, 1e-6);
  EXPECT_NEAR(chiSquareSurvival(18.307038, 10), 0.05, 1e-6);
  EXPECT_NEAR(chiSquareSurvival(0.5, 2), std::exp(-0.25), 1e-12);  // dof 2: exp(-x/2)
  // F tables' 95 % points (F(3, 6) = 4.757063, F(10, 60) = 1.992592) and the closed form for dof1 = 2,
  // P(F > f) = (1 + 2 f / dof2)^(-dof2 / 2); F(1, d) is a squared Student t.
  EXPECT_NEAR(fisherSurvival(4.757063, 3, 6), 0.05, 1e-6);
  EXPECT_NEAR(fisherSurvival(1.992592, 10, 60), 0.05, 1e-6);
  EXPECT_NEAR(fisherSurvival(3.7, 2, 7.5), std::pow(1 + 2 * 3.7 / 7.5, -7.5 / 2), 1e-12);
  EXPECT_NEAR(fisherSurvival(2.1 * 2.1, 1, 9), 2 * (1 - studentCdf(2.1, 9)), 1e-12);
  EXPECT_EQ(fisherSurvival(0, 3, 4), 1.0);
  EXPECT_TRUE(std::isnan(fisherSurvival(1, 0, 4)));
  const MeanInterval m = meanInterval({1, 2, 3, 4});
  EXPECT_DOUBLE_EQ(m.mean, 2.5);
  EXPECT_NEAR(m.sd, 1.2909944, 1e-7);
  EXPECT_NEAR(m.upper - m.mean, 3.182446 * 1.2909944 / 2, 1e-5);
  const MeanInterval w = weightedMeanInterval({1, 2, 3, 4}, {1, 1, 1, 1});
  EXPECT_NEAR(w.upper, m.upper, 1e-9);
  EXPECT_DOUBLE_EQ(effectiveCount({1, 1, 2}), 16.0 / 6.0);
}

TEST(Signals, AutoregressionRecoversAnArProcessAndWhitensIt) {
  // x_t = 1.6 x_{t-1} - 0.8 x_{t-2} + e_t, e ~ N(0, 1): three runs of 2000, one broken by a NaN.
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<std::vector<double>> runs(3, std::vector<double>(2000, 0.0));
  double e2 = 0;
  int ne = 0;
  for (auto& x : runs)
    for (size_t t = 2; t < x.size(); ++t) {
      const double e = g(rng);
      x[t] = 1.6 * x[t - 1] - 0.8 * x[t - 2] + e;
      if (t >= 4) e2 += e * e, ++ne;
    }
  runs[1][1000] = std::nan("");
  const std::vector<double> phi = fitAutoregression(runs);  // order by BIC
  ASSERT_GE(phi.size(), 2u);
  EXPECT_NEAR(phi[0], 1.6, 0.05);
  EXPECT_NEAR(phi[1], -0.8, 0.05);
  for (size_t k = 2; k < phi.size(); ++k) EXPECT_NEAR(phi[k], 0.0, 0.05);
  const std::vector<double> fixed2 = fitAutoregression(runs, 2);
  ASSERT_EQ(fixed2.size(), 2u);
  // Whitened with the true filter, the innovations come back: their sum of squares, run 0 (from t = 2).
  double s_true = 0;
  for (size_t t = 2; t < runs[0].size(); ++t) {
    const double e = runs[0][t] - 1.6 * runs[0][t - 1] + 0.8 * runs[0][t - 2];
    s_true += e * e;
  }
  EXPECT_NEAR(whitenedSumOfSquares({1.6, -0.8}, runs[0]), s_true, 1e-9 * s_true);
  EXPECT_NEAR(whitenedSumOfSquares(fixed2, runs[0]) / 1998, 1.0, 0.1);  // unit innovation variance
  // The NaN removes itself and the two samples that need it as history.
  const double broken = whitenedSumOfSquares({1.6, -0.8}, runs[1]);
  std::vector<double> head(runs[1].begin(), runs[1].begin() + 1000), tail(runs[1].begin() + 1001, runs[1].end());
  EXPECT_NEAR(broken, whitenedSumOfSquares({1.6, -0.8}, head) + whitenedSumOfSquares({1.6, -0.8}, tail), 1e-9 * broken);
  // No filter: the plain sum of squares; too few samples: no filter.
  EXPECT_NEAR(whitenedSumOfSquares({}, {1, 2, 3}), 14.0, 1e-12);
  EXPECT_TRUE(fitAutoregression({{1, 2, 3, 4, 5}}).empty());
}

TEST(Signals, RelativeReductionOfPairedTotals) {
  // b = 0.7 a exactly: R = 0.3 with no spread.
  const MeanInterval exact = relativeReductionInterval({1, 2, 3, 4}, {0.7, 1.4, 2.1, 2.8});
  EXPECT_NEAR(exact.mean, 0.3, 1e-12);
  EXPECT_NEAR(exact.sd, 0.0, 1e-12);
  EXPECT_NEAR(exact.lower, 0.3, 1e-12);
  // By hand: a = (2, 4, 6), b = (1, 4, 3): R = 1 - 8/12 = 1/3; d = (1, 0, 3), d - R a = (1/3, -4/3,
  // 1); se^2 = 3/2 (1/9 + 16/9 + 1) / 144 = 3/2 * 26/9 / 144; interval R -+ t(0.975, 2) se.
  const MeanInterval m = relativeReductionInterval({2, 4, 6}, {1, 4, 3});
  const double se = std::sqrt(1.5 * 26.0 / 9.0 / 144.0);
  EXPECT_NEAR(m.mean, 1.0 / 3.0, 1e-12);
  EXPECT_NEAR(m.sd, se * std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(m.upper - m.mean, 4.302653 * se, 1e-6);
  EXPECT_EQ(m.n, 3);
  // It weighs units by their totals, unlike a mean of per-unit log ratios: a loud unit that halves
  // outweighs a quiet one that doubles.
  const MeanInterval w = relativeReductionInterval({100, 1}, {50, 2});
  EXPECT_NEAR(w.mean, 1 - 52.0 / 101.0, 1e-12);
  EXPECT_TRUE(std::isnan(relativeReductionInterval({}, {}).mean));
  EXPECT_TRUE(std::isnan(relativeReductionInterval({5}, {4}).lower));
}

TEST(Signals, CorrelationsDerivativesAndInterpolation) {
  EXPECT_NEAR(pearson({1, 2, 3, 4}, {2, 4, 6, 8.0}), 1.0, 1e-12);
  EXPECT_NEAR(pearson({1, 2, 3, 4}, {1, 3, 2, 4}), 0.8, 1e-12);
  EXPECT_TRUE(std::isnan(pearson({1, 1, 1}, {1, 2, 3})));
  EXPECT_DOUBLE_EQ(effectiveSampleSize(100, 0.5, 0.5), 100 * 0.75 / 1.25);
  const auto ci = correlationInterval(0.5, 103);
  EXPECT_NEAR(ci.first, std::tanh(std::atanh(0.5) - 1.959964 / 10), 1e-6);
  const auto d = derivative({0, 1, 3}, {0, 1, 9});
  EXPECT_DOUBLE_EQ(d[0], 1);
  EXPECT_DOUBLE_EQ(d[1], 3);
  EXPECT_DOUBLE_EQ(d[2], 4);
  const auto v = interpolate({0, 1, 2}, {0, 10, 20}, {-0.1, 0.5, 1.5, 2.05, 3}, 0.1);
  EXPECT_DOUBLE_EQ(v[0], 0);
  EXPECT_DOUBLE_EQ(v[1], 5);
  EXPECT_DOUBLE_EQ(v[2], 15);
  EXPECT_DOUBLE_EQ(v[3], 20);
  EXPECT_TRUE(std::isnan(v[4]));
  // The envelope of a 100 Hz carrier modulated at 1 Hz follows the modulation (mean |sin| = 2/pi).
  std::vector<double> emg;
  for (int i = 0; i < 2400; ++i) {
    const double t = i / 1200.0;
    emg.push_back((1 + 0.5 * std::sin(2 * M_PI * t)) * std::sin(2 * M_PI * 100 * t) + 0.3);
  }
  const auto env = emgEnvelope(emg, 1200);
  EXPECT_NEAR(env[300], (1 + 0.5) * 2 / M_PI, 0.03);  // t = 0.25 s, modulation peak
  EXPECT_NEAR(env[900], (1 - 0.5) * 2 / M_PI, 0.03);  // t = 0.75 s, trough
}

}  // namespace
}  // namespace kneesim::gap
