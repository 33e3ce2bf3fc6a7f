// IK speed: microseconds per frame and frames per second, single thread, with the marker RMS
// reached. Two cases: OpenSim's gait2354 regression trial (if ../shared/data is present) and a
// synthetic 24-DOF knee-model tree with 22 markers (the paper's model structure).
#include <benchmark/benchmark.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "ik/solver.hpp"
#include "ik/tool.hpp"
#include "io/marker_table.hpp"
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
  kneesim::ik::Solver solver(sys, tasks, {});
  Eigen::VectorXd q = Eigen::VectorXd::Zero(nq);
  solver.solveFrame(*ws, frames[0], {}, q);  // warm-up from the default pose
  const Eigen::VectorXd q0 = q;
  size_t f = 0;
  double rms = 0;
  int n = 0;
  for (auto _ : state) {
    if (f == 0) q = q0;  // each pass over the trial starts warm, as a real run does
    const auto r = solver.solveFrame(*ws, frames[f], {}, q);
    rms += r.rms_error;
    ++n;
    f = (f + 1) % frames.size();
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["us_per_frame"] = benchmark::Counter(state.iterations(), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["marker_rms_mm"] = rms / n * 1e3;
}
BENCHMARK(BM_IkSynthetic24Dof)->Unit(benchmark::kMicrosecond);

void BM_IkGait2354(benchmark::State& state) {
  const std::string dir = std::string(KNEESIM_DATA_DIR) + "/opensim-ik-tests/";
  if (!std::filesystem::exists(dir + "subject01_Setup_InverseKinematics.xml")) {
    state.SkipWithError("OpenSim IK test data not found");
    return;
  }
  const auto setup = kneesim::ik::readIkSetup(dir + "subject01_Setup_InverseKinematics.xml");
  auto model = model::readOsim(setup.model_file);
  kneesim::sim::System sys(model);
  auto ws = sys.createWorkspace();
  const auto markers = kneesim::io::readMarkerFile(setup.marker_file);
  std::vector<kneesim::ik::MarkerTask> tasks;
  std::vector<int> cols;
  for (const auto& t : setup.tasks) {
    if (t.kind != kneesim::ik::TaskSpec::Kind::Marker || !t.apply || t.weight == 0) continue;
    const int mi = model->findMarker(t.name), col = markers.findMarker(t.name);
    if (mi < 0 || col < 0) continue;
    tasks.push_back({mi, t.weight});
    cols.push_back(col);
  }
  kneesim::ik::Solver solver(sys, tasks, {});
  std::vector<std::vector<Vec3>> frames;
  for (int f = 0; f < markers.getNumFrames(); ++f) {
    std::vector<Vec3> obs;
    for (int c : cols) obs.push_back(markers.getPosition(f, c));
    frames.push_back(obs);
  }
  Eigen::VectorXd q = sys.getDefaultCoordinates();
  solver.solveFrame(*ws, frames[0], {}, q);
  const Eigen::VectorXd q0 = q;
  size_t f = 0;
  double rms = 0;
  int n = 0;
  for (auto _ : state) {
    if (f == 0) q = q0;  // each pass over the trial starts warm, as a real run does
    const auto r = solver.solveFrame(*ws, frames[f], {}, q);
    rms += r.rms_error;
    ++n;
    f = (f + 1) % frames.size();
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["us_per_frame"] = benchmark::Counter(state.iterations(), benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["marker_rms_mm"] = rms / n * 1e3;
}
BENCHMARK(BM_IkGait2354)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
