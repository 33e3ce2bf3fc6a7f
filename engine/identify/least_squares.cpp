#include "identify/least_squares.hpp"

#include <IpIpoptApplication.hpp>
#include <IpSolveStatistics.hpp>
#include <IpTNLP.hpp>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>

#include "core/error.hpp"

namespace kneesim::identify {

std::mutex& getIpoptMutex() {
  static std::mutex m;
  return m;
}

namespace {

std::string statusName(Ipopt::ApplicationReturnStatus s) {
  switch (s) {
    case Ipopt::Solve_Succeeded: return "Solve_Succeeded";
    case Ipopt::Solved_To_Acceptable_Level: return "Solved_To_Acceptable_Level";
    case Ipopt::Infeasible_Problem_Detected: return "Infeasible_Problem_Detected";
    case Ipopt::Search_Direction_Becomes_Too_Small: return "Search_Direction_Becomes_Too_Small";
    case Ipopt::Diverging_Iterates: return "Diverging_Iterates";
    case Ipopt::User_Requested_Stop: return "User_Requested_Stop";
    case Ipopt::Feasible_Point_Found: return "Feasible_Point_Found";
    case Ipopt::Maximum_Iterations_Exceeded: return "Maximum_Iterations_Exceeded";
    case Ipopt::Restoration_Failed: return "Restoration_Failed";
    case Ipopt::Error_In_Step_Computation: return "Error_In_Step_Computation";
    case Ipopt::Maximum_CpuTime_Exceeded: return "Maximum_CpuTime_Exceeded";
    case Ipopt::Not_Enough_Degrees_Of_Freedom: return "Not_Enough_Degrees_Of_Freedom";
    case Ipopt::Invalid_Problem_Definition: return "Invalid_Problem_Definition";
    case Ipopt::Invalid_Option: return "Invalid_Option";
    case Ipopt::Invalid_Number_Detected: return "Invalid_Number_Detected";
    case Ipopt::Unrecoverable_Exception: return "Unrecoverable_Exception";
    case Ipopt::NonIpopt_Exception_Thrown: return "NonIpopt_Exception_Thrown";
    case Ipopt::Insufficient_Memory: return "Insufficient_Memory";
    case Ipopt::Internal_Error: return "Internal_Error";
  }
  return "Unknown_Status_" + std::to_string(static_cast<int>(s));
}

// The TNLP works on y = x / scale and minimises 0.5 * sum w r^2 / objective_scale, with the
// objective scale set to the start point's value so that Ipopt sees an objective of order one.
class LsqTnlp : public Ipopt::TNLP {
 public:
  LsqTnlp(LeastSquaresProblem& p, const std::vector<double>& x0, const LeastSquaresOptions& o)
      : prob_(p), n_(p.getNumParameters()), m_(p.getNumResiduals()), x0_(x0) {
    scale_ = o.scale.empty() ? std::vector<double>(n_, 1.0) : o.scale;
    lower_ = o.lower.empty() ? std::vector<double>(n_, -1e20) : o.lower;
    upper_ = o.upper.empty() ? std::vector<double>(n_, 1e20) : o.upper;
    w_ = o.weights.empty() ? std::vector<double>(m_, 1.0) : o.weights;
    gauss_newton_ = o.gauss_newton;
    x_.assign(n_, 0.0);
    cached_x_.assign(n_, std::nan(""));
    r_.assign(m_, 0.0);
    jac_.assign(static_cast<size_t>(m_) * n_, 0.0);
    best_x_ = x0;
  }

