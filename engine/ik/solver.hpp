#pragma once
// Inverse kinematics: weighted least squares between model and measured markers, per frame.

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Cholesky>

#include "ik/constraint_terms.hpp"
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
  /// OpenSim's constraint_weight for Model::constraints: infinity enforces them (every iterate
  /// is projected back onto them), a finite value adds weight * |c|^2 to the objective, c being
  /// Simbody's position errors (see ConstraintTerms). Couplers are always enforced exactly.
  double constraint_weight = std::numeric_limits<double>::infinity();
  /// Hard constraints are met when no equation is off by more than this (m, or the
  /// dimensionless orientation equations of a weld).
  double constraint_tolerance = 1e-10;
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
  /// Largest violation of Model::constraints at the solution (ConstraintTerms::calcViolation:
  /// m, or rad for a weld's orientation); 0 without constraints.
  double max_constraint_error = 0;
};

/// Weighted least-squares IK over the model's coordinates, honouring locked coordinates (held at
/// their default), clamped ranges (box constraints, active set), coordinate couplers
/// (eliminated: dependent coordinates are computed from their independents, so couplers hold
/// exactly) and the model's body constraints (SolverOptions::constraint_weight). Minimises
/// OpenSim's InverseKinematicsSolver objective (twice Simbody's Assembler goal):
///   sum_i w_i |x_i - p_i(q)|^2 / sum_i w_i  +  sum_j w_j (q_j - r_j)^2  [+ W |c(q)|^2]
/// (markers missing in the frame leave both sums) by Levenberg-Marquardt on the free
/// coordinates with Simbody's station Jacobians; with W infinite, c(q) = 0 is kept by a
/// constrained (KKT) step and a projection of every trial point back onto the constraints.
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
  /// The constraint equations in use (empty without Model::constraints).
  const ConstraintTerms& getConstraintTerms() const { return terms_; }
  /// Violation of each Model::constraints entry at the last solved frame (see FrameResult).
  const std::vector<double>& getLastConstraintErrors() const { return constraint_errors_; }

 private:
  double evaluate(sim::Workspace& ws, const Eigen::VectorXd& q, const std::vector<Eigen::Vector3d>& observed,
                  const std::vector<double>& reference);
  void buildExpansion(const Eigen::VectorXd& q);
  void calcResidualJacobian(sim::Workspace& ws, const Eigen::VectorXd& q);
  double calcMarkerMotion() const;
  /// Constraint stations at the realised state: positions, then (if @p jacobian) C = dc/dz.
  void evalConstraintStations(sim::Workspace& ws, bool jacobian);
  /// J = J_q E for the rows of one station set (columns over E's non-zeros).
  void expandJacobian(const Eigen::MatrixXd& Jq, Eigen::Ref<Eigen::MatrixXd> out) const;
  /// Moves z onto the hard constraints (Gauss-Newton, least-norm steps); updates q. Returns
  /// the largest remaining equation error.
  double projectOntoConstraints(sim::Workspace& ws, Eigen::VectorXd& z, Eigen::VectorXd& q);
  /// Solves the damped step with the linearised hard constraints C dz = -c (Schur complement).
  void solveConstrainedStep();
  /// The start of solveFrame(): the marker weights of the frame (into @p res's markers_used), q
  /// clamped to the bounds and onto the constraints; returns the cost there.
  double startFrame(sim::Workspace& ws, const std::vector<Eigen::Vector3d>& observed,
                    const std::vector<double>& reference, Eigen::VectorXd& q, FrameResult& res);
  /// Gradient g_ and Gauss-Newton matrix H_ at q, and the variables held at a bound (active_).
  void formNormalEquations(sim::Workspace& ws, const Eigen::VectorXd& q);
  /// The step with damping @p lambda, clamped to the bounds (step_, z_trial_); returns its size.
  double solveDampedStep(double lambda);
  /// q_trial_ from q and z_trial_, projected onto the hard constraints; returns the size of the
  /// step taken (@p step_size unless the projection changed it).
  double placeTrialPoint(sim::Workspace& ws, const Eigen::VectorXd& q, double step_size);
  /// The end of solveFrame(): unweighted marker errors and constraint violations at the solution.
  void finishFrame(sim::Workspace& ws, const std::vector<Eigen::Vector3d>& observed, FrameResult& res);
  bool hardConstraints() const { return n_eq_ > 0 && !std::isfinite(options_.constraint_weight); }
  bool penaltyConstraints() const { return n_eq_ > 0 && std::isfinite(options_.constraint_weight); }

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

  // Body constraints (ConstraintTerms), all buffers sized once.
  ConstraintTerms terms_;
  int n_eq_ = 0;
  int n_pen_ = 0;                     // penalty rows in r_/J_ (n_eq_ with a finite weight)
  std::vector<Eigen::Vector3d> k_points_;  // constraint stations in ground
  Eigen::MatrixXd Jk_, JkE_;          // their Jacobians in q and in z
  Eigen::VectorXd c_;                 // equation values
  Eigen::MatrixXd C_;                 // dc/dz
  Eigen::VectorXd c_here_;            // c and C at the current iterate
  Eigen::MatrixXd C_here_;
  Eigen::MatrixXd AinvCt_, S_;        // Schur complement pieces
  Eigen::VectorXd y_, mu_, cy_;
  Eigen::LDLT<Eigen::MatrixXd> ldlt_s_;
  std::vector<double> constraint_errors_;
};

}  // namespace kneesim::ik
