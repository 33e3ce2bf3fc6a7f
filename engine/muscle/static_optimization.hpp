#pragma once
// Static optimisation as OpenSim's StaticOptimization analysis poses it, one frame at a time:
// the activations x of the model's muscles and coordinate actuators that minimise sum |x_i|^p
// subject to the equations of motion at the frame's accelerations and to each actuator's
// control bounds. An actuator's force is x_i times its "optimal force": a muscle's rigid-tendon
// force at full activation (use_muscle_physiology) or its max_isometric_force, a coordinate
// actuator's optimal_force. OpenSim states the equality on the accelerations of the
// unconstrained coordinates (forward dynamics with the actuators' forces); here it is stated on
// their generalised forces, C^T R F = C^T tau_ID (C the couplers' dq/dq_free, R the moment
// arms, tau_ID inverse dynamics at the coupled accelerations), which has the same solutions.
//
//   StaticOptimization so(id, options);       // immutable, shared between threads
//   auto ws = so.createWorkspace();           // per thread
//   so.solveFrame(*ws, t, q, qdot, qddot, loads);   // then ws->getActivations(), getForces()
// Ipopt solves each frame (one solve at a time in the process: identify::getIpoptMutex()),
// starting from the previous frame's solution.

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "dynamics/external_loads.hpp"
#include "dynamics/inverse_dynamics.hpp"
#include "io/storage.hpp"
#include "muscle/force.hpp"
#include "muscle/path.hpp"

namespace kneesim::muscle {

/// OpenSim StaticOptimization's settings.
struct SoOptions {
  double activation_exponent = 2.0;   ///< p in sum |x|^p.
  bool use_muscle_physiology = true;  ///< Muscle force from the force-length-velocity curves.
  double convergence = 1e-4;          ///< optimizer_convergence_criterion (Ipopt's tol).
  int max_iterations = 100;           ///< optimizer_max_iterations.
  /// Solve each frame as OpenSim does (sim/interior_point.hpp: Simbody's interior-point optimizer
  /// on the accelerations' equations, from zero, stopping at `convergence`), which reproduces
  /// OpenSim's answers where its optimizer stops short of the optimum; false: the optimum itself
  /// (the dedicated quadratic programme for exponent 2, else Ipopt to `convergence`). Allocates.
  bool opensim_optimizer = false;
};

/// One optimised actuator, in the order OpenSim writes them (muscles, then coordinate actuators;
/// disabled ones left out).
struct SoActuator {
  std::string name;
  bool is_muscle = true;
  int index = -1;  ///< Into Model::muscles or Model::actuators.
  double min_control = 0.0, max_control = 1.0;
};

/// How a frame's solve ended.
struct SoFrameStatus {
  bool converged = false;
  int iterations = 0;
  /// Largest equation-of-motion residual |C^T (R F - tau)| (N·m or N) and the coordinate it is on.
  double max_violation = 0.0;
  int worst_coordinate = -1;
  std::string message;  ///< The optimizer's, where it failed (opensim_optimizer).
};

class SoSolver;

/// Per-thread buffers of StaticOptimization.
class SoWorkspace {
 public:
  ~SoWorkspace();
  /// The frame's activations (controls), one per actuator of StaticOptimization::getActuators().
  const Eigen::VectorXd& getActivations() const { return x_; }
  /// The frame's actuator forces (N, or N·m for rotational coordinate actuators).
  const Eigen::VectorXd& getForces() const { return force_; }
  /// Each actuator's force per unit activation at this frame.
  const Eigen::VectorXd& getOptimalForces() const { return fopt_; }
  /// The inverse dynamics and path workspaces, realised at the frame (for joint reactions).
  dynamics::IdWorkspace& updIdWorkspace() { return *id_; }
  const PathWorkspace& getPathWorkspace() const { return *paths_; }
  /// The accelerations the frame used, couplers applied (model order).
  const Eigen::VectorXd& getAccelerations() const { return qddot_; }

 private:
  friend class StaticOptimization;
  std::unique_ptr<dynamics::IdWorkspace> id_;
  std::unique_ptr<PathWorkspace> paths_;
  std::unique_ptr<SoSolver> solver_;
  Eigen::MatrixXd C_, A_;
  Eigen::VectorXd d_, qddot_, tau_, g_, b_, fopt_, x_, force_, lower_, upper_;
  // SoOptions::opensim_optimizer: the free coordinates' mass matrix and the accelerations' equations.
  Eigen::MatrixXd mass_, A_acc_;
  Eigen::VectorXd tau0_, unit_qddot_, b_acc_;
  Eigen::LDLT<Eigen::MatrixXd> mass_ldlt_;
  bool has_previous_ = false;
};

/// Static optimisation of one model; immutable and shared between threads.
class StaticOptimization {
 public:
  /// Keeps @p id (and its model). Throws InputError if the model has fewer actuators than
  /// unconstrained coordinates (OpenSim's "over-constrained system") or a muscle's parameters
  /// are refused (MuscleForceSet).
  StaticOptimization(std::shared_ptr<const dynamics::InverseDynamics> id, const SoOptions& options);

  const std::vector<SoActuator>& getActuators() const { return actuators_; }
  /// The coordinates whose equations of motion are enforced (not coupled, not locked).
  const std::vector<int>& getFreeCoordinates() const { return free_; }
  const dynamics::InverseDynamics& getInverseDynamics() const { return *id_; }
  const PathSet& getPaths() const { return paths_; }
  const SoOptions& getOptions() const { return options_; }

  std::unique_ptr<SoWorkspace> createWorkspace() const;

  /// Solves frame @p t at coordinates @p q, rates @p qdot and accelerations @p qddot (model
  /// order, SI; coupled coordinates' entries are replaced by the couplers' values, locked
  /// coordinates' by zero) with external loads @p loads (may be null).
  SoFrameStatus solveFrame(SoWorkspace& ws, double t, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
                           const Eigen::VectorXd& qddot, const dynamics::ExternalLoads* loads) const;

  /// The loads of the frame's actuator forces (ws after solveFrame()): added to @p F (one column
  /// per body, as InverseDynamics' applied forces) and to @p mobility (per coordinate: coordinate
  /// actuators and moving path points).
  void addActuatorLoads(const SoWorkspace& ws, sim::SpatialColumns& F, Eigen::Ref<Eigen::VectorXd> mobility) const;

 private:
  /// ws.mass_: C_f^T M C_f of the free coordinates at the frame's state, from inverse dynamics.
  void calcReducedMassMatrix(SoWorkspace& ws) const;
  std::shared_ptr<const dynamics::InverseDynamics> id_;
  SoOptions options_;
  PathSet paths_;
  MuscleForceSet forces_;
  std::vector<SoActuator> actuators_;
  std::vector<int> free_;
};

/// A table of one value per actuator of @p so at each of @p times (rows of @p values), laid out as
/// OpenSim's StaticOptimization writes its _activation.sto and _force.sto.
io::Storage makeActuatorStorage(const StaticOptimization& so, const std::vector<double>& times,
                                const Eigen::MatrixXd& values);

}  // namespace kneesim::muscle