  // Stops a solve whose objective no longer moves (see kStallIterations) once its scaled dual
  // infeasibility is small: Ipopt's own tests need the gradient below tol, which an
  // ill-conditioned valley with a Gauss-Newton Hessian (e.g. a threshold change that mostly
  // rescales the area, against the modulus) can take hundreds of cut-back steps to reach.
  bool intermediate_callback(Ipopt::AlgorithmMode mode, Ipopt::Index iter, Ipopt::Number obj_value, Ipopt::Number,
                             Ipopt::Number inf_du, Ipopt::Number, Ipopt::Number, Ipopt::Number, Ipopt::Number,
                             Ipopt::Number, Ipopt::Index, const Ipopt::IpoptData*,
                             Ipopt::IpoptCalculatedQuantities*) override {
    if (mode != Ipopt::RegularMode) return true;
    if (obj_value < best_objective_ - kStallRelativeChange * std::max(1.0, std::abs(obj_value))) {
      best_objective_ = obj_value;
      best_iteration_ = iter;
    }
    if (iter - best_iteration_ >= kStallIterations && inf_du < kStallDualInfeasibility) {
      stalled_ = true;
      return false;
    }
    return true;
  }

  // Objective at the start point; also sets the objective scale.
  double initialise() {
    evaluate(x0_.data(), false, true);
    start_sse_ = sse_;
    objective_scale_ = sse_ > 0 && std::isfinite(sse_) ? 0.5 * sse_ : 1.0;
    return sse_;
  }

  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac_g, Ipopt::Index& nnz_h_lag,
                    IndexStyleEnum& style) override {
    n = n_;
    m = 0;
    nnz_jac_g = 0;
    nnz_h_lag = n_ * (n_ + 1) / 2;
    style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* xl, Ipopt::Number* xu, Ipopt::Index, Ipopt::Number*,
                       Ipopt::Number*) override {
    for (int j = 0; j < n; ++j) {
      xl[j] = lower_[j] <= -1e19 ? -1e20 : lower_[j] / scale_[j];
      xu[j] = upper_[j] >= 1e19 ? 1e20 : upper_[j] / scale_[j];
    }
    return true;
  }

  bool get_starting_point(Ipopt::Index n, bool init_x, Ipopt::Number* x, bool, Ipopt::Number*, Ipopt::Number*,
                          Ipopt::Index, bool, Ipopt::Number*) override {
    if (init_x)
      for (int j = 0; j < n; ++j) x[j] = x0_[j] / scale_[j];
    return true;
  }

  bool eval_f(Ipopt::Index, const Ipopt::Number* y, bool, Ipopt::Number& f) override {
    if (!evaluateScaled(y, false)) return false;
    f = 0.5 * sse_ / objective_scale_;
    return std::isfinite(f);
  }

  bool eval_grad_f(Ipopt::Index n, const Ipopt::Number* y, bool, Ipopt::Number* g) override {
    if (!evaluateScaled(y, true)) return false;
    for (int j = 0; j < n; ++j) {
      const double* col = &jac_[static_cast<size_t>(j) * m_];
      double s = 0;
      for (int i = 0; i < m_; ++i) s += w_[i] * r_[i] * col[i];
      g[j] = s * scale_[j] / objective_scale_;
    }
    return true;
  }

  bool eval_g(Ipopt::Index, const Ipopt::Number*, bool, Ipopt::Index, Ipopt::Number*) override { return true; }

  bool eval_jac_g(Ipopt::Index, const Ipopt::Number*, bool, Ipopt::Index, Ipopt::Index, Ipopt::Index*, Ipopt::Index*,
                  Ipopt::Number*) override {
    return true;
  }

  bool eval_h(Ipopt::Index n, const Ipopt::Number* y, bool, Ipopt::Number obj_factor, Ipopt::Index, const Ipopt::Number*,
              bool, Ipopt::Index, Ipopt::Index* irow, Ipopt::Index* jcol, Ipopt::Number* values) override {
    if (!gauss_newton_) return false;
    if (!values) {
      int k = 0;
      for (int a = 0; a < n; ++a)
        for (int b = 0; b <= a; ++b) {
          irow[k] = a;
          jcol[k] = b;
          ++k;
        }
      return true;
    }
    if (!evaluateScaled(y, true)) return false;
    int k = 0;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b <= a; ++b) {
        const double* ca = &jac_[static_cast<size_t>(a) * m_];
        const double* cb = &jac_[static_cast<size_t>(b) * m_];
        double s = 0;
        for (int i = 0; i < m_; ++i) s += w_[i] * ca[i] * cb[i];
        values[k++] = obj_factor * s * scale_[a] * scale_[b] / objective_scale_;
      }
    return true;
  }

