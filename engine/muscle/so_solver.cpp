// Ipopt on one static-optimisation frame: sum |x|^p with linear equalities and bounds.
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

struct SoSolver::Impl {
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app;
  Ipopt::SmartPtr<SoTnlp> tnlp;
};

SoSolver::SoSolver(int num_variables, int num_constraints, double exponent, double tolerance, int max_iterations)
    : impl_(std::make_unique<Impl>()) {
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
  o.SetStringValue("hessian_constant", exponent == 2.0 ? "yes" : "no");
  // As OpenSim sets it: rows of the equations of motion scaled to a largest gradient of 1.
  o.SetNumericValue("nlp_scaling_max_gradient", 1.0);
  impl_->app->RethrowNonIpoptException(false);
  // Initialize("") rather than Initialize(): the latter reads a stray ipopt.opt from the working folder.
  KNEESIM_CHECK(impl_->app->Initialize("") == Ipopt::Solve_Succeeded, "Ipopt refused the static optimisation options");
}

SoSolver::~SoSolver() {
  std::lock_guard<std::mutex> lock(identify::getIpoptMutex());
  impl_.reset();
}

bool SoSolver::solve(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const Eigen::VectorXd& lower,
                     const Eigen::VectorXd& upper, Eigen::VectorXd& x, int& iterations) {
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
