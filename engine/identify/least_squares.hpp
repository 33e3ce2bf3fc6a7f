#pragma once
// Bounded weighted nonlinear least squares solved with Ipopt (C++ API).
//
// Ipopt's linear solver (MUMPS) is not thread-safe, so every solve in the process holds one mutex
// (getIpoptMutex()); solves from several threads run one after another.

#include <mutex>
#include <string>
#include <vector>

namespace kneesim::identify {

/// Residuals r(x) and their Jacobian for solveLeastSquares.
class LeastSquaresProblem {
 public:
  virtual ~LeastSquaresProblem() = default;
  /// Number of unknowns.
  virtual int getNumParameters() const = 0;
  /// Number of residuals.
  virtual int getNumResiduals() const = 0;
  /// Fills @p r (getNumResiduals() values) at @p x and, if @p jacobian is not null, dr_i/dx_j into
  /// jacobian[j * n + i]. May throw; the exception is rethrown by solveLeastSquares.
  virtual void calcResiduals(const double* x, double* r, double* jacobian) = 0;
};

/// How to solve.
struct LeastSquaresOptions {
  std::vector<double> lower;    ///< Bounds of x (use +-1e20 for none); empty: unbounded.
  std::vector<double> upper;
  std::vector<double> scale;    ///< Typical magnitude of each x_j; Ipopt works on x_j / scale_j. Empty: 1.
  std::vector<double> weights;  ///< Per-residual weights >= 0; empty: 1.
  int max_iterations = 200;
  double tolerance = 1e-10;     ///< Ipopt "tol" on the scaled problem (objective 1 at the start point).
  bool gauss_newton = true;     ///< Hessian J^T W J (exact Gauss-Newton); false: Ipopt's L-BFGS.
  bool verbose = false;         ///< Ipopt's iteration log on stdout (print_level 5) instead of silence.
  /// Starting barrier parameter with the monotone barrier strategy, for a start point known to be
  /// near the solution (refits from an optimum: about half the iterations). 0: Ipopt's adaptive
  /// strategy from its default barrier parameter.
  double warm_mu = 0;
};

/// Outcome of solveLeastSquares.
struct LeastSquaresResult {
  std::vector<double> x;        ///< Solution (the start point if nothing was free).
  double sse = 0;               ///< Sum of weight * residual^2 at x.
  double start_sse = 0;         ///< The same at the start point.
  int iterations = 0;
  int status_code = 0;          ///< Ipopt's ApplicationReturnStatus.
  std::string status;           ///< Its name, e.g. "Solve_Succeeded"; or "Objective_Stalled" (below).
  /// Solved, solved to an acceptable level, or stalled: the objective has not decreased by more than
  /// 1e-10 (relative) for 25 iterations while the scaled gradient is below 1e-2 -- converged in value
  /// though Ipopt's gradient test is not met; x is then the best point evaluated.
  bool success = false;
  std::vector<bool> at_lower;   ///< x_j within 1e-6 scale_j of its bound.
  std::vector<bool> at_upper;
};

/// Minimises sum_i w_i r_i(x)^2 subject to lower <= x <= upper from @p x0. Throws whatever the
/// problem's calcResiduals threw; otherwise reports Ipopt's status without throwing.
LeastSquaresResult solveLeastSquares(LeastSquaresProblem& problem, const std::vector<double>& x0,
                                     const LeastSquaresOptions& options);

/// The process-wide mutex every Ipopt solve holds (MUMPS is not thread-safe).
std::mutex& getIpoptMutex();

}  // namespace kneesim::identify
