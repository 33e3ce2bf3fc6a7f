#include "gap/remaining.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace kneesim::gap {
namespace {

// Ten gait-like cycles of 1 s at 120 Hz in two recordings; flexion, its rate, an area, a vertical GRF
// and the recording's time as channels; the residual is smooth noise of 100 N (an AR(1) with a 50 ms
// correlation time, the diagnosis's noise level) plus a chosen structure. Folds: five of two cycles.
struct World {
  std::vector<identify::Trial> trials;
  RemainingData data;
};

enum class Structure { none, direction_times_load, varying_gain, wander, offset };

World makeWorld(Structure s, unsigned seed, double size) {
  World w;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> z(0, 1);
  const double dt = 1.0 / 120, rho = std::exp(-dt / 0.05);
  w.trials.resize(2);
  int unit = 0;
  for (int t = 0; t < 2; ++t) {
    auto& tr = w.trials[t];
    std::vector<double> res, fit_res, pred, phase;
    std::vector<int> units;
    std::mt19937_64 rng_drift(seed * 31 + t);  // its own stream: the other structures' draws stay as they were
    double e = 100 * z(rng), drift = size * z(rng_drift);
    const double offset = (t == 0 ? 1 : -1) * size;  // the recordings' own offsets, opposite
    const double rho_drift = std::exp(-dt / 5.0);  // the stress suite's wander: 5 s correlation time
    for (int c = 0; c < 5; ++c, ++unit) {
      const double amp = 1 + 0.1 * z(rng), load = 700 * (1 + 0.1 * z(rng)), gain = size * z(rng);
      for (int k = 0; k < 120; ++k) {
        const double ph = k / 120.0, time = (c * 120 + k) * dt;
        const double th = 0.2 + 0.5 * amp * std::pow(std::sin(M_PI * ph), 2);
        const double rate = 0.5 * amp * M_PI * std::sin(2 * M_PI * ph);  // d theta / d t (cycle of 1 s)
        const double grf = ph < 0.6 ? load * std::sin(M_PI * ph / 0.6) : 0.0;
        const double f = 400 + 1.2 * grf;
        tr.time.push_back(time);
        tr.channels["knee_flexion"].push_back(th);
        tr.channels["knee_flexion_rate"].push_back(rate);
        tr.channels["S"].push_back(2.3e-3 + 4e-4 * th);
        tr.channels["GRF:vertical"].push_back(grf);
        tr.channels["trial_time"].push_back(time);
        e = rho * e + 100 * std::sqrt(1 - rho * rho) * z(rng);
        double g = 0;
        if (s == Structure::direction_times_load) g = size * std::tanh(rate / 0.3) * grf / 700;
        if (s == Structure::varying_gain) g = gain * f;
        drift = rho_drift * drift + size * std::sqrt(1 - rho_drift * rho_drift) * z(rng_drift);
        if (s == Structure::wander) g = drift;
        if (s == Structure::offset) g = offset;
        res.push_back(e + g);
        fit_res.push_back(e + g);
        pred.push_back(f);
        phase.push_back(ph);
        units.push_back(unit);
      }
    }
    w.data.residual.push_back(res);
    w.data.fitted_residual.push_back(fit_res);
    w.data.prediction.push_back(pred);
    w.data.phase.push_back(phase);
    w.data.unit.push_back(units);
  }
  for (auto& tr : w.trials) w.data.trials.push_back(&tr);
  w.data.unit_activity.assign(10, "gait");
  for (int f = 0; f < 5; ++f) w.data.folds.push_back({2 * f, 2 * f + 1});
  return w;
}

// Pure noise: each test finds something at its level (1/80 per seed: at most 2 of 20 seeds at any
// plausible rate), the noise floor is the noise (100 N) and the withheld error is consistent with it.
TEST(Remaining, PureNoiseLeavesNothing) {
  int check = 0, hetero = 0, consistent = 0, above = 0, wander = 0;
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const World w = makeWorld(Structure::none, seed, 0);
    const AgnosticCheck c = runAgnosticCheck(w.data);
    ASSERT_TRUE(c.run) << c.note;
    check += c.significant;
    const NoiseFloor nf = estimateNoiseFloor(w.data);
    ASSERT_TRUE(nf.run) << nf.note;
    // Matched frames of other cycles differ by the noise alone: sqrt(E (e_i - e_j)^2 / 2) = 100 N.
    EXPECT_NEAR(nf.floor, 100, 20);
    EXPECT_NEAR(nf.rmse, 100, 20);
    above += nf.above;
    consistent += nf.consistent;
    const CycleHeterogeneity h = testCycleHeterogeneity(w.data);
    ASSERT_TRUE(h.run) << h.note;
    EXPECT_EQ(h.dof, 2000 + 1);  // 10! pairings: 2000 drawn, and the observed one
    hetero += h.significant;
    const RecordingWander rw = testRecordingWander(w.data);
    ASSERT_TRUE(rw.run) << rw.note;
    EXPECT_EQ(rw.recordings, 2);
    EXPECT_EQ(rw.cells, 40);  // two recordings of five cycles and four quarters
    EXPECT_EQ(rw.draws, 2000);
    wander += rw.significant;
  }
  EXPECT_LE(check, 2);
  EXPECT_LE(wander, 2);
  EXPECT_LE(above, 2);
  EXPECT_LE(hetero, 2);
  EXPECT_GE(consistent, 18);
}

