// One static-optimisation frame: sum |x|^p with linear equalities and bounds, by Newton's method
// on the dual for p = 2 and by Ipopt otherwise.
#include "muscle/so_solver.hpp"

#include <IpIpoptApplication.hpp>
#include <IpSolveStatistics.hpp>
#include <IpTNLP.hpp>

#include <cmath>
#include <mutex>

#include "core/error.hpp"
#include "identify/least_squares.hpp"

namespace kneesim::muscle {

namespace {

/// The frame's problem as Ipopt sees it; the data belong to the caller for one solve.
class SoTnlp : public Ipopt::TNLP {
 public:
  SoTnlp(int n, int m, double p) : n_(n), m_(m), p_(p) {}

  const Eigen::MatrixXd* A = nullptr;
  const Eigen::VectorXd* b = nullptr;
  const Eigen::VectorXd* lower = nullptr;
  const Eigen::VectorXd* upper = nullptr;
  Eigen::VectorXd* x = nullptr;
  bool solved = false;

  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac_g, Ipopt::Index& nnz_h_lag,
                    IndexStyleEnum& style) override {
    n = n_;
    m = m_;
    nnz_jac_g = n_ * m_;
    nnz_h_lag = n_;  // the objective is separable; the constraints are linear
    style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* xl, Ipopt::Number* xu, Ipopt::Index m, Ipopt::Number* gl,
                       Ipopt::Number* gu) override {
    for (int j = 0; j < n; ++j) {
      xl[j] = (*lower)[j];
      xu[j] = (*upper)[j];
    }
    for (int i = 0; i < m; ++i) gl[i] = gu[i] = (*b)[i];
    return true;
  }

  bool get_starting_point(Ipopt::Index n, bool, Ipopt::Number* x0, bool, Ipopt::Number*, Ipopt::Number*, Ipopt::Index,
                          bool, Ipopt::Number*) override {
    for (int j = 0; j < n; ++j) x0[j] = (*x)[j];
    return true;
  }

  bool eval_f(Ipopt::Index n, const Ipopt::Number* x0, bool, Ipopt::Number& f) override {
    f = 0;
    for (int j = 0; j < n; ++j) f += std::pow(std::abs(x0[j]), p_);
    return true;
  }

  bool eval_grad_f(Ipopt::Index n, const Ipopt::Number* x0, bool, Ipopt::Number* g) override {
    for (int j = 0; j < n; ++j) g[j] = std::copysign(p_ * std::pow(std::abs(x0[j]), p_ - 1.0), x0[j]);
    return true;
  }

  bool eval_g(Ipopt::Index n, const Ipopt::Number* x0, bool, Ipopt::Index m, Ipopt::Number* g) override {
    for (int i = 0; i < m; ++i) {
      double s = 0;
      for (int j = 0; j < n; ++j) s += (*A)(i, j) * x0[j];
      g[i] = s;
    }
    return true;
  }

  bool eval_jac_g(Ipopt::Index n, const Ipopt::Number*, bool, Ipopt::Index m, Ipopt::Index, Ipopt::Index* rows,
                  Ipopt::Index* cols, Ipopt::Number* values) override {
    int k = 0;
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < n; ++j, ++k) {
        if (values)
          values[k] = (*A)(i, j);
        else {
          rows[k] = i;
          cols[k] = j;
        }
      }
    return true;
  }

  bool eval_h(Ipopt::Index n, const Ipopt::Number* x0, bool, Ipopt::Number obj_factor, Ipopt::Index, const Ipopt::Number*,
              bool, Ipopt::Index, Ipopt::Index* rows, Ipopt::Index* cols, Ipopt::Number* values) override {
    for (int j = 0; j < n; ++j) {
      if (values)
        values[j] = obj_factor * p_ * (p_ - 1.0) * std::pow(std::max(std::abs(x0[j]), 1e-12), p_ - 2.0);
      else
        rows[j] = cols[j] = j;
    }
    return true;
  }

  void finalize_solution(Ipopt::SolverReturn status, Ipopt::Index n, const Ipopt::Number* xs, const Ipopt::Number*,
                         const Ipopt::Number*, Ipopt::Index, const Ipopt::Number*, const Ipopt::Number*, Ipopt::Number,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    for (int j = 0; j < n; ++j) (*x)[j] = xs[j];
    solved = status == Ipopt::SUCCESS || status == Ipopt::STOP_AT_ACCEPTABLE_POINT;
  }

 private:
  int n_, m_;
  double p_;
};

}  // namespace

BoundedMinNormSolver::BoundedMinNormSolver(int n, int m)
    : nu_(Eigen::VectorXd::Zero(m)),
      trial_nu_(Eigen::VectorXd::Zero(m)),
      step_(Eigen::VectorXd::Zero(m)),
      r_(Eigen::VectorXd::Zero(m)),
      atnu_(Eigen::VectorXd::Zero(n)),
      trial_x_(Eigen::VectorXd::Zero(n)),
      J_(Eigen::MatrixXd::Zero(m, m)),
      Jm_(Eigen::MatrixXd::Zero(m, m)),
      AF_(Eigen::MatrixXd::Zero(m, n)),
      ldlt_(m) {}

