#pragma once
// Inverse kinematics: weighted least squares between model and measured markers, per frame.

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Cholesky>

#include "sim/system.hpp"

namespace kneesim::ik {

/// A marker the solver tracks: a model marker and its weight.
struct MarkerTask {
  int marker = -1;      ///< Index into Model::markers.
  double weight = 1.0;
};

/// A coordinate the solver pulls towards a reference value (OpenSim's IKCoordinateTask).
struct CoordinateTask {
  int coordinate = -1;  ///< Index into Model::coordinates.
  double weight = 1.0;
};

/// Solver settings.
struct SolverOptions {
  int max_iterations = 200;         ///< Per frame.
  /// Converged when the next Gauss-Newton step would change no coordinate by more than this (rad
  /// or m), or would move no tracked marker (m) and no coordinate-task coordinate (rad or m) by
  /// more than this. The IK tool sets it to the setup's accuracy.
  double step_tolerance = 1e-9;
  double cost_tolerance = 1e-14;    ///< ... or when the cost decreases by less than this fraction.
};

/// What one frame's solve produced. Errors are unweighted distances in metres.
struct FrameResult {
  double total_squared_error = 0;  ///< Sum over used markers of |model - measured|^2 (m^2).
  double rms_error = 0;            ///< sqrt(total_squared_error / markers_used).
  double max_error = 0;
  int worst_marker = -1;           ///< Index into the solver's marker tasks.
  int markers_used = 0;
  int iterations = 0;
  bool converged = false;
};

/// Weighted least-squares IK over the model's coordinates, honouring locked coordinates (held at
/// their default), clamped ranges (box constraints, active set), and coordinate couplers
/// (eliminated: dependent coordinates are computed from their independents, so couplers hold
/// exactly). Solves  min_q  sum_i w_i |x_i - p_i(q)|^2 + sum_j w_j (q_j - r_j)^2  by
/// Levenberg-Marquardt on the free coordinates with Simbody's station Jacobians.
///
/// A Solver holds every buffer it needs: solving a frame does not allocate. Not thread-safe; use
/// one Solver (and Workspace) per thread.
class Solver {
 public:
  Solver(const sim::System& system, std::vector<MarkerTask> markers, std::vector<CoordinateTask> coordinates,
         SolverOptions options = {});

  /// Solves one frame. @p observed holds one position per marker task (ground frame, metres;
  /// NaN for a missing marker). @p reference holds one value per coordinate task. @p q is the
  /// initial guess (warm start) on entry and the solution on exit, all model coordinates.
  FrameResult solveFrame(sim::Workspace& ws, const std::vector<Eigen::Vector3d>& observed,
                         const std::vector<double>& reference, Eigen::VectorXd& q);

  /// Solves the next frame of a trial: solveFrame() warm-started from the linear extrapolation
  /// q_last + (q_last - q_before) of the last two frames solved by trackFrame() (from q_last
  /// after one frame; from @p q as given after construction or resetTracking()). Sampled motion
  /// is smooth, so this start is usually within the convergence tolerance after one step.
  FrameResult trackFrame(sim::Workspace& ws, const std::vector<Eigen::Vector3d>& observed,
                         const std::vector<double>& reference, Eigen::VectorXd& q);
  /// Forgets the frames trackFrame() remembers (call at a new trial or after a skipped frame).
  void resetTracking() { tracked_ = 0; }

  /// Applies locks and couplers to @p q (dependent coordinates recomputed; locked ones reset).
  void applyConstraints(Eigen::VectorXd& q) const;

  /// Per-marker distance |model - measured| of the last solved frame (NaN for missing markers).
  const std::vector<double>& getLastMarkerErrors() const { return marker_errors_; }
  /// Model marker positions in ground of the last solved frame.
  const std::vector<Eigen::Vector3d>& getLastModelMarkers() const { return model_markers_; }

  const std::vector<MarkerTask>& getMarkerTasks() const { return marker_tasks_; }
  const std::vector<CoordinateTask>& getCoordinateTasks() const { return coord_tasks_; }
  /// Indices of the coordinates the solver varies.
  const std::vector<int>& getFreeCoordinates() const { return free_; }

 private:
  double evaluate(sim::Workspace& ws, const Eigen::VectorXd& q, const std::vector<Eigen::Vector3d>& observed,
                  const std::vector<double>& reference);
  void buildExpansion(const Eigen::VectorXd& q);
  void calcResidualJacobian(sim::Workspace& ws, const Eigen::VectorXd& q);
  double calcMarkerMotion() const;

  const sim::System& system_;
  std::vector<MarkerTask> marker_tasks_;
  std::vector<CoordinateTask> coord_tasks_;
  SolverOptions options_;

  std::vector<int> free_;             // free coordinate indices (variables)
  std::vector<int> var_of_coord_;     // coordinate -> variable index or -1
  std::vector<int> coupler_order_;    // couplers in dependency order
  std::vector<double> lower_, upper_; // bounds per variable (±inf if not clamped)

  // Buffers (sized once).
  std::vector<int> bodies_;
  std::vector<Eigen::Vector3d> stations_;
  std::vector<double> weights_;       // per marker task, 0 when missing this frame
  Eigen::MatrixXd Jq_;                // 3m x nq
  Eigen::MatrixXd E_;                 // nq x nz  (dq/dz)
  std::vector<std::vector<int>> e_cols_;  // per coordinate: columns of E that may be non-zero
  Eigen::MatrixXd J_;                 // (3m + nc) x nz residual Jacobian
  Eigen::VectorXd r_;                 // residuals
  Eigen::MatrixXd H_, A_;           // Gauss-Newton matrix and its damped copy
  Eigen::VectorXd g_, step_, z_, z_trial_;
  Eigen::VectorXd q_trial_;
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
  std::vector<char> active_;
  std::vector<double> marker_errors_;
  Eigen::VectorXd q_last_, q_before_;  // trackFrame() history
  int tracked_ = 0;
  std::vector<Eigen::Vector3d> model_markers_;
};

}  // namespace kneesim::ik
