// NoiseMetric: the synthetic noise's Mahalanobis metric behind the blind suite's best-possible
// rates (OracleBound), checked against closed forms; and what the generator refuses.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "gap/synth.hpp"
#include "plugin/registry.hpp"
#include "support/input_error.hpp"

namespace kneesim::gap {
namespace {

SynthOptions noise(double smooth_sd, double white_sd) {
  SynthOptions o;
  o.noise_sd = smooth_sd;
  o.white_sd = white_sd;
  o.noise_time = 0.05;  // the generator's default: cut-off 1 / (2 pi 0.05 s) = 3.18 Hz
  return o;
}

TEST(NoiseMetric, WhiteNoiseOnlyIsTheScaledSquaredNorm) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g(0, 30);
  std::vector<double> d(200);
  double ss = 0;
  for (double& x : d) x = g(rng), ss += x * x;
  const NoiseMetric m(noise(0, 5));
  EXPECT_NEAR(m.calcSquaredDistance(d, 100), ss / 25, 1e-6 * ss / 25);
}

TEST(NoiseMetric, FastDifferencesSeeOnlyTheWhitePart) {
  // At the Nyquist frequency the smooth noise (cut-off 3.18 Hz, 8th-order roll-off) has no power:
  // a +-1 N alternation over n frames has D^2 = n / white_sd^2.
  std::vector<double> d(300);
  for (size_t i = 0; i < d.size(); ++i) d[i] = i % 2 ? 1.0 : -1.0;
  const NoiseMetric m(noise(100, 5));
  EXPECT_NEAR(m.calcSquaredDistance(d, 100), 300.0 / 25, 0.02 * 300.0 / 25);
  // Low-passed at 6 Hz first, it is gone.
  const NoiseMetric band(noise(100, 5), 6);
  EXPECT_LT(band.calcSquaredDistance(d, 100), 1e-3 * 300.0 / 25);
}

TEST(NoiseMetric, SlowDifferencesAreHiddenByTheSmoothNoise) {
  // A constant difference c over T seconds against noise of SD sigma whose one-sided density at 0 Hz
  // is sigma^2 / B (B: the equivalent noise bandwidth of the forward-backward 2nd-order Butterworth,
  // |H|^2 = 1 / (1 + (f / fc)^8), B = fc (pi / 8) / sin(pi / 8) = 3.266 Hz): D^2 = 2 c^2 T B / sigma^2
  // = 19.6 for c = sigma = 100 N, T = 3 s. Ends and the finite record make it approximate.
  const double fc = 1 / (2 * M_PI * 0.05), b = fc * (M_PI / 8) / std::sin(M_PI / 8);
  const double expected = 2 * 3.0 * b;
  std::vector<double> d(300, 100.0);
  const NoiseMetric m(noise(100, 5));
  const double d2 = m.calcSquaredDistance(d, 100);
  std::printf("[ info     ] D^2 = %.2f, closed form %.2f\n", d2, expected);
  EXPECT_NEAR(d2, expected, 0.25 * expected);
  // Under white noise of the same SD it would be n = 300.
  EXPECT_GT(NoiseMetric(noise(0, 100)).calcSquaredDistance(d, 100), 10 * d2);
}

// Requests the generator cannot honour are one-line errors before any trial is made (no source
// trials are needed to get them): an injected value outside its effect's bounds (the plugin's
// interpolation would be extrapolated, and no fit could recover it), negative noise, no replicates,
// no seeds.
TEST(Synth, RequestsOutsideTheirRangesAreOneLineErrors) {
  using ::testing::HasSubstr;
  using kneesim::test::inputErrorOf;
  plugin::Registry reg;
  reg.loadPlugin("hertz");
  reg.loadPlugin("gap_effects");
  const identify::ContactLaw hertz = identify::ContactLaw::fromRegistry(reg, "hertz");
  const std::vector<Effect> catalogue = {Effect::fromRegistry(reg, "threshold")};
  SynthOptions o;
  o.effects = {{"threshold", {{"dh", -0.01}}}};
  EXPECT_EQ(inputErrorOf([&] { makeSyntheticTrials(hertz, catalogue, {}, o); }),
            "synthetic effect threshold.dh: expected a value within its bounds [-0.002, 0.002] m, got -0.01");
  o.effects = {{"threshold", {{"dh", -0.0015}}}};
  EXPECT_EQ(makeSyntheticTrials(hertz, catalogue, {}, o).size(), 0u);  // in bounds: nothing to refuse
  o.noise_sd = -1;
  EXPECT_THAT(inputErrorOf([&] { makeSyntheticTrials(hertz, catalogue, {}, o); }),
              HasSubstr("synthetic noise: expected standard deviations >= 0 N, got -1 N (smooth)"));
  o.noise_sd = 100;
  o.replicates = 0;
  EXPECT_THAT(inputErrorOf([&] { makeSyntheticTrials(hertz, catalogue, {}, o); }),
              HasSubstr("expected at least 1 replicate per source trial, got 0"));
  BlindSuiteOptions bo;
  bo.seeds = 0;
  EXPECT_EQ(inputErrorOf([&] { runBlindSuite(hertz, catalogue, {}, bo); }),
            "blind suite: expected at least 1 seed per case, got 0");
}

// What counts as a right answer in the blind suite. A visible effect must be named; nothing
// injected must give the baseline; the outside bump must give "none". An absorbed effect (its right
// answer turned into "baseline") may also be named itself -- it is there -- but no other effect may.
TEST(Synth, AnAbsorbedEffectMayBeNamedButNoOtherEffect) {
  const std::vector<InjectedEffect> gain = {{"flexion_gain", {{"gain", 0.2}}}};
  EXPECT_TRUE(isRightAnswer("threshold", "threshold", {{"threshold", {{"dh", -0.0015}}}}));
  EXPECT_FALSE(isRightAnswer("baseline", "threshold", {{"threshold", {{"dh", -0.0015}}}}));
  EXPECT_FALSE(isRightAnswer("flexion_gain", "threshold", {{"threshold", {{"dh", -0.0015}}}}));
  EXPECT_TRUE(isRightAnswer("baseline", "baseline", gain));
  EXPECT_TRUE(isRightAnswer("flexion_gain", "baseline", gain));
  EXPECT_FALSE(isRightAnswer("threshold", "baseline", gain));
  EXPECT_FALSE(isRightAnswer("none of the candidates", "baseline", gain));
  EXPECT_TRUE(isRightAnswer("undecided", "baseline", gain));
  EXPECT_FALSE(isRightAnswer("undecided", "baseline", {}));
  EXPECT_FALSE(isRightAnswer("undecided", "threshold", {{"threshold", {{"dh", -0.0015}}}}));
  EXPECT_TRUE(isRightAnswer("baseline", "baseline", {}));
  EXPECT_FALSE(isRightAnswer("flexion_gain", "baseline", {}));
  EXPECT_TRUE(isRightAnswer("none of the candidates", "none of the candidates", {}));
  EXPECT_FALSE(isRightAnswer("baseline", "none of the candidates", {}));
}

// The matrix gives each case's rate of right answers with its 95 % Wilson interval (17 of 20:
// 64-95 %, the figures of Statistics.WilsonIntervalOfABinomialProportion), so that 17 and 18 of 20
// read as what they are: not told apart by 20 seeds.
TEST(Synth, TheMatrixGivesEachRateWithItsInterval) {
  BlindSuiteResult res;
  res.rows = {"threshold"};
  res.columns = {"threshold", "baseline", "none of the candidates"};
  res.counts = {{17, 3, 0}};
  res.expected["threshold"] = "threshold";
  for (int seed = 1; seed <= 20; ++seed) {
    BlindOutcome o;
    o.case_name = "threshold";
    o.expected = "threshold";
    o.seed = seed;
    o.answer = seed <= 17 ? "threshold" : "baseline";
    o.correct = o.correct_or_confusable = seed <= 17;
    res.outcomes.push_back(o);
  }
  const std::string md = res.formatMarkdown();
  EXPECT_NE(md.find("| threshold | 17 | 3 | . | 17/20 [64–95 %] | 17/20 |"), std::string::npos) << md;
}

}  // namespace
}  // namespace kneesim::gap
