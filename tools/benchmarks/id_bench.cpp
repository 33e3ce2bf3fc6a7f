// Inverse dynamics speed: microseconds per frame (CPU time, one thread) with the coordinate
// smoothing excluded (it is done once per run), on OpenSim's gait2354 regression case with its
// ground reactions, with and without the joint loads, and on JW's 24-DOF knee model; and the
// whole InverseDynamicsTool run of the gait2354 setup (reading the model, coordinates and GRF,
// filtering, splines, 67 frames, writing the .sto).
#include <benchmark/benchmark.h>

#include <time.h>

#include <cmath>
#include <filesystem>

#include "dynamics/tool.hpp"
#include "model/osim_reader.hpp"

namespace {

namespace dyn = kneesim::dynamics;
namespace model = kneesim::model;

double cpuNow() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

const std::string kCase = std::string(KNEESIM_DATA_DIR) + "/opensim-dynamics-tests/id/";

/// One frame: q, qdot, qddot from the splines, state, external loads, generalised forces, and
/// (if asked) the joint loads.
void runGait2354(benchmark::State& state, bool joint_loads) {
  auto m = model::readOsim(kCase + "subject01.osim");
  dyn::CoordinateSmoothingOptions so;
  so.cutoff_hz = 6;
  const dyn::CoordinateTrajectories traj(*m, kneesim::io::readStorage(kCase + "subject01_walk1_ik.mot"), "ik", so);
  const dyn::ExternalLoads loads(dyn::readExternalLoads(kCase + "subject01_walk1_grf.xml"), *m);
  const dyn::InverseDynamics id(m);
  auto ws = id.createWorkspace();
  const int n = id.getNumCoordinates();
  Eigen::VectorXd q(n), qd(n), qdd(n), tau(n);
  kneesim::sim::SpatialColumns F(6, m->bodies.size());
  const std::vector<double> times = dyn::selectFrameTimes(traj.getTimes(), 0.5, 1.6, traj.getStartTime(), traj.getEndTime());
  size_t f = 0;
  long frames = 0;
  const double c0 = cpuNow();
  for (auto _ : state) {
    const double t = times[f];
    f = (f + 1) % times.size();
    traj.calcAt(t, q, qd, qdd);
    id.setState(*ws, q, qd);
    loads.addBodyForces(id.getSystem(), ws->getSimWorkspace(), t, ws->updAppliedForces());
    id.calcGeneralizedForces(*ws, qdd, tau);
    if (joint_loads) id.calcJointLoads(*ws, qdd, F);
    benchmark::DoNotOptimize(tau.data());
    ++frames;
  }
  state.counters["us_per_frame"] = (cpuNow() - c0) * 1e6 / double(std::max(frames, 1L));
  state.SetItemsProcessed(frames);
}

void BM_IdGait2354(benchmark::State& state) { runGait2354(state, false); }
BENCHMARK(BM_IdGait2354)->Unit(benchmark::kMicrosecond);

void BM_IdGait2354WithJointLoads(benchmark::State& state) { runGait2354(state, true); }
BENCHMARK(BM_IdGait2354WithJointLoads)->Unit(benchmark::kMicrosecond);

/// JW's 24-DOF knee model (models/jw-knee24) moving every coordinate sinusoidally, with a load
/// on the calcaneus; generalised forces and joint loads per frame.
void BM_IdJwKnee24(benchmark::State& state) {
  auto m = model::readOsim(std::string(KNEESIM_SOURCE_DIR) + "/models/jw-knee24/jw_knee24.osim");
  const dyn::InverseDynamics id(m);
  auto ws = id.createWorkspace();
  const int n = id.getNumCoordinates(), calcaneus = m->findBody("calcaneus");
  Eigen::VectorXd q(n), qd(n), qdd(n), tau(n);
  kneesim::sim::SpatialColumns F(6, m->bodies.size());
  long frames = 0;
  const double c0 = cpuNow();
  for (auto _ : state) {
    const double t = 0.01 * double(frames % 100);
    for (int c = 0; c < n; ++c) {
      q[c] = 0.2 * std::sin(2 * t + c);
      qd[c] = 0.4 * std::cos(2 * t + c);
      qdd[c] = -0.8 * std::sin(2 * t + c);
    }
    id.setState(*ws, q, qd);
    ws->updAppliedForces().col(calcaneus) << 1, 2, 3, 30, 650, -20;
    id.calcGeneralizedForces(*ws, qdd, tau);
    id.calcJointLoads(*ws, qdd, F);
    benchmark::DoNotOptimize(tau.data());
    ++frames;
  }
  state.counters["us_per_frame"] = (cpuNow() - c0) * 1e6 / double(std::max(frames, 1L));
  state.counters["coordinates"] = n;
  state.SetItemsProcessed(frames);
}
BENCHMARK(BM_IdJwKnee24)->Unit(benchmark::kMicrosecond);

/// The whole gait2354 setup as `kneesim run` does it (without process start-up).
void BM_IdToolGait2354(benchmark::State& state) {
  dyn::IdSetup setup = dyn::readIdSetup(kCase + "subject01_Setup_InverseDynamics.xml");
  const std::string out = (std::filesystem::temp_directory_path() / "kneesim_bench_id").string();
  setup.output_gen_force_file = out + "/subject01_InverseDynamics.sto";
  double smoothing_and_io = 0;
  long runs = 0;
  for (auto _ : state) {
    const dyn::IdReport r = dyn::runInverseDynamicsTool(setup);
    smoothing_and_io += r.seconds_total - r.seconds_solving;
    ++runs;
  }
  state.counters["ms_outside_frame_loop"] = 1e3 * smoothing_and_io / double(std::max(runs, 1L));
  std::filesystem::remove_all(out);
}
BENCHMARK(BM_IdToolGait2354)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
