#pragma once
// The optimisation of one static-optimisation frame: minimise sum |x_i|^p subject to A x = b and
// lower <= x <= upper. For p = 2 (a quadratic programme) by Newton's method on its dual; for
// other exponents by Ipopt (C++ API; one solve at a time in the process).

#include <memory>

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace kneesim::muscle {

/// min sum x_i^2 subject to A x = b, lower <= x <= upper, on the dual: x(nu) = clamp(-A^T nu / 2),
/// and nu solves A x(nu) = b, a piecewise-linear system solved by semismooth Newton steps,
/// Levenberg-damped where too few variables are free, each raising the (concave) dual function.
/// Exact once the active bounds are found.
class BoundedMinNormSolver {
 public:
  BoundedMinNormSolver(int num_variables, int num_constraints);
  /// Solves from the multipliers of the previous call (zero at first); @p x receives the
  /// solution. Returns whether |A x - b| <= @p tolerance was reached. No allocation.
  bool solve(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lower,
             const Eigen::VectorXd& upper, double tolerance, Eigen::VectorXd& x, int& iterations);

 private:
  double calcDual(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lower,
                  const Eigen::VectorXd& upper, const Eigen::VectorXd& nu, Eigen::VectorXd& x);
  Eigen::VectorXd nu_, trial_nu_, step_, r_, atnu_, trial_x_;
  Eigen::MatrixXd J_, Jm_, AF_;
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
};

/// The frame's solver, set up once for problems of one size and reused frame after frame.
class SoSolver {
 public:
  /// Ipopt unless @p exponent is 2 and @p dedicated_qp (BoundedMinNormSolver).
  SoSolver(int num_variables, int num_constraints, double exponent, double tolerance, int max_iterations,
           bool dedicated_qp = true);
  ~SoSolver();

  /// Solves the problem held in @p A, @p b, @p lower, @p upper (kept by reference for the call),
  /// starting from @p x (Ipopt) or the previous multipliers (p = 2), @p x receiving the solution.
  /// Returns whether the solver converged and writes its iteration count to @p iterations.
  bool solve(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lower,
             const Eigen::VectorXd& upper, Eigen::VectorXd& x, int& iterations);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;                 // Ipopt, for p != 2
  std::unique_ptr<BoundedMinNormSolver> qp_;  // for p = 2
};

}  // namespace kneesim::muscle
