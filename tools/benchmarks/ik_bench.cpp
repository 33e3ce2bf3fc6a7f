// IK speed: microseconds per frame and frames per second, single thread, with the marker RMS
// reached. Cases: a synthetic 24-DOF knee-model tree with 22 markers (the paper's model
// structure), OpenSim's gait2354 regression trial (with the marker RMS of OpenSim's stored answer
// for comparison) and OpenSim's constraintTest (the last two on data/opensim-ik-tests).
#include <benchmark/benchmark.h>

#include <time.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <random>

#include "ik/solver.hpp"
#include "ik/tool.hpp"
#include "io/marker_table.hpp"
#include "io/storage.hpp"
#include "model/osim_reader.hpp"

namespace {

using kneesim::model::Vec3;
namespace model = kneesim::model;

// pelvis(6) - femur(hip 3) - tibia(TF 6) and patella(PF 6) - talus(ankle 1) - calcaneus(subtalar 1) - toes(1) = 24.
std::shared_ptr<model::Model> makeKnee24() {
  auto m = std::make_shared<model::Model>();
  m->name = "synthetic knee24";
  m->format_version = 40000;
  const char* names[] = {"ground", "pelvis", "femur", "tibia", "patella", "talus", "calcaneus", "toes"};
  for (const char* n : names) {
    model::Body b;
    b.name = n;
    b.mass = std::string(n) == "ground" ? 0 : 1;
    b.inertia = b.mass * 0.01 * model::Mat3::Identity();
    m->bodies.push_back(b);
  }
  auto custom = [&](const std::string& name, int parent, int child, Vec3 loc, int nrot, int ntrans) {
    model::Joint j;
    j.name = name;
    j.type = model::JointType::Custom;
    j.parent_body = parent;
    j.child_body = child;
    j.X_PF = model::poseFromXYZ(Vec3::Zero(), loc);
    const Vec3 rot_axes[3] = {Vec3::UnitZ(), Vec3::UnitX(), Vec3::UnitY()};
    const Vec3 tr_axes[3] = {Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()};
    for (int a = 0; a < 6; ++a) {
      j.spatial[a].axis = a < 3 ? rot_axes[a] : tr_axes[a - 3];
      const bool used = a < 3 ? a < nrot : (a - 3) < ntrans;
      if (!used) continue;
      model::Coordinate c;
      c.name = name + "_" + std::to_string(a);
      c.motion_type = a < 3 ? model::MotionType::Rotational : model::MotionType::Translational;
      c.joint = int(m->joints.size());
      m->coordinates.push_back(c);
      const int ci = int(m->coordinates.size()) - 1;
      j.coordinates.push_back(ci);
      j.spatial[a].coordinates = {ci};
      j.spatial[a].function = model::makeLinear(1.0, 0.0);
    }
    m->joints.push_back(j);
  };
  custom("ground_pelvis", 0, 1, Vec3(0, 0.9, 0), 3, 3);
  custom("hip", 1, 2, Vec3(-0.05, -0.08, 0.08), 3, 0);
  custom("tibiofemoral", 2, 3, Vec3(0, -0.40, 0), 3, 3);
  custom("patellofemoral", 2, 4, Vec3(0.04, -0.38, 0), 3, 3);
  custom("ankle", 3, 5, Vec3(0, -0.42, 0), 1, 0);
  custom("subtalar", 5, 6, Vec3(-0.05, -0.04, 0.01), 1, 0);
  custom("mtp", 6, 7, Vec3(0.17, 0, 0), 1, 0);
  const std::pair<int, Vec3> mk[22] = {
      {1, Vec3(0.02, 0.02, 0.12)},  {1, Vec3(0.02, 0.02, -0.12)}, {1, Vec3(-0.15, 0.05, 0.05)},
      {1, Vec3(-0.15, 0.05, -0.05)}, {1, Vec3(-0.17, 0.06, 0)},   {2, Vec3(0.0, -0.10, 0.08)},
      {2, Vec3(0.03, -0.25, 0.06)},  {2, Vec3(-0.03, -0.2, 0.08)}, {2, Vec3(0.0, -0.38, 0.06)},
      {2, Vec3(0.0, -0.38, -0.05)},  {4, Vec3(0.02, 0, 0)},         {3, Vec3(0.03, -0.1, 0.05)},
      {3, Vec3(0.0, -0.2, 0.06)},    {3, Vec3(-0.03, -0.25, 0.05)}, {3, Vec3(0.0, -0.40, 0.05)},
      {3, Vec3(0.0, -0.40, -0.04)},  {6, Vec3(-0.02, 0.02, 0)},     {6, Vec3(0.1, 0.03, 0.03)},
      {6, Vec3(0.1, 0.03, -0.03)},   {6, Vec3(0.08, 0.06, 0)},      {7, Vec3(0.04, 0.01, 0.02)},
      {7, Vec3(0.04, 0.01, -0.03)}};
  for (int i = 0; i < 22; ++i) m->markers.push_back({"m" + std::to_string(i), mk[i].first, mk[i].second, false});
  m->finalize();
  return m;
}

double threadCpuSeconds() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// Solves the frames of a trial over and over as a run does (trackFrame warm starts, couplers
// eliminated), and reports us/frame, frames/s, Gauss-Newton iterations and the marker RMS reached.
void runTrial(benchmark::State& state, const kneesim::sim::System& sys, kneesim::ik::Solver& solver,
              const std::vector<std::vector<Vec3>>& frames, const Eigen::VectorXd& q_start) {
  auto ws = sys.createWorkspace();
  sys.setCouplersEnabled(*ws, false);
  Eigen::VectorXd q = q_start;
  solver.solveFrame(*ws, frames[0], {}, q);  // the first frame from the default pose, untimed
  const Eigen::VectorXd q0 = q;
  size_t f = 0;
  double rms = 0;
  long iterations = 0, n = 0;
  const double cpu0 = threadCpuSeconds();
  for (auto _ : state) {
    if (f == 0) {  // each pass over the trial starts warm, as a run does after its first frame
      q = q0;
      solver.resetTracking();
    }
    const auto r = solver.trackFrame(*ws, frames[f], {}, q);
    rms += r.rms_error;
    iterations += r.iterations;
    ++n;
    f = (f + 1) % frames.size();
  }
  const double cpu = threadCpuSeconds() - cpu0;
  state.SetItemsProcessed(state.iterations());  // items_per_second = frames/s (CPU time)
  state.counters["us_per_frame"] = cpu * 1e6 / double(std::max(n, 1L));
  state.counters["iterations_per_frame"] = double(iterations) / double(std::max(n, 1L));
  state.counters["marker_rms_mm"] = rms / double(std::max(n, 1L)) * 1e3;
}

void BM_IkSynthetic24Dof(benchmark::State& state) {
  auto model = makeKnee24();
  kneesim::sim::System sys(model);
  auto ws = sys.createWorkspace();
  const int nq = sys.getNumCoordinates();
  // A smooth synthetic motion of 120 frames, 1 mm marker noise.
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, 0.001);
  std::vector<std::vector<Vec3>> frames;
  for (int f = 0; f < 120; ++f) {
    const double s = 2 * M_PI * f / 120.0;
    Eigen::VectorXd q = Eigen::VectorXd::Zero(nq);
    for (int c = 0; c < nq; ++c) {
      const bool rot = model->coordinates[c].motion_type == model::MotionType::Rotational;
      q[c] = (rot ? 0.3 : 0.01) * std::sin(s + c);
    }
    q[3] = 0.5 * f / 120.0;  // pelvis walks forwards
    sys.realizePosition(*ws, q);
    std::vector<Vec3> obs;
    for (const auto& mk : model->markers)
      obs.push_back(sys.findStationLocation(*ws, mk.body, mk.p_BM) + Vec3(noise(rng), noise(rng), noise(rng)));
    frames.push_back(obs);
  }
  std::vector<kneesim::ik::MarkerTask> tasks;
  for (int i = 0; i < 22; ++i) tasks.push_back({i, 1.0});
  kneesim::ik::SolverOptions options;
  options.step_tolerance = 1e-5;  // OpenSim's default accuracy, as a setup file would give
  kneesim::ik::Solver solver(sys, tasks, {}, options);
  runTrial(state, sys, solver, frames, Eigen::VectorXd::Zero(nq));
}
BENCHMARK(BM_IkSynthetic24Dof)->Unit(benchmark::kMicrosecond);