double BoundedMinNormSolver::calcDual(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lower,
                                      const Eigen::VectorXd& upper, const Eigen::VectorXd& nu, Eigen::VectorXd& x) {
  // theta(nu) = min over the box of sum x^2 + nu . (A x - b), reached at x = clamp(-A^T nu / 2).
  atnu_.noalias() = A.transpose() * nu;
  x = (-0.5 * atnu_).cwiseMax(lower).cwiseMin(upper);
  return x.squaredNorm() + atnu_.dot(x) - nu.dot(b);
}

bool BoundedMinNormSolver::solve(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lower,
                                 const Eigen::VectorXd& upper, double tolerance, Eigen::VectorXd& x, int& iterations) {
  constexpr int kMaxIterations = 100;
  if (!nu_.allFinite()) nu_.setZero();
  double theta = calcDual(A, b, lower, upper, nu_, x);
  // The damping's scale: the mean diagonal of A A^T / 2.
  const double scale = std::max(0.5 * A.squaredNorm() / double(std::max<Eigen::Index>(1, A.rows())), 1e-300);
  double mu = 1e-10 * scale;
  bool accepted = false;
  for (iterations = 0; iterations < kMaxIterations; ++iterations) {
    r_.noalias() = A * x;
    r_ -= b;  // the dual's gradient
    if (r_.cwiseAbs().maxCoeff() <= tolerance) return true;
    // The dual's (negative) Hessian: the free variables' columns, A_F A_F^T / 2, made definite by
    // a tiny ridge where too few variables are free.
    for (int j = 0; j < A.cols(); ++j) {
      const double v = -0.5 * atnu_[j];
      if (v > lower[j] && v < upper[j])
        AF_.col(j) = A.col(j);
      else
        AF_.col(j).setZero();
    }
    J_.noalias() = 0.5 * AF_ * AF_.transpose();
    // Levenberg damping: tiny while Newton steps succeed, raised while they do not.
    accepted = false;
    for (int tries = 0; tries < 40 && !accepted; ++tries) {
      Jm_ = J_;
      Jm_.diagonal().array() += mu;
      ldlt_.compute(Jm_);
      step_ = ldlt_.solve(r_);
      trial_nu_ = nu_ + step_;
      const double trial = calcDual(A, b, lower, upper, trial_nu_, trial_x_);
      if (trial >= theta + 1e-4 * r_.dot(step_)) {
        theta = trial;
        nu_ = trial_nu_;
        x = trial_x_;
        accepted = true;
        mu = std::max(mu * 0.1, 1e-14 * scale);
      } else {
        mu *= 10.0;
      }
    }
    if (!accepted) break;  // no ascent left: infeasible, or converged to rounding
  }
  calcDual(A, b, lower, upper, nu_, x);
  r_.noalias() = A * x;
  r_ -= b;
  return r_.cwiseAbs().maxCoeff() <= tolerance;
}

struct SoSolver::Impl {
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app;
  Ipopt::SmartPtr<SoTnlp> tnlp;
};

SoSolver::SoSolver(int num_variables, int num_constraints, double exponent, double tolerance, int max_iterations,
                   bool dedicated_qp) {
  if (exponent == 2.0 && dedicated_qp) {
    qp_ = std::make_unique<BoundedMinNormSolver>(num_variables, num_constraints);
    return;
  }
  impl_ = std::make_unique<Impl>();
  std::lock_guard<std::mutex> lock(identify::getIpoptMutex());
  impl_->tnlp = new SoTnlp(num_variables, num_constraints, exponent);
  impl_->app = IpoptApplicationFactory();
  Ipopt::OptionsList& o = *impl_->app->Options();
  o.SetStringValue("sb", "yes");
  o.SetIntegerValue("print_level", 0);
  o.SetIntegerValue("max_iter", max_iterations);
  o.SetNumericValue("tol", tolerance);
  o.SetStringValue("mu_strategy", "adaptive");
  o.SetStringValue("jac_c_constant", "yes");
  // As OpenSim sets it: rows of the equations of motion scaled to a largest gradient of 1.
  o.SetNumericValue("nlp_scaling_max_gradient", 1.0);
  impl_->app->RethrowNonIpoptException(false);
  // Initialize("") rather than Initialize(): the latter reads a stray ipopt.opt from the working folder.
  KNEESIM_CHECK(impl_->app->Initialize("") == Ipopt::Solve_Succeeded, "Ipopt refused the static optimisation options");
}

SoSolver::~SoSolver() {
  if (!impl_) return;
  std::lock_guard<std::mutex> lock(identify::getIpoptMutex());
  impl_.reset();
}

bool SoSolver::solve(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lower,
                     const Eigen::VectorXd& upper, Eigen::VectorXd& x, int& iterations) {
  // p = 2: exact once the active bounds are found, so a tolerance near rounding.
  if (qp_) return qp_->solve(A, b, lower, upper, 1e-10 * (1.0 + b.cwiseAbs().maxCoeff()), x, iterations);
  SoTnlp& t = *impl_->tnlp;
  t.A = &A;
  t.b = &b;
  t.lower = &lower;
  t.upper = &upper;
  t.x = &x;
  t.solved = false;
  std::lock_guard<std::mutex> lock(identify::getIpoptMutex());
  impl_->app->OptimizeTNLP(Ipopt::GetRawPtr(impl_->tnlp));
  const auto stats = impl_->app->Statistics();
  iterations = Ipopt::IsValid(stats) ? stats->IterationCount() : 0;
  return t.solved;
}

}  // namespace kneesim::muscle
