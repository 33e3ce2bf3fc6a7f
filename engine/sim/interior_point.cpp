// Simbody's interior-point optimizer with OpenSim StaticOptimization's settings.
#include "sim/interior_point.hpp"

#include <SimTKmath.h>

#include <cmath>

namespace kneesim::sim {

namespace {

/// StaticOptimizationTarget's problem: the objective sum |x|^p with its analytic gradient, and
/// linear equalities with their constant Jacobian.
class PowerSumProblem : public SimTK::OptimizerSystem {
 public:
  PowerSumProblem(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, double p)
      : SimTK::OptimizerSystem(int(A.cols())), A_(A), b_(b), p_(p) {
    setNumEqualityConstraints(int(A.rows()));
    setNumLinearEqualityConstraints(int(A.rows()));
  }
  int objectiveFunc(const SimTK::Vector& x, bool, SimTK::Real& f) const override {
    f = 0.0;
    for (int i = 0; i < x.size(); ++i) f += std::pow(std::fabs(x[i]), p_);
    return 0;
  }
  int gradientFunc(const SimTK::Vector& x, bool, SimTK::Vector& g) const override {
    for (int i = 0; i < x.size(); ++i) g[i] = (x[i] < 0 ? -1.0 : 1.0) * p_ * std::pow(std::fabs(x[i]), p_ - 1.0);
    return 0;
  }
  int constraintFunc(const SimTK::Vector& x, bool, SimTK::Vector& c) const override {
    for (int r = 0; r < int(A_.rows()); ++r) {
      double ax = 0.0;
      for (int j = 0; j < int(A_.cols()); ++j) ax += A_(r, j) * x[j];
      c[r] = b_[r] - ax;
    }
    return 0;
  }
  int constraintJacobian(const SimTK::Vector&, bool, SimTK::Matrix& J) const override {
    for (int r = 0; r < int(A_.rows()); ++r)
      for (int j = 0; j < int(A_.cols()); ++j) J(r, j) = -A_(r, j);
    return 0;
  }

 private:
  const Eigen::MatrixXd& A_;
  const Eigen::VectorXd& b_;
  double p_;
};

}  // namespace

bool minimizePowerSumWithSimbody(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lower,
                                 const Eigen::VectorXd& upper, double p, const SimbodyOptimizerSettings& settings,
                                 Eigen::VectorXd& x, std::string& status) {
  const int n = int(A.cols());
  PowerSumProblem problem(A, b, p);
  SimTK::Vector lo(n), up(n), xs(n);
  for (int j = 0; j < n; ++j) {
    lo[j] = lower[j];
    up[j] = upper[j];
    xs[j] = x[j];
  }
  problem.setParameterLimits(lo, up);
  SimTK::Optimizer optimizer(problem, SimTK::InteriorPoint);
  optimizer.setDiagnosticsLevel(0);
  optimizer.setConvergenceTolerance(settings.tolerance);
  optimizer.setMaxIterations(settings.max_iterations);
  optimizer.useNumericalGradient(false);
  optimizer.useNumericalJacobian(false);
  optimizer.setLimitedMemoryHistory(settings.lbfgs_history);
  optimizer.setAdvancedBoolOption("warm_start", true);  // no effect on a fresh optimizer's first solve
  optimizer.setAdvancedRealOption("obj_scaling_factor", 1);
  optimizer.setAdvancedRealOption("nlp_scaling_max_gradient", 1);
  try {
    optimizer.optimize(xs);
  } catch (const std::exception& e) {
    status = e.what();
    return false;
  }
  for (int j = 0; j < n; ++j) x[j] = xs[j];
  status = "solved";
  return true;
}

}  // namespace kneesim::sim