// Markers of an OpenSim setup's trial in the time range, with the model and solver it describes.
struct SetupCase {
  std::shared_ptr<const model::Model> model;
  std::unique_ptr<kneesim::sim::System> sys;
  std::vector<kneesim::ik::MarkerTask> tasks;
  std::vector<std::vector<Vec3>> frames;
  kneesim::ik::SolverOptions options;
};

bool loadSetupCase(benchmark::State& state, const std::string& file, SetupCase& c) {
  const std::string path = std::string(KNEESIM_DATA_DIR) + "/opensim-ik-tests/" + file;
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("OpenSim IK test data not found");
    return false;
  }
  const auto setup = kneesim::ik::readIkSetup(path);
  c.model = model::readOsim(setup.model_file);
  c.sys = std::make_unique<kneesim::sim::System>(c.model);
  c.options = setup.solver;
  const auto markers = kneesim::io::readMarkerFile(setup.marker_file);
  std::vector<int> cols;
  for (const auto& t : setup.tasks) {
    if (t.kind != kneesim::ik::TaskSpec::Kind::Marker || !t.apply || t.weight == 0) continue;
    const int mi = c.model->findMarker(t.name), col = markers.findMarker(t.name);
    if (mi < 0 || col < 0) continue;
    c.tasks.push_back({mi, t.weight});
    cols.push_back(col);
  }
  for (int f = 0; f < markers.getNumFrames(); ++f) {
    if (markers.time[f] < setup.time_start - 1e-9 || markers.time[f] > setup.time_end + 1e-9) continue;
    std::vector<Vec3> obs;
    for (int col : cols) obs.push_back(markers.getPosition(f, col));
    c.frames.push_back(obs);
  }
  return true;
}

