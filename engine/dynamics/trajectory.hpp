#pragma once
// Inverse dynamics over a motion: frame selection as OpenSim's InverseDynamicsTool does it, the
// frame loop (one workspace, no allocation per frame), and the result tables OpenSim writes.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "dynamics/coordinate_smoothing.hpp"
#include "dynamics/external_loads.hpp"
#include "dynamics/inverse_dynamics.hpp"
#include "dynamics/joint_loads.hpp"
#include "io/storage.hpp"

namespace kneesim::dynamics {

/// A joint whose net load is reported over the motion.
struct JointLoadRequest {
  int joint = -1;
  LoadOnBody on = LoadOnBody::Child;
  LoadFrame frame = LoadFrame::Child;
};

/// Inverse dynamics over a motion.
struct TrajectoryResult {
  std::vector<double> time;
  /// Rows are frames, columns the model's coordinates (model order), N·m or N.
  Eigen::MatrixXd generalized_forces;
  /// Rows are frames, 9 columns per JointLoadRequest: fx fy fz mx my mz px py pz.
  Eigen::MatrixXd joint_loads;
};

/// The sample times OpenSim analyses for a time range [t0, t1]: from the last sample at or
/// before max(t0, first) to the last sample at or before min(t1, last), where first and last
/// bound @p data_span (the coordinate file's own rows; OpenSim would use the padded times, which
/// analyses the padding when no time range is given).
std::vector<double> selectFrameTimes(const std::vector<double>& times, double t0, double t1, double first, double last);

/// Runs inverse dynamics at @p times: coordinates from @p coordinates, external loads from
/// @p loads (may be null), joint loads for @p joints.
TrajectoryResult calcInverseDynamicsTrajectory(const InverseDynamics& id, const CoordinateTrajectories& coordinates,
                                               const ExternalLoads* loads, const std::vector<double>& times,
                                               const std::vector<JointLoadRequest>& joints = {});

/// The generalised forces as OpenSim writes them: columns "<coordinate>_moment" (rotational) or
/// "<coordinate>_force", in Simbody's mobility order, named "Inverse Dynamics Generalized Forces".
io::Storage makeGeneralizedForceStorage(const sim::System& system, const TrajectoryResult& result);

/// The joint loads with OpenSim JointReaction's labels <joint>_on_<body>_in_<frame>_fx .. _pz.
io::Storage makeJointLoadStorage(const model::Model& model, const std::vector<JointLoadRequest>& joints,
                                 const TrajectoryResult& result);

}  // namespace kneesim::dynamics
