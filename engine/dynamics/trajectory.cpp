#include "dynamics/trajectory.hpp"

#include <algorithm>

#include "core/error.hpp"

namespace kneesim::dynamics {

namespace {

/// OpenSim's Storage::findIndex: the last sample at or before @p t (0 if none).
int findIndex(const std::vector<double>& times, double t) {
  const auto it = std::upper_bound(times.begin(), times.end(), t);
  return std::max(0, int(it - times.begin()) - 1);
}

}  // namespace

std::vector<double> selectFrameTimes(const std::vector<double>& times, double t0, double t1, double first, double last) {
  const double start = std::max(first, t0), end = std::min(last, t1);
  if (times.empty() || end < start) return {};
  const int i0 = findIndex(times, start), i1 = findIndex(times, end);
  return std::vector<double>(times.begin() + i0, times.begin() + i1 + 1);
}

TrajectoryResult calcInverseDynamicsTrajectory(const InverseDynamics& id, const CoordinateTrajectories& coordinates,
                                               const ExternalLoads* loads, const std::vector<double>& times,
                                               const std::vector<JointLoadRequest>& joints) {
  const int n = id.getNumCoordinates(), nf = int(times.size());
  TrajectoryResult r;
  r.time = times;
  r.generalized_forces.resize(nf, n);
  r.joint_loads.resize(nf, 9 * int(joints.size()));
  auto ws = id.createWorkspace();
  Eigen::VectorXd q(n), qd(n), qdd(n), tau(n);
  sim::SpatialColumns F_joint = sim::SpatialColumns::Zero(6, id.getModel().bodies.size());
  for (int f = 0; f < nf; ++f) {
    coordinates.calcAt(times[f], q, qd, qdd);
    id.setState(*ws, q, qd);
    if (loads) loads->addBodyForces(id.getSystem(), ws->getSimWorkspace(), times[f], ws->updAppliedForces());
    id.calcGeneralizedForces(*ws, qdd, tau);
    r.generalized_forces.row(f) = tau.transpose();
    if (joints.empty()) continue;
    id.calcJointLoads(*ws, qdd, F_joint);
    for (size_t k = 0; k < joints.size(); ++k) {
      const JointLoad l =
          expressJointLoad(id.getSystem(), ws->getSimWorkspace(), joints[k].joint, F_joint, joints[k].on, joints[k].frame);
      r.joint_loads.block<1, 3>(f, 9 * k) = l.force.transpose();
      r.joint_loads.block<1, 3>(f, 9 * k + 3) = l.moment.transpose();
      r.joint_loads.block<1, 3>(f, 9 * k + 6) = l.point.transpose();
    }
  }
  return r;
}

io::Storage makeGeneralizedForceStorage(const sim::System& system, const TrajectoryResult& result) {
  const model::Model& m = system.getModel();
  const std::vector<int> order = system.getCoordinatesInTreeOrder();
  io::Storage s;
  s.name = "Inverse Dynamics Generalized Forces";
  s.labels.push_back("time");
  for (int c : order)
    s.labels.push_back(m.coordinates[c].name +
                       (m.coordinates[c].motion_type == model::MotionType::Rotational ? "_moment" : "_force"));
  s.data.resize(result.time.size(), order.size() + 1);
  for (size_t f = 0; f < result.time.size(); ++f) {
    s.data(f, 0) = result.time[f];
    for (size_t k = 0; k < order.size(); ++k) s.data(f, k + 1) = result.generalized_forces(f, order[k]);
  }
  return s;
}

io::Storage makeJointLoadStorage(const model::Model& model, const std::vector<JointLoadRequest>& joints,
                                 const TrajectoryResult& result) {
  io::Storage s;
  s.name = "Joint Loads";
  s.labels.push_back("time");
  static const char* suffix[9] = {"fx", "fy", "fz", "mx", "my", "mz", "px", "py", "pz"};
  for (const JointLoadRequest& j : joints) {
    const std::string prefix = model.joints[j.joint].name + "_on_" + getLoadBodyName(model, j.joint, j.on) + "_in_" +
                               getLoadFrameName(model, j.joint, j.frame) + "_";
    for (const char* x : suffix) s.labels.push_back(prefix + x);
  }
  s.data.resize(result.time.size(), 1 + result.joint_loads.cols());
  for (size_t f = 0; f < result.time.size(); ++f) {
    s.data(f, 0) = result.time[f];
    s.data.row(f).tail(result.joint_loads.cols()) = result.joint_loads.row(f);
  }
  return s;
}

}  // namespace kneesim::dynamics