// The flexion's direction times the load, 150 N at full load (outside any catalogue's single effect):
// found in every seed and carried by the signals it is a function of -- the flexion rate and the GRF,
// or the cycle's phase, which here fixes both; the noise floor still sees only the noise (the
// structure is a function of the matched signals) and the withheld error is above it (at a fifth of
// 5 %, since the wander test joined the family, in 4 of the 5 seeds).
TEST(Remaining, FindsADirectionTimesLoadStructureAndNamesItsSignals) {
  int above = 0;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    SCOPED_TRACE(seed);
    const World w = makeWorld(Structure::direction_times_load, seed, 150);
    const AgnosticCheck c = runAgnosticCheck(w.data);
    EXPECT_TRUE(c.significant) << "reduction " << c.reduction << " lower " << c.reduction_lower << " score t "
                               << c.score_t;
    double carriers = 0;  // the predicted force here is 400 N + 1.2 GRF: the GRF under another name
    for (const auto& im : c.importance)
      if (im.signal == "knee_flexion_rate" || im.signal == "GRF:vertical" || im.signal == "cycle phase" ||
          im.signal == "predicted force")
        carriers += im.share;
    EXPECT_GT(carriers, 0.5);
    ASSERT_EQ(c.dependence.size(), 3u);
    EXPECT_EQ(c.dependence[0].signal, c.importance[0].signal);
    const NoiseFloor nf = estimateNoiseFloor(w.data);
    EXPECT_NEAR(nf.floor, 100, 25);
    above += nf.above;
  }
  EXPECT_GE(above, 4);
}

// The direction alone, +-150 N by the sign of the flexion rate in every frame: the partial dependence on
// the rate rises by over a third of the 300 N between the two (the rest the trees give the cycle's
// phase, which fixes the rate's sign here too).
TEST(Remaining, PartialDependenceFollowsTheStructure) {
  World w = makeWorld(Structure::none, 7, 0);
  for (size_t t = 0; t < w.trials.size(); ++t)
    for (size_t i = 0; i < w.trials[t].time.size(); ++i)
      w.data.residual[t][i] += 150 * std::tanh(w.trials[t].channels.at("knee_flexion_rate")[i] / 0.3);
  const AgnosticCheck c = runAgnosticCheck(w.data);
  ASSERT_TRUE(c.significant);
  const PartialDependence* pd = nullptr;
  for (const auto& d : c.dependence)
    if (d.signal == "knee_flexion_rate") pd = &d;
  ASSERT_NE(pd, nullptr);
  // Rising with the rate: the fit at the largest rates minus that at the most negative, in N.
  EXPECT_GT(pd->y.back() - pd->y.front(), 100);
  EXPECT_LT(pd->x.front(), -1.0);
  EXPECT_GT(pd->x.back(), 1.0);
}

// A gain that changes from cycle to cycle (SD 30 % of a force of 400-1240 N): no signal predicts it on a
// withheld cycle, and matched frames of two cycles differ by it, so the noise floor takes it up; the
// two halves of each cycle agree on it, which sizes its SD too.
TEST(Remaining, SeesAGainVaryingFromCycleToCycle) {
  int found = 0;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const World w = makeWorld(Structure::varying_gain, seed, 0.3);
    const CycleHeterogeneity h = testCycleHeterogeneity(w.data);
    found += h.significant;
    EXPECT_NEAR(h.gain_sd, 0.3, 0.15);
    const AgnosticCheck c = runAgnosticCheck(w.data);
    EXPECT_FALSE(c.significant);
  }
  EXPECT_GE(found, 4);
}

// A wander of the recording's offset (an Ornstein-Uhlenbeck series with a 5 s correlation time,
// independent per recording, as the stress suite injects): the quarter cycles agree with their neighbours
// in time beyond their successive differences. Measured (10 seeds, at a fifth of 5 %): found in 4 at 50 N,
// 7 at 100 N, 10 at 200 N; the same worlds without it: WanderTestHoldsItsLevelOnSmoothNoise.
TEST(Remaining, SeesAWanderWithinARecording) {
  for (double size : {100.0, 200.0}) {
    int found = 0;
    double sd = 0;
    for (unsigned seed = 1; seed <= 10; ++seed) {
      const RecordingWander w = testRecordingWander(makeWorld(Structure::wander, seed, size).data);
      ASSERT_TRUE(w.run) << w.note;
      found += w.significant;
      sd += w.wander_sd / 10;
    }
    EXPECT_GE(found, size > 150 ? 9 : 5);
    EXPECT_GT(sd, 0.6 * size);  // measured 84 and 166 N
    EXPECT_LT(sd, size);
  }
}

// Each recording's own offset (+-100 N, the same over its five cycles): a model error common to its cycles
// or a shift of the load cells' zero. The former trend test took the recording's mean curve out and could
// not see it; the successive differences do not move with it. Measured: 10 of 10 at 100 N, 4 of 10 at 50 N.
TEST(Remaining, SeesARecordingsOwnOffset) {
  for (double size : {50.0, 100.0}) {
    int found = 0;
    for (unsigned seed = 1; seed <= 10; ++seed)
      found += testRecordingWander(makeWorld(Structure::offset, seed, size).data).significant;
    EXPECT_GE(found, size > 75 ? 9 : 2);
  }
}

// The test's level on pure smooth noise (100 N, 50 ms): 400 worlds at 5 % (measured 21, 5.3 %; over 2000
// worlds 122 at 5 % and 30 at 1 %: the quarters' small positive correlation makes it a little liberal).
TEST(Remaining, WanderTestHoldsItsLevelOnSmoothNoise) {
  RemainingOptions o;
  o.alpha = 0.05;
  int found = 0;
  for (unsigned seed = 1; seed <= 400; ++seed) found += testRecordingWander(makeWorld(Structure::none, seed, 0).data, o).significant;
  EXPECT_GE(found, 8);
  EXPECT_LE(found, 32);
}

}  // namespace
}  // namespace kneesim::gap
