// Speed of the model readers on the real model files and of the OpenSim functions that the IK
// hot loop evaluates (gait2354's knee SimmSpline, with derivatives). Prints time per call;
// skips a file that is not present.

#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "model/function.hpp"
#include "model/osim_reader.hpp"
#include "model/urdf.hpp"

namespace {

std::string data(const char* rel) { return std::string(KNEESIM_DATA_DIR) + "/" + rel; }

void readModel(benchmark::State& state, const std::string& path) {
  if (!std::filesystem::exists(path)) {
    state.SkipWithError(("data not available: " + path).c_str());
    return;
  }
  for (auto _ : state) benchmark::DoNotOptimize(kneesim::model::readOsim(path));
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(std::filesystem::file_size(path)));
}

void BM_ReadOsim_gait2354_20303(benchmark::State& s) { readModel(s, data("opensim-ik-tests/subject01_simbody.osim")); }
void BM_ReadOsim_constraintTest_20302(benchmark::State& s) {
  readModel(s, data("opensim-ik-tests/constraintTest_ikOnly.osim"));
}
void BM_ReadOsim_jw_30000(benchmark::State& s) { readModel(s, data("kgc4-jw/model/jw_all_body_scaled.osim")); }

void BM_FormatUrdf_jw(benchmark::State& state) {
  const std::string path = data("kgc4-jw/model/jw_all_body_scaled.osim");
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("data not available");
    return;
  }
  const auto m = kneesim::model::readOsim(path);
  for (auto _ : state) {
    std::vector<std::string> lost;
    benchmark::DoNotOptimize(kneesim::model::formatUrdf(*m, &lost));
  }
}

// gait2354 knee_r translation1: 12 uneven knots, scaled by a MultiplierFunction.
kneesim::model::FunctionPtr kneeSpline() {
  return kneesim::model::makeMultiplier(
      kneesim::model::makeSimmSpline({-2.0944, -1.74533, -1.39626, -1.0472, -0.698132, -0.349066, -0.174533, 0.197344,
                                      0.337395, 0.490178, 1.52146, 2.0944},
                                     {-0.0032, 0.00179, 0.00411, 0.0041, 0.00212, -0.001, -0.0031, -0.005227,
                                      -0.005435, -0.005574, -0.005435, -0.00525}),
      1.14724);
}

void BM_SimmSplineValue(benchmark::State& state) {
  const auto f = kneeSpline();
  double q = -2.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f->calcValue(q));
    q = q > 2.0 ? -2.0 : q + 0.001;
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_SimmSplineValueAndTwoDerivatives(benchmark::State& state) {
  const auto f = kneeSpline();
  double q = -2.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f->calcValue(q));
    benchmark::DoNotOptimize(f->calcDerivative1(q));
    benchmark::DoNotOptimize(f->calcDerivative2(q));
    q = q > 2.0 ? -2.0 : q + 0.001;
  }
  state.SetItemsProcessed(state.iterations());
}

}  // namespace

BENCHMARK(BM_ReadOsim_gait2354_20303)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadOsim_constraintTest_20302)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadOsim_jw_30000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FormatUrdf_jw)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SimmSplineValue);
BENCHMARK(BM_SimmSplineValueAndTwoDerivatives);
BENCHMARK_MAIN();
