// The IK round trip of a model (see the header).
#include "ik/round_trip.hpp"

#include <algorithm>
#include <cmath>
#include <memory>

#include "ik/solver.hpp"
#include "sim/system.hpp"

namespace kneesim::ik {

namespace {

/// The model itself, or a copy with three markers on every body when it has none.
model::ModelPtr withMarkers(const model::ModelPtr& model, bool& synthetic) {
  synthetic = model->markers.empty();
  if (!synthetic) return model;
  auto copy = std::make_shared<model::Model>(*model);
  for (size_t b = 1; b < copy->bodies.size(); ++b)
    for (int a = 0; a < 3; ++a)
      copy->markers.push_back({copy->bodies[b].name + "_" + "xyz"[a], int(b), 0.05 * Eigen::Vector3d::Unit(a), false});
  copy->finalize();
  return copy;
}

}  // namespace

RoundTripResult runRoundTrip(const model::ModelPtr& source, int frames) {
  RoundTripResult out;
  const model::ModelPtr model = withMarkers(source, out.synthetic_markers);
  const model::Model& m = *model;
  sim::System system(model);
  auto ws = system.createWorkspace();
  system.setCouplersEnabled(*ws, false);
  system.setConstraintsEnabled(*ws, false);
  std::vector<MarkerTask> tasks;
  for (size_t i = 0; i < m.markers.size(); ++i) tasks.push_back({int(i), 1.0});
  out.markers = int(tasks.size());
  out.frames = frames;
  SolverOptions options;
  options.step_tolerance = 1e-10;
  Solver assembler(system, {}, {}, options);  // no markers: places a pose on the constraints
  Solver solver(system, tasks, {}, options);
  const Eigen::VectorXd q0 = system.getDefaultCoordinates();
  std::vector<Eigen::Vector3d> observed(tasks.size());
  for (int f = 0; f < frames; ++f) {
    Eigen::VectorXd q = q0;
    for (size_t c = 0; c < m.coordinates.size(); ++c) {
      const model::Coordinate& co = m.coordinates[c];
      if (co.locked) continue;
      const double step = co.motion_type == model::MotionType::Translational ? 0.01 : 0.2;
      q[c] = std::clamp(q0[c] + step * std::sin(1.7 * double(c) + 2.3 * (f + 1)), co.range_min, co.range_max);
    }
    assembler.applyConstraints(q);
    assembler.solveFrame(*ws, {}, {}, q);
    system.realizePosition(*ws, q);
    for (size_t i = 0; i < tasks.size(); ++i)
      observed[i] = system.findStationLocation(*ws, m.markers[i].body, m.markers[i].p_BM);
    Eigen::VectorXd guess = q0;
    const FrameResult r = solver.solveFrame(*ws, observed, {}, guess);
    out.converged = out.converged && r.converged;
    out.rms_error = std::max(out.rms_error, r.rms_error);
    out.max_error = std::max(out.max_error, r.max_error);
    out.max_constraint_error = std::max(out.max_constraint_error, r.max_constraint_error);
  }
  return out;
}

}  // namespace kneesim::ik
