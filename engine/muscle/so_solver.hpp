#pragma once
// The optimisation of one static-optimisation frame: minimise sum |x_i|^p subject to A x = b and
// lower <= x <= upper, by Ipopt (C++ API; one solve at a time in the process).

#include <memory>

#include <Eigen/Core>

namespace kneesim::muscle {

/// Ipopt set up once for problems of one size, reused frame after frame.
class SoSolver {
 public:
  SoSolver(int num_variables, int num_constraints, double exponent, double tolerance, int max_iterations);
  ~SoSolver();

  /// Solves the problem held in @p A, @p b, @p lower, @p upper (kept by reference for the call),
  /// starting from @p x, which receives the solution. Returns whether Ipopt converged and
  /// writes its iteration count to @p iterations.
  bool solve(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lower,
             const Eigen::VectorXd& upper, Eigen::VectorXd& x, int& iterations);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kneesim::muscle