  void finalize_solution(Ipopt::SolverReturn, Ipopt::Index n, const Ipopt::Number* y, const Ipopt::Number*,
                         const Ipopt::Number*, Ipopt::Index, const Ipopt::Number*, const Ipopt::Number*, Ipopt::Number,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    final_x_.resize(n);
    for (int j = 0; j < n; ++j) final_x_[j] = y[j] * scale_[j];
  }

  // Evaluations report failure by returning false after storing the exception: Ipopt then stops
  // (or backtracks) and solveLeastSquares rethrows.
  bool evaluateScaled(const double* y, bool need_jac) {
    for (int j = 0; j < n_; ++j) x_[j] = y[j] * scale_[j];
    return evaluate(x_.data(), need_jac, false);
  }

  bool evaluate(const double* x, bool need_jac, bool rethrow) {
    const bool same = std::equal(x, x + n_, cached_x_.begin());
    if (same && (have_jac_ || !need_jac)) return std::isfinite(sse_);
    try {
      prob_.calcResiduals(x, r_.data(), need_jac ? jac_.data() : nullptr);
    } catch (...) {
      if (rethrow) throw;
      if (!error_) error_ = std::current_exception();
      std::fill(cached_x_.begin(), cached_x_.end(), std::nan(""));
      return false;
    }
    std::copy(x, x + n_, cached_x_.begin());
    have_jac_ = need_jac;
    sse_ = 0;
    for (int i = 0; i < m_; ++i) sse_ += w_[i] * r_[i] * r_[i];
    if (std::isfinite(sse_) && sse_ < best_sse_) {
      best_sse_ = sse_;
      best_x_.assign(x, x + n_);
    }
    return std::isfinite(sse_);
  }

  // Iterations without a relative objective decrease above kStallRelativeChange after which a solve
  // whose scaled dual infeasibility is below kStallDualInfeasibility counts as converged.
  static constexpr int kStallIterations = 25;
  static constexpr double kStallRelativeChange = 1e-10;
  static constexpr double kStallDualInfeasibility = 1e-2;
  bool stalled_ = false;
  double best_sse_ = std::numeric_limits<double>::infinity();
  std::vector<double> best_x_;  // lowest objective evaluated: the answer of a stalled solve

  std::exception_ptr error_;
  std::vector<double> final_x_;
  double start_sse_ = 0;

 private:
  LeastSquaresProblem& prob_;
  int n_, m_;
  std::vector<double> x0_, scale_, lower_, upper_, w_, x_, cached_x_, r_, jac_;
  double best_objective_ = std::numeric_limits<double>::infinity();
  int best_iteration_ = 0;
  bool gauss_newton_ = true;
  bool have_jac_ = false;
  double sse_ = 0;
  double objective_scale_ = 1;
};

// Sum of weighted squared residuals at x, for the final report.
double evalSse(LeastSquaresProblem& p, const std::vector<double>& x, const std::vector<double>& w) {
  std::vector<double> r(p.getNumResiduals());
  p.calcResiduals(x.data(), r.data(), nullptr);
  double s = 0;
  for (size_t i = 0; i < r.size(); ++i) s += (w.empty() ? 1.0 : w[i]) * r[i] * r[i];
  return s;
}

}  // namespace

