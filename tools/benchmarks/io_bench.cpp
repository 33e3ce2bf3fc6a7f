// Read speed of the motion-capture and table readers on the real data files.
// Prints time per file and bytes/s; skips a file that is not present.

#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "io/c3d.hpp"
#include "io/knee_forces.hpp"
#include "io/storage.hpp"
#include "io/trc.hpp"

namespace {

std::string data(const char* rel) { return std::string(KNEESIM_DATA_DIR) + "/" + rel; }

template <class Fn>
void runRead(benchmark::State& state, const std::string& path, Fn fn) {
  if (!std::filesystem::exists(path)) {
    state.SkipWithError(("data not available: " + path).c_str());
    return;
  }
  for (auto _ : state) benchmark::DoNotOptimize(fn(path));
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(std::filesystem::file_size(path)));
}

void BM_ReadC3d_1legstand_2_8MB(benchmark::State& s) {
  runRead(s, data("kgc4-jw/markers/jw_1legstand1.c3d"), [](const std::string& p) { return kneesim::io::readC3d(p); });
}
void BM_ReadC3d_ngait_og3_0_7MB(benchmark::State& s) {
  runRead(s, data("kgc4-jw/markers/jw_ngait_og3.c3d"), [](const std::string& p) { return kneesim::io::readC3d(p); });
}
void BM_ReadTrc_constraintTest_2_5MB(benchmark::State& s) {
  runRead(s, data("opensim-ik-tests/constraintTest.trc"), [](const std::string& p) { return kneesim::io::readTrc(p); });
}
void BM_ReadStorage_markers_coords(benchmark::State& s) {
  runRead(s, data("opensim-ik-tests/std_markers_coords_ik.sto"), [](const std::string& p) { return kneesim::io::readStorage(p); });
}
void BM_ReadKneeForces_chairrise(benchmark::State& s) {
  runRead(s, data("kgc4-jw/knee-forces/jw_chairrise1_knee_forces.csv"),
          [](const std::string& p) { return kneesim::io::readKneeForces(p); });
}
void BM_PlateWrench_1legstand_12110_samples(benchmark::State& state) {
  const std::string path = data("kgc4-jw/markers/jw_1legstand1.c3d");
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("data not available");
    return;
  }
  const kneesim::io::C3dFile c = kneesim::io::readC3d(path);
  for (auto _ : state) benchmark::DoNotOptimize(kneesim::io::calcPlateWrench(c, 0));
  state.SetItemsProcessed(int64_t(state.iterations()) * c.analog.data.rows());
}

}  // namespace

BENCHMARK(BM_ReadC3d_1legstand_2_8MB)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadC3d_ngait_og3_0_7MB)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadTrc_constraintTest_2_5MB)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadStorage_markers_coords)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ReadKneeForces_chairrise)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_PlateWrench_1legstand_12110_samples)->Unit(benchmark::kMicrosecond);
BENCHMARK_MAIN();