void BM_IkGait2354(benchmark::State& state) {
  SetupCase c;
  if (!loadSetupCase(state, "subject01_Setup_InverseKinematics.xml", c)) return;
  kneesim::ik::Solver solver(*c.sys, c.tasks, {}, c.options);
  runTrial(state, *c.sys, solver, c.frames, c.sys->getDefaultCoordinates());

  // The marker RMS of OpenSim's stored answer on the same frames, for comparison.
  const auto standard = kneesim::io::readStorage(std::string(KNEESIM_DATA_DIR) + "/opensim-ik-tests/std_subject01_walk1_ik.mot");
  auto ws = c.sys->createWorkspace();
  double rms = 0;
  const int rows = std::min<int>(standard.getNumRows(), int(c.frames.size()));
  for (int r = 0; r < rows; ++r) {
    Eigen::VectorXd q = c.sys->getDefaultCoordinates();
    for (size_t k = 0; k < c.model->coordinates.size(); ++k) {
      const auto& co = c.model->coordinates[k];
      const int col = standard.findColumn(co.name);
      if (col >= 0) q[k] = standard.data(r, col) * (co.motion_type == model::MotionType::Rotational ? M_PI / 180 : 1.0);
    }
    c.sys->realizePosition(*ws, q);
    double sum2 = 0;
    for (size_t i = 0; i < c.tasks.size(); ++i) {
      const auto& mk = c.model->markers[c.tasks[i].marker];
      sum2 += (c.sys->findStationLocation(*ws, mk.body, mk.p_BM) - c.frames[r][i]).squaredNorm();
    }
    rms += std::sqrt(sum2 / c.tasks.size()) / rows;
  }
  state.counters["opensim_marker_rms_mm"] = rms * 1e3;
}
BENCHMARK(BM_IkGait2354)->Unit(benchmark::kMicrosecond);

// OpenSim's constraintTest: 58 coordinates, 8 couplers, 42 markers on a model whose markers were
// never placed for this subject (large residuals, slow convergence).
void BM_IkConstraintTest(benchmark::State& state) {
  SetupCase c;
  if (!loadSetupCase(state, "constraintTest_setup_ik.xml", c)) return;
  kneesim::ik::Solver solver(*c.sys, c.tasks, {}, c.options);
  runTrial(state, *c.sys, solver, c.frames, c.sys->getDefaultCoordinates());
}
BENCHMARK(BM_IkConstraintTest)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
