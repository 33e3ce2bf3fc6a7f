// Cost of contact-law identification: a law evaluation with its Jacobian, one Hertz fit (Ipopt,
// Gauss-Newton Hessian, identifiability check included), and a fit with profile and block-bootstrap
// intervals. Synthetic stance-like contact areas at 120 Hz, 30 N noise.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "identify/fit.hpp"
#include "plugin/registry.hpp"

namespace {

using namespace kneesim;

identify::Trial makeTrial(int frames) {
  identify::Trial t;
  t.name = "synthetic";
  std::mt19937_64 rng(1);
  std::normal_distribution<double> noise(0, 30);
  for (int i = 0; i < frames; ++i) {
    const double time = i / 120.0, x = std::fmod(time, 1.2);
    const double s = 1e-6 * (100 + 800 * std::exp(-std::pow((x - 0.15) / 0.08, 2)) +
                             900 * std::exp(-std::pow((x - 0.45) / 0.09, 2)));
    t.time.push_back(time);
    t.channels["S"].push_back(s);
    t.measured_force.push_back(2.0 / (3 * 0.037) * 2e7 * std::pow(s / M_PI, 1.5) + noise(rng));
  }
  return t;
}

struct Setup {
  plugin::Registry registry;
  std::unique_ptr<identify::ContactLaw> law;
  Setup() {
    registry.loadPlugin("hertz");
    law = std::make_unique<identify::ContactLaw>(registry.getContactLaw("hertz"));
  }
};

Setup& setup() {
  static Setup s;
  return s;
}

void BM_HertzForceAndJacobian(benchmark::State& state) {
  const identify::Trial t = makeTrial(static_cast<int>(state.range(0)));
  const identify::LawInputs in(*setup().law, t.channels, t.time, t.name);
  Eigen::VectorXd f(t.time.size());
  Eigen::MatrixXd j(t.time.size(), 3);
  const Eigen::Vector3d p(1e9, 0.45, 0.037);
  for (auto _ : state) {
    setup().law->calcForce(p.data(), in, f.data(), j.data());
    benchmark::DoNotOptimize(f.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));  // frames/s
}
BENCHMARK(BM_HertzForceAndJacobian)->Arg(144)->Arg(1440);

void BM_HertzFit(benchmark::State& state) {
  const std::vector<identify::Trial> trials{makeTrial(static_cast<int>(state.range(0)))};
  identify::FitOptions o;
  o.confidence.bootstrap_samples = 0;
  o.confidence.profile = false;
  int iterations = 0;
  for (auto _ : state) iterations = identify::fit(*setup().law, trials, o).solver.iterations;
  state.counters["ipopt_iterations"] = iterations;
}
BENCHMARK(BM_HertzFit)->Arg(144)->Arg(1440)->Unit(benchmark::kMillisecond);

void BM_HertzFitWithIntervals(benchmark::State& state) {
  const std::vector<identify::Trial> trials{makeTrial(1440)};
  identify::FitOptions o;
  o.confidence.bootstrap_samples = static_cast<int>(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(identify::fit(*setup().law, trials, o).derived);
  state.counters["bootstrap_samples"] = static_cast<double>(state.range(0));
}
BENCHMARK(BM_HertzFitWithIntervals)->Arg(200)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
