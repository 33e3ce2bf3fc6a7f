// Cost of the gap diagnosis: an extended law's force and Jacobian (a force-map effect, and a
// rewrite effect whose derivatives are central differences through the pipeline), and one whole
// blind diagnosis of synthetic gait-like recordings (4 recordings x 3 cycles at 120 Hz, every effect
// of the gap_effects plugin screened where the recordings carry its channels, top 3 fitted, 5-fold
// cross-validation) with a 30 ms delay injected.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "gap/diagnosis.hpp"
#include "gap/synth.hpp"
#include "plugin/registry.hpp"

namespace {

using namespace kneesim;

// Three gait-like cycles of analytic contact area, flexion, GRF and EMG channels.
gap::GapTrial makeRecording(const std::string& name, double shift) {
  gap::GapTrial g;
  g.activity = "gait";
  g.trial.name = name;
  const int n = 3 * 132;
  for (int i = 0; i < n; ++i) {
    const double t = i / 120.0, x = std::fmod(t + shift, 1.1) / 1.1;
    const auto bump = [&](double c, double w) { return std::exp(-std::pow((x - c) / w, 2)); };
    const double s = 1e-6 * (150 + 700 * bump(0.12, 0.07) + 800 * bump(0.45, 0.08) + 250 * bump(0.3, 0.1));
    auto& ch = g.trial.channels;
    g.trial.time.push_back(t);
    ch["S"].push_back(s);
    ch["S_medial"].push_back(0.55 * s);
    ch["S_lateral"].push_back(0.45 * s);
    for (int mm : {2, 3, 5, 6}) ch["S@" + std::to_string(mm) + "mm"].push_back(s + 2.5e-4 * (mm - 4) * (1 + 0.2 * x));
    ch["knee_flexion"].push_back(0.1 + 0.9 * bump(0.75, 0.12));
    ch["GRF:vertical"].push_back(700 * (bump(0.12, 0.08) + bump(0.45, 0.08)));
    ch["EMG:cocontraction"].push_back(0.2 + 0.3 * bump(0.1, 0.1));
    ch["dS_dap"].push_back(0.02 * s * std::sin(7 * x));
    g.trial.measured_force.push_back(0);
    g.medial.push_back(0);
    g.lateral.push_back(0);
  }
  auto& ch = g.trial.channels;
  ch["dS_dt"] = gap::derivative(g.trial.time, ch["S"]);
  ch["knee_flexion_rate"] = gap::derivative(g.trial.time, ch["knee_flexion"]);
  std::vector<double> r(n);
  for (int i = 0; i < n; ++i) r[i] = ch["dS_dt"][i] * ch["knee_flexion_rate"][i] / (std::pow(ch["knee_flexion_rate"][i], 2) + 1);
  ch["dS_dflexion"] = r;
  std::vector<double> starts;
  for (double t0 = 1.1 - shift; t0 < g.trial.time.back(); t0 += 1.1) starts.push_back(t0);
  gap::setCycles(g, starts, {});
  return g;
}

struct Setup {
  plugin::Registry registry;
  std::unique_ptr<identify::ContactLaw> hertz;
  std::vector<gap::Effect> catalogue;
  Setup() {
    registry.loadPlugin("hertz");
    registry.loadPlugin("gap_effects");
    hertz = std::make_unique<identify::ContactLaw>(identify::ContactLaw::fromRegistry(registry, "hertz"));
    for (const auto& n : registry.getEffectNames()) catalogue.push_back(gap::Effect::fromRegistry(registry, n));
  }
};

Setup& setup() {
  static Setup s;
  return s;
}

void BM_ExtendedLawForceAndJacobian(benchmark::State& state, const char* effect) {
  Setup& s = setup();
  const gap::GapTrial g = makeRecording("r", 0.0);
  const identify::ContactLaw law = gap::makeExtendedLaw(*s.hertz, {gap::Effect::fromRegistry(s.registry, effect)});
  const identify::LawInputs in(law, g.trial.channels, g.trial.time, "r");
  Eigen::VectorXd p = law.getDefaultValues(), f;
  p[0] = 2e7;
  p[3] = law.getParameter(3).typical_scale;
  Eigen::MatrixXd j;
  for (auto _ : state) {
    law.calcForce(p, in, f, &j);
    benchmark::DoNotOptimize(f.data());
  }
  state.SetItemsProcessed(state.iterations() * in.getNumFrames());
  state.counters["us_per_frame"] =
      benchmark::Counter(in.getNumFrames() * 1e-6, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK_CAPTURE(BM_ExtendedLawForceAndJacobian, time_delay_map, "time_delay");
BENCHMARK_CAPTURE(BM_ExtendedLawForceAndJacobian, flexion_offset_rewrite, "flexion_offset");

void BM_BlindDiagnosis(benchmark::State& state) {
  Setup& s = setup();
  std::vector<gap::GapTrial> sources;
  for (int k = 0; k < 4; ++k) sources.push_back(makeRecording("r" + std::to_string(k), 0.05 * k));
  gap::SynthOptions so;
  so.base_values = {{"E", 2e7}};
  so.effects = {{"time_delay", {{"delay", 0.03}}}};
  so.replicates = 1;
  const auto trials = gap::makeSyntheticTrials(*s.hertz, s.catalogue, sources, so);
  identify::FitOptions fit;
  fit.free_parameters = {"E", "nu"};
  fit.assumed_values = {{"nu", 0.45}};
  const gap::DiagnosisOptions o = gap::getStandardBlindSuiteOptions(fit).diagnosis;
  std::string verdict;
  for (auto _ : state) verdict = gap::diagnose(*s.hertz, s.catalogue, trials, o).targets[0].verdict;
  state.SetLabel("verdict: " + verdict);
}
BENCHMARK(BM_BlindDiagnosis)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
