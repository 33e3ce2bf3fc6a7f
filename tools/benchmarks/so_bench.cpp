// Static optimization speed: milliseconds per frame (CPU time, one thread) of one frame's
// solve (coordinates from splines, inverse dynamics, every path with its wraps and moment arms,
// the muscles' force-length-velocity, the exponent-2 quadratic programme warm-started from the
// previous frame), on OpenSim's arm26 case (6 Thelen2003 muscles, 2 coordinates),
// gait10dof18musc (18 muscles, 10 coordinates, a reserve on each; gravity only: the case has no
// ground reactions) and JW (the UF model's 44 leg muscles on the 24-DOF knee model with the
// reserves of models/jw-knee24/jw_muscle_reserves.xml, ngait_og3's stored IK with its C3D
// ground reactions), with and without the knee's reaction (JW's chain per frame).
#include <benchmark/benchmark.h>

#include <ctime>

#include "dynamics/c3d_loads.hpp"
#include "dynamics/coordinate_smoothing.hpp"
#include "dynamics/joint_loads.hpp"
#include "dynamics/tool.hpp"
#include "dynamics/trajectory.hpp"
#include "io/c3d.hpp"
#include "model/osim_reader.hpp"
#include "muscle/static_optimization.hpp"
#include "tool/knee_contact_workflow.hpp"

namespace {

namespace dyn = kneesim::dynamics;
namespace model = kneesim::model;
namespace muscle = kneesim::muscle;

// CPU time of the process (the benchmark runs one thread).
double cpuNow() { return double(std::clock()) / CLOCKS_PER_SEC; }

const std::string kData = std::string(KNEESIM_DATA_DIR) + "/";
const std::string kSource = std::string(KNEESIM_SOURCE_DIR) + "/";

/// A model, its motion and loads, and the frames to solve.
struct Case {
  model::ModelPtr model;
  std::unique_ptr<dyn::CoordinateTrajectories> traj;
  std::unique_ptr<dyn::ExternalLoads> loads;
  std::vector<double> times;
  int knee = -1;  ///< Joint whose reaction is computed too (JW), or -1.
};

Case makeCase(model::ModelPtr m, const std::string& motion, double cutoff) {
  Case c;
  c.model = std::move(m);
  dyn::CoordinateSmoothingOptions so;
  so.cutoff_hz = cutoff;
  const kneesim::io::Storage s = kneesim::io::readStorage(motion);
  so.in_degrees = dyn::fileSaysDegrees(s);
  c.traj = std::make_unique<dyn::CoordinateTrajectories>(*c.model, s, motion, so);
  c.times = dyn::selectFrameTimes(c.traj->getTimes(), -1e30, 1e30, c.traj->getStartTime(), c.traj->getEndTime());
  return c;
}

/// gait10dof18musc with a reserve on every coordinate (residuals of 100 on the pelvis's).
model::ModelPtr withReserves(model::ModelPtr m) {
  auto out = std::make_shared<model::Model>(*m);
  for (size_t i = 0; i < out->coordinates.size(); ++i) {
    model::CoordinateActuator a;
    a.name = "reserve_" + out->coordinates[i].name;
    a.coordinate = int(i);
    a.optimal_force = out->coordinates[i].name.rfind("pelvis", 0) == 0 ? 100 : 1;
    out->actuators.push_back(a);
  }
  out->finalize();
  return out;
}

Case jwCase() {
  kneesim::tool::WorkflowSetup w = kneesim::tool::readWorkflowSetup(kSource + "models/jw-knee24/jw_muscle_chain.xml");
  const auto knee = model::readOsim(kSource + "models/jw-knee24/jw_knee24.osim");
  const kneesim::tool::MuscleChainModel chain = kneesim::tool::buildMuscleChainModel(w.muscles, knee);
  Case c = makeCase(chain.model, kSource + "tests/models/reference/jw_ngait_og3_ik.sto", 6);
  const dyn::IdSetup id = dyn::readIdSetup(kSource + "models/jw-knee24/ngait_og3_id_setup.xml");
  const dyn::GroundReactions g = dyn::calcGroundReactions(kneesim::io::readC3d(id.plates_c3d_file), id.plates);
  c.loads = std::make_unique<dyn::ExternalLoads>(g.loads, *c.model, g.grf);
  c.knee = c.model->findJoint("knee");
  return c;
}

void runSo(benchmark::State& state, const Case& c) {
  const auto id = std::make_shared<const dyn::InverseDynamics>(c.model);
  muscle::SoOptions o;
  const muscle::StaticOptimization so(id, o);
  auto ws = so.createWorkspace();
  const int n = int(c.model->coordinates.size());
  Eigen::VectorXd q(n), qd(n), qdd(n), mobility(n);
  kneesim::sim::SpatialColumns F(6, c.model->bodies.size());
  size_t f = 0;
  long frames = 0;
  const double c0 = cpuNow();
  for (auto _ : state) {
    const double t = c.times[f];
    f = (f + 1) % c.times.size();
    c.traj->calcAt(t, q, qd, qdd);
    so.solveFrame(*ws, t, q, qd, qdd, c.loads.get());
    if (c.knee >= 0 && state.range(0) == 1) {
      mobility.setZero();
      so.addActuatorLoads(*ws, ws->updIdWorkspace().updAppliedForces(), mobility);
      id->calcJointLoads(ws->updIdWorkspace(), ws->getAccelerations(), F);
      const dyn::JointLoad L = dyn::expressJointLoad(id->getSystem(), ws->updIdWorkspace().getSimWorkspace(), c.knee, F,
                                                     dyn::LoadOnBody::Child, dyn::LoadFrame::Child);
      benchmark::DoNotOptimize(L.force.data());
    }
    benchmark::DoNotOptimize(ws->getForces().data());
    ++frames;
  }
  state.counters["ms_per_frame"] = (cpuNow() - c0) * 1e3 / double(std::max(frames, 1L));
  state.counters["muscles"] = double(c.model->muscles.size());
  state.counters["actuators"] = double(so.getActuators().size());
  state.SetItemsProcessed(frames);
}

void BM_SoArm26(benchmark::State& state) {
  static const Case c = makeCase(model::readOsim(kData + "opensim-dynamics-tests/so/arm26.osim"),
                                 kData + "opensim-dynamics-tests/so/arm26_InverseKinematics.mot", 6);
  runSo(state, c);
}
BENCHMARK(BM_SoArm26)->Arg(0)->Unit(benchmark::kMillisecond);

void BM_SoGait10dof18musc(benchmark::State& state) {
  static const Case c =
      makeCase(withReserves(model::readOsim(kData + "opensim-dynamics-tests/wrapping/walk_gait1018_subject01.osim")),
               kData + "opensim-dynamics-tests/wrapping/walk_gait1018_state_reference.mot", 6);
  runSo(state, c);
}
BENCHMARK(BM_SoGait10dof18musc)->Arg(0)->Unit(benchmark::kMillisecond);

/// Arg 1: with the knee's reaction (the musculoskeletal knee force's whole frame).
void BM_SoJw(benchmark::State& state) {
  static const Case c = jwCase();
  runSo(state, c);
}
BENCHMARK(BM_SoJw)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