LeastSquaresResult solveLeastSquares(LeastSquaresProblem& problem, const std::vector<double>& x0,
                                     const LeastSquaresOptions& o) {
  const int n = problem.getNumParameters();
  const int m = problem.getNumResiduals();
  KNEESIM_CHECK(static_cast<int>(x0.size()) == n, "start point of the wrong size");
  KNEESIM_CHECK(o.lower.empty() || static_cast<int>(o.lower.size()) == n, "lower bounds of the wrong size");
  KNEESIM_CHECK(o.upper.empty() || static_cast<int>(o.upper.size()) == n, "upper bounds of the wrong size");
  KNEESIM_CHECK(o.scale.empty() || static_cast<int>(o.scale.size()) == n, "scales of the wrong size");
  KNEESIM_CHECK(o.weights.empty() || static_cast<int>(o.weights.size()) == m, "weights of the wrong size");
  for (double s : o.scale) KNEESIM_CHECK(s > 0, "parameter scales must be positive");

  LeastSquaresResult res;
  res.x = x0;
  res.at_lower.assign(n, false);
  res.at_upper.assign(n, false);
  if (n == 0) {
    res.sse = res.start_sse = evalSse(problem, x0, o.weights);
    res.status = "Nothing_To_Solve";
    res.success = true;
    return res;
  }

  Ipopt::SmartPtr<LsqTnlp> tnlp = new LsqTnlp(problem, x0, o);
  res.start_sse = tnlp->initialise();  // throws if the start point cannot be evaluated
  {
    std::lock_guard<std::mutex> lock(getIpoptMutex());
    Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
    app->RethrowNonIpoptException(false);
    app->Options()->SetStringValue("sb", "yes");  // no banner
    app->Options()->SetIntegerValue("print_level", o.verbose ? 5 : 0);
    app->Options()->SetIntegerValue("max_iter", o.max_iterations);
    app->Options()->SetNumericValue("tol", o.tolerance);
    app->Options()->SetNumericValue("acceptable_tol", std::max(o.tolerance * 1e3, 1e-8));
    if (o.warm_mu > 0) {
      app->Options()->SetStringValue("mu_strategy", "monotone");
      app->Options()->SetNumericValue("mu_init", o.warm_mu);
      // Keep the warm start where it is: the default push (1 % of the scaled value, at least 0.01)
      // moved a modulus sitting near its lower bound far enough to multiply the objective by 1000.
      app->Options()->SetNumericValue("bound_push", 1e-8);
      app->Options()->SetNumericValue("bound_frac", 1e-8);
    } else {
      app->Options()->SetStringValue("mu_strategy", "adaptive");
    }
    app->Options()->SetStringValue("nlp_scaling_method", "none");  // the TNLP scales itself
    app->Options()->SetStringValue("hessian_approximation", o.gauss_newton ? "exact" : "limited-memory");
    // Initialize("") rather than Initialize(): the latter reads a stray ipopt.opt from the working folder.
    Ipopt::ApplicationReturnStatus st = app->Initialize("");
    if (st == Ipopt::Solve_Succeeded) st = app->OptimizeTNLP(Ipopt::GetRawPtr(tnlp));
    res.status_code = static_cast<int>(st);
    res.status = statusName(st);
    res.success = st == Ipopt::Solve_Succeeded || st == Ipopt::Solved_To_Acceptable_Level;
    if (st == Ipopt::User_Requested_Stop && tnlp->stalled_) {
      res.status = "Objective_Stalled";
      res.success = true;
    }
    if (Ipopt::IsValid(app->Statistics())) res.iterations = app->Statistics()->IterationCount();
  }
  if (tnlp->error_) std::rethrow_exception(tnlp->error_);
  if (tnlp->stalled_) res.x = tnlp->best_x_;  // the last iterate may be a watchdog trial point
  else if (static_cast<int>(tnlp->final_x_.size()) == n) res.x = tnlp->final_x_;
  // Clip round-off outside the bounds so that callers can rely on them.
  for (int j = 0; j < n; ++j) {
    const double lo = o.lower.empty() ? -1e20 : o.lower[j], hi = o.upper.empty() ? 1e20 : o.upper[j];
    const double s = o.scale.empty() ? 1.0 : o.scale[j];
    res.x[j] = std::min(std::max(res.x[j], lo), hi);
    res.at_lower[j] = lo > -1e19 && res.x[j] - lo <= 1e-6 * s;
    res.at_upper[j] = hi < 1e19 && hi - res.x[j] <= 1e-6 * s;
  }
  res.sse = evalSse(problem, res.x, o.weights);
  return res;
}

}  // namespace kneesim::identify
