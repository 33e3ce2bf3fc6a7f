#pragma once
// Simbody's interior-point optimizer (SimTK::Optimizer with InteriorPoint: the Ipopt that
// Simbody bundles, with a limited-memory Hessian) on the problem OpenSim's StaticOptimization
// gives it at each frame, with the settings it gives it (StaticOptimization::record): minimise
// sum |x_i|^p subject to A x = b and lower <= x <= upper. OpenSim's answers are this optimizer's
// iterate where its convergence test stops, not the optimum; solving the same problem the same
// way reproduces them (docs/static_optimization.md). Simbody types stay out of this header.

#include <string>

#include <Eigen/Core>

namespace kneesim::sim {

/// What OpenSim's StaticOptimization sets on the optimizer.
struct SimbodyOptimizerSettings {
  double tolerance = 1e-4;    ///< optimizer_convergence_criterion (Ipopt's tol and its kin).
  int max_iterations = 100;   ///< optimizer_max_iterations.
  int lbfgs_history = 500;    ///< setLimitedMemoryHistory(500).
};

/// Minimises sum |x_i|^p subject to @p A x = @p b and @p lower <= x <= @p upper by a fresh
/// SimTK::Optimizer (OpenSim makes one per frame), started from @p x (OpenSim: zero); @p x receives
/// the result. The equality is stated as OpenSim states it, b - A x = 0 with Jacobian -A. Returns
/// false, with Simbody's message in @p status, where the optimizer throws (then @p x is left as
/// given). Allocates; not for hot loops.
bool minimizePowerSumWithSimbody(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lower,
                                 const Eigen::VectorXd& upper, double p, const SimbodyOptimizerSettings& settings,
                                 Eigen::VectorXd& x, std::string& status);

}  // namespace kneesim::sim
