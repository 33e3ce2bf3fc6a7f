#include "gap/diagnosis.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <sstream>

#include <Eigen/QR>
#include <Eigen/SVD>

#include "core/strings.hpp"

namespace kneesim::gap {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string fmt(double v, int digits = 3) {
  std::ostringstream s;
  s.precision(digits);
  s << v;
  return s.str();
}

// A cycle of a trial with its frames: the unit of cross-validation.
struct Unit {
  int trial = 0;
  std::string activity;
  double begin = 0, end = 0;
  std::vector<int> frames;
};

// A model (the baseline plus effects) fitted on all units and cross-validated.
struct Model {
  explicit Model(identify::ContactLaw l) : law(std::move(l)) {}
  std::vector<Effect> effects;
  identify::ContactLaw law;
  std::vector<std::string> free;
  identify::FitReport fit;
  Eigen::VectorXd params;
  std::vector<std::vector<double>> pred;  // held-out prediction per trial and frame (NaN elsewhere)
  std::vector<double> unit_sse;
  std::vector<double> unit_wsse;  // prewhitened (Context::ar) held-out squared errors per unit
  std::vector<Eigen::VectorXd> fold_params;
  std::vector<std::vector<double>> fitted;  // in-sample force per trial and frame
  int cv_failures = 0;
  std::string cv_failure_status;  // Ipopt's status of the last fold fit that failed
  double cvMse(const std::vector<Unit>& units) const {
    double s = 0, n = 0;
    for (size_t u = 0; u < units.size(); ++u) s += unit_sse[u], n += units[u].frames.size();
    return n > 0 ? s / n : kNaN;
  }
  double totalWsse() const { return std::accumulate(unit_wsse.begin(), unit_wsse.end(), 0.0); }
};

// Everything the analyses of one target share.
struct Context {
  const identify::ContactLaw* base = nullptr;
  const std::vector<GapTrial>* gap_trials = nullptr;
  std::vector<identify::Trial> trials;  // target trials, no windows
  std::vector<Unit> units;
  std::vector<std::vector<int>> folds;
  const DiagnosisOptions* o = nullptr;
  double body_weight = 0;  // N
  std::vector<double> ar;  // prewhitening filter phi_1..phi_p (empty: none)
};

// A unit's values as one run of consecutive frames (NaN where the unit skips a frame), low-passed
// at kComparisonBandwidth when the run is complete: a measured force does not carry the
// frame-to-frame jitter the kinematics put into a model's areas, and whitening would weigh it most.
constexpr double kComparisonBandwidth = 6;  // Hz
std::vector<double> unitRun(const Context& c, const Unit& u, const std::vector<double>& v) {
  if (u.frames.empty()) return {};
  std::vector<double> run(u.frames.back() - u.frames.front() + 1, kNaN);
  for (int i : u.frames) run[i - u.frames.front()] = v[i];
  const auto& time = c.trials[u.trial].time;
  const double rate = time.size() > 1 ? (time.size() - 1) / (time.back() - time.front()) : 0.0;
  if (run.size() > 12 && rate > 2 * kComparisonBandwidth &&
      std::all_of(run.begin(), run.end(), [](double x) { return std::isfinite(x); }))
    run = lowPass(run, rate, kComparisonBandwidth);
  return run;
}

// The prewhitened held-out squared errors of each unit from m.pred.
void updateWhitened(const Context& c, Model& m) {
  m.unit_wsse.assign(c.units.size(), 0.0);
  std::vector<double> r;
  for (size_t u = 0; u < c.units.size(); ++u) {
    const Unit& un = c.units[u];
    if (c.ar.empty()) {
      m.unit_wsse[u] = m.unit_sse[u];
      continue;
    }
    r.assign(c.trials[un.trial].time.size(), kNaN);
    for (int i : un.frames) r[i] = c.trials[un.trial].measured_force[i] - m.pred[un.trial][i];
    m.unit_wsse[u] = whitenedSumOfSquares(c.ar, unitRun(c, un, r));
  }
}

// Per-frame values minus their activity's mean over the normalised cycle (bin means over all units
// of the activity, interpolated linearly between bin centres); NaN where fewer than two units cover
// a bin or the frame has no phase. What repeats from cycle to cycle is structure an effect may
// explain; what differs between cycles is the noise (the report's repeatability band).
std::vector<std::vector<double>> cycleDeviations(const Context& c, const std::vector<std::vector<double>>& v, int bins) {
  struct Curve {
    std::vector<double> sum, frames;
    std::vector<int> units;
  };
  std::map<std::string, Curve> curves;
  auto binOf = [&](double phase) { return std::clamp(static_cast<int>(phase * bins), 0, bins - 1); };
  auto usable = [&](const Unit& u, int i) {
    return std::isfinite(v[u.trial][i]) && std::isfinite((*c.gap_trials)[u.trial].cycle_phase[i]);
  };
  for (const auto& u : c.units) {
    Curve& cv = curves[u.activity];
    cv.sum.resize(bins, 0.0);
    cv.frames.resize(bins, 0.0);
    cv.units.resize(bins, 0);
    std::vector<bool> seen(bins, false);
    for (int i : u.frames) {
      if (!usable(u, i)) continue;
      const int b = binOf((*c.gap_trials)[u.trial].cycle_phase[i]);
      cv.sum[b] += v[u.trial][i];
      cv.frames[b] += 1;
      seen[b] = true;
    }
    for (int b = 0; b < bins; ++b) cv.units[b] += seen[b];
  }
  std::vector<std::vector<double>> out(v.size());
  for (size_t t = 0; t < v.size(); ++t) out[t].assign(v[t].size(), kNaN);
  for (const auto& u : c.units) {
    const Curve& cv = curves.at(u.activity);
    auto meanAt = [&](int b) { return cv.units[b] >= 2 ? cv.sum[b] / cv.frames[b] : kNaN; };
    for (int i : u.frames) {
      if (!usable(u, i)) continue;
      const double x = (*c.gap_trials)[u.trial].cycle_phase[i] * bins - 0.5;  // in bin-centre units
      const int b0 = std::clamp(static_cast<int>(std::floor(x)), 0, bins - 1), b1 = std::min(bins - 1, b0 + 1);
      const double w = std::clamp(x - b0, 0.0, 1.0);
      out[u.trial][i] = v[u.trial][i] - ((1 - w) * meanAt(b0) + w * meanAt(b1));
    }
  }
  return out;
}

// The prewhitening filter of a target: an AR model of the baseline's in-sample residuals over the
// units (DiagnosisOptions::prewhiten_order), once their cycle-locked mean is removed (cycleDeviations).
std::vector<double> fitPrewhitening(const Context& c, const std::vector<std::vector<double>>& v, int order) {
  if (order == 0) return {};
  std::vector<std::vector<double>> runs;
  for (const auto& u : c.units) runs.push_back(unitRun(c, u, v[u.trial]));
  return fitAutoregression(runs, order);
}

std::vector<std::pair<double, double>> windowsOf(const Context& c, int trial, const std::vector<int>& unit_ids) {
  std::vector<std::pair<double, double>> w;
  for (int u : unit_ids)
    if (c.units[u].trial == trial) w.emplace_back(c.units[u].begin, c.units[u].end);
  return w;
}

// The target trials restricted to the given units (trials without any are left out).
std::vector<identify::Trial> restrict(const Context& c, const std::vector<int>& unit_ids) {
  std::vector<identify::Trial> out;
  for (size_t t = 0; t < c.trials.size(); ++t) {
    const auto w = windowsOf(c, static_cast<int>(t), unit_ids);
    if (w.empty()) continue;
    identify::Trial tr = c.trials[t];
    for (const auto& [b, e] : w) tr.windows.push_back({b, e});
    out.push_back(std::move(tr));
  }
  return out;
}

identify::FitOptions fitOptionsFor(const Context& c, const identify::ContactLaw& law, const std::vector<std::string>& free,
                                   const Eigen::VectorXd& start, bool warm = false) {
  identify::FitOptions fo;
  fo.free_parameters = free;
  for (int j = 0; j < law.getNumParameters(); ++j) fo.parameter_values[law.getParameter(j).name] = start[j];
  for (const auto& [name, b] : c.o->fit.bounds)
    if (law.findParameterIndex(name) >= 0) fo.bounds[name] = b;
  fo.identifiability_tolerance = c.o->fit.identifiability_tolerance;
  fo.weak_identifiability_tolerance = c.o->fit.weak_identifiability_tolerance;
  fo.body_mass = c.o->fit.body_mass;
  fo.confidence.level = c.o->level;
  fo.confidence.asymptotic = true;
  fo.confidence.profile = false;
  fo.confidence.bootstrap_samples = 0;
  fo.max_iterations = c.o->fit.max_iterations;
  fo.tolerance = c.o->fit.tolerance;
  fo.where = c.o->fit.where;
  fo.warm_start = warm;
  return fo;
}

std::vector<int> allUnits(const Context& c) {
  std::vector<int> v(c.units.size());
  std::iota(v.begin(), v.end(), 0);
  return v;
}

// Fits `m` on all units (its law, free set and start in m.params) and cross-validates it.
void fitAndValidate(const Context& c, Model& m) {
  const std::vector<identify::Trial> all = restrict(c, allUnits(c));
  m.fit = identify::fit(m.law, all, fitOptionsFor(c, m.law, m.free, m.params));
  m.params = m.fit.getValues();
  // In-sample forces.
  m.fitted.assign(c.trials.size(), {});
  for (size_t t = 0; t < c.trials.size(); ++t) {
    const identify::LawInputs in(m.law, c.trials[t].channels, c.trials[t].time, c.trials[t].name);
    Eigen::VectorXd f;
    m.law.calcForce(m.params, in, f);
    m.fitted[t].assign(f.data(), f.data() + f.size());
  }
  m.pred.assign(c.trials.size(), {});
  for (size_t t = 0; t < c.trials.size(); ++t) m.pred[t].assign(c.trials[t].time.size(), kNaN);
  m.unit_sse.assign(c.units.size(), 0.0);
  m.fold_params.clear();
  m.cv_failures = 0;
  m.cv_failure_status.clear();
  for (const auto& fold : c.folds) {
    std::vector<int> train;
    for (size_t u = 0; u < c.units.size(); ++u)
      if (std::find(fold.begin(), fold.end(), static_cast<int>(u)) == fold.end()) train.push_back(static_cast<int>(u));
    const identify::FitReport fr =
        identify::fit(m.law, restrict(c, train), fitOptionsFor(c, m.law, m.free, m.params, /*warm=*/true));
    if (!fr.solver.success) ++m.cv_failures, m.cv_failure_status = fr.solver.status;
    const Eigen::VectorXd p = fr.getValues();
    m.fold_params.push_back(p);
    std::set<int> trials_in_fold;
    for (int u : fold) trials_in_fold.insert(c.units[u].trial);
    for (int t : trials_in_fold) {
      const identify::LawInputs in(m.law, c.trials[t].channels, c.trials[t].time, c.trials[t].name);
      Eigen::VectorXd f;
      m.law.calcForce(p, in, f);
      for (int u : fold) {
        if (c.units[u].trial != t) continue;
        double sse = 0;
        for (int i : c.units[u].frames) {
          m.pred[t][i] = f[i];
          const double r = c.trials[t].measured_force[i] - f[i];
          sse += r * r;
        }
        m.unit_sse[u] = sse;
      }
    }
  }
  updateWhitened(c, m);
}

// Lag-1 autocorrelation of per-frame values pooled over units (consecutive frames only).
double pooledLag1(const Context& c, const std::vector<std::vector<double>>& v) {
  double num = 0, den = 0;
  for (const auto& u : c.units) {
    double m = 0;
    int n = 0;
    for (int i : u.frames)
      if (std::isfinite(v[u.trial][i])) m += v[u.trial][i], ++n;
    if (n == 0) continue;
    m /= n;
    for (size_t k = 0; k < u.frames.size(); ++k) {
      const double a = v[u.trial][u.frames[k]] - m;
      if (!std::isfinite(a)) continue;
      den += a * a;
      if (k + 1 < u.frames.size() && std::isfinite(v[u.trial][u.frames[k + 1]]))
        num += a * (v[u.trial][u.frames[k + 1]] - m);
    }
  }
  return den > 0 ? num / den : 0.0;
}

// Effects (names) usable on every target trial, and the reasons of the others.
bool testable(const Context& c, const Effect& e, std::string& reason) {
  for (const auto& t : c.trials) {
    const auto miss = e.findMissingInputs(t.channels);
    if (!miss.empty()) {
      reason = "trial '" + t.name + "' lacks channel '" + miss.front() + "'";
      return false;
    }
  }
  return true;
}

// Orthonormal basis of the force changes an effect's parameters make at the current model that the
// current model's own parameters cannot make (its scaled sensitivity columns with the current
// model's columns projected out): what the data can see of the effect. Two effects whose bases
// span nearly the same direction cannot be told apart on these trials, however large they are.
using VisibleBasis = Eigen::MatrixXd;

Screening screen(const Context& c, const Model& m, const Effect& e, VisibleBasis* visible = nullptr) {
  Screening s;
  s.effect = e.getName();
  if (!testable(c, e, s.reason)) {
    s.testable = false;
    return s;
  }
  std::vector<Effect> effs = m.effects;
  effs.push_back(e);
  const identify::ContactLaw law = makeExtendedLaw(*c.base, effs);
  Eigen::VectorXd p0 = law.getDefaultValues();
  p0.head(m.params.size()) = m.params;
  std::vector<int> cols;
  for (const auto& f : m.free) cols.push_back(law.getParameterIndex(f));
  const int k_m = static_cast<int>(cols.size());
  std::vector<int> ecols;
  for (int j = m.law.getNumParameters(); j < law.getNumParameters(); ++j)
    if (!law.getParameter(j).fixed_by_default) ecols.push_back(j);
  cols.insert(cols.end(), ecols.begin(), ecols.end());
  int n = 0;
  for (const auto& u : c.units) n += static_cast<int>(u.frames.size());
  Eigen::MatrixXd a(n, cols.size());
  Eigen::VectorXd r(n);
  std::vector<std::vector<double>> resid(c.trials.size());
  int row = 0;
  for (size_t t = 0; t < c.trials.size(); ++t) {
    const identify::LawInputs in(law, c.trials[t].channels, c.trials[t].time, c.trials[t].name);
    Eigen::VectorXd f;
    Eigen::MatrixXd j;
    law.calcForce(p0, in, f, &j);
    resid[t].assign(f.size(), 0.0);
    for (int i = 0; i < f.size(); ++i) resid[t][i] = c.trials[t].measured_force[i] - f[i];
    for (const auto& u : c.units) {
      if (u.trial != static_cast<int>(t)) continue;
      for (int i : u.frames) {
        r[row] = resid[t][i];
        for (size_t k = 0; k < cols.size(); ++k) {
          const double sc = std::max(std::abs(p0[cols[k]]), law.getParameter(cols[k]).typical_scale);
          a(row, k) = j(i, cols[k]) * sc;
        }
        ++row;
      }
    }
  }
  if (!a.allFinite() || !r.allFinite()) {
    s.testable = false;
    s.reason = "non-finite force or sensitivity at the current model";
    return s;
  }
  auto projected = [&](const Eigen::MatrixXd& x, int& rank) {
    if (x.cols() == 0) {
      rank = 0;
      return 0.0;
    }
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(x);
    qr.setThreshold(1e-10);
    rank = static_cast<int>(qr.rank());
    const Eigen::VectorXd qtr = qr.householderQ().transpose() * r;
    return qtr.head(rank).squaredNorm();
  };
  int rank_m = 0, rank_full = 0;
  const double proj_m = projected(a.leftCols(k_m), rank_m);
  const double proj_full = projected(a, rank_full);
  s.dof = rank_full - rank_m;
  if (s.dof <= 0) {
    s.testable = false;
    s.reason = "its parameters do not change the force at the current model (no sensitivity)";
    return s;
  }
  const double sse = r.squaredNorm();
  const double sigma2 = sse / std::max(1, n - rank_m);
  const double delta = std::max(0.0, proj_full - proj_m);
  // One Gauss-Newton step: the least-squares solution of a x = r in the scaled parameters.
  const Eigen::VectorXd x = a.colPivHouseholderQr().solve(r);
  // Serial correlation of what the step leaves: the current model's residuals carry the very
  // structure being looked for, so their lag-1 correlation is near 1 for every effect and the
  // discount erased the ranking; after the effect's own step, the right effect leaves noise.
  {
    const Eigen::VectorXd left = r - a * x;
    int k = 0;  // rows of a are ordered as they were filled: by trial, then unit, then frame
    for (size_t t = 0; t < c.trials.size(); ++t)
      for (const auto& u : c.units)
        if (u.trial == static_cast<int>(t))
          for (int i : u.frames) resid[t][i] = left[k++];
  }
  const double rho = std::clamp(pooledLag1(c, resid), 0.0, 0.99);
  s.statistic = delta / sigma2 * (1 - rho) / (1 + rho);
  s.predicted_reduction = sse > 0 ? delta / sse : 0.0;
  bool outside = false;
  for (size_t k = 0; k < ecols.size(); ++k) {
    const int j = ecols[k];
    const double sc = std::max(std::abs(p0[j]), law.getParameter(j).typical_scale);
    const double v = p0[j] + x[k_m + k] * sc;
    s.one_step.emplace_back(law.getParameter(j).name, v);
    const auto& lp = law.getParameter(j);
    if ((p0[j] <= lp.lower && v < lp.lower) || (p0[j] >= lp.upper && v > lp.upper)) outside = true;
  }
  if (outside && ecols.size() == 1) {
    // At a bound the score test is one-sided: a step out of the bounds improves nothing allowed.
    s.statistic = 0;
    s.predicted_reduction = 0;
    s.reason = "the data push its parameter out of its bounds";
  }
  s.p_value = chiSquareSurvival(s.statistic, s.dof);
  s.z = (s.statistic - s.dof) / std::sqrt(2.0 * s.dof);
  if (visible) {
    Eigen::MatrixXd ex = a.rightCols(a.cols() - k_m);
    if (k_m > 0) {
      Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qm(a.leftCols(k_m));
      qm.setThreshold(1e-10);
      // Thin Q only: the full one is frames x frames.
      const Eigen::MatrixXd q = qm.householderQ() * Eigen::MatrixXd::Identity(ex.rows(), qm.rank());
      ex -= q * (q.transpose() * ex);
    }
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qe(ex);
    qe.setThreshold(1e-8);
    *visible = qe.householderQ() * Eigen::MatrixXd::Identity(ex.rows(), qe.rank());
  }
  return s;
}

// Largest canonical correlation between two visible bases (1: one effect's visible force change
// lies in the other's span).
double canonicalCorrelation(const VisibleBasis& a, const VisibleBasis& b) {
  if (a.cols() == 0 || b.cols() == 0 || a.rows() != b.rows()) return 0;
  const Eigen::MatrixXd m = a.transpose() * b;
  return std::min(1.0, Eigen::JacobiSVD<Eigen::MatrixXd>(m).singularValues()(0));
}

std::vector<double> signature(const Context& c, const Model& with, const Model& without) {
  std::vector<double> d;
  for (const auto& u : c.units)
    for (int i : u.frames) d.push_back(with.fitted[u.trial][i] - without.fitted[u.trial][i]);
  return d;
}

// Per-unit log ratios ln(a / b) of SSEs (> 0 where b is better).
std::vector<double> unitLogRatios(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> z(a.size());
  for (size_t u = 0; u < a.size(); ++u) z[u] = std::log(std::max(a[u], 1e-300) / std::max(b[u], 1e-300));
  return z;
}

CandidateFit evaluate(const Context& c, const Model& current, const Effect& e, int step, int n_candidates,
                      int n_screened, Model& out) {
  CandidateFit cf;
  cf.effect = e.getName();
  cf.step = step;
  out.effects = current.effects;
  out.effects.push_back(e);
  out.law = makeExtendedLaw(*c.base, out.effects);
  cf.law = out.law.getName();
  out.params = out.law.getDefaultValues();
  out.params.head(current.params.size()) = current.params;
  out.free = current.free;
  const int first = current.law.getNumParameters();
  for (int j = first; j < out.law.getNumParameters(); ++j)
    if (!out.law.getParameter(j).fixed_by_default) out.free.push_back(out.law.getParameter(j).name);
  fitAndValidate(c, out);
  cf.converged = out.fit.solver.success && out.cv_failures == 0;
  if (!out.fit.solver.success) cf.notes.push_back("the full fit did not converge: " + out.fit.solver.status);
  if (out.cv_failures > 0)
    cf.notes.push_back(std::to_string(out.cv_failures) + " fold fit(s) did not converge (" + out.cv_failure_status +
                       ")");
  cf.rmse_in_sample = out.fit.overall.rmse;
  cf.rmse_heldout = std::sqrt(out.cvMse(c.units));
  cf.log_ratio = meanInterval(unitLogRatios(current.unit_sse, out.unit_sse), c.o->level);
  cf.whitened_improvement = 1 - out.totalWsse() / std::max(current.totalWsse(), 1e-300);
  cf.relative_improvement = 1 - out.cvMse(c.units) / current.cvMse(c.units);
  // The significance of what the step selects on (the pooled MSE): per-cycle log ratios weigh a
  // quiet cycle like a loud one, and with about a dozen cycles their spread hid reductions of 20-30 %.
  cf.reduction = relativeReductionInterval(current.unit_sse, out.unit_sse, c.o->level);
  const int nu = cf.reduction.n;
  const double t = studentQuantile(1 - c.o->alpha / std::max(1, n_candidates), std::max(1, nu - 1));
  auto oneSidedLower = [t](const MeanInterval& m) { return m.mean - t * m.sd / std::sqrt(std::max(1, m.n)); };
  cf.one_sided_lower = oneSidedLower(cf.reduction);
  cf.whitened_one_sided_lower =
      oneSidedLower(relativeReductionInterval(current.unit_wsse, out.unit_wsse, c.o->level));
  std::vector<double> score(c.units.size(), 0.0);
  for (size_t u = 0; u < c.units.size(); ++u) {
    const Unit& un = c.units[u];
    const auto &y = c.trials[un.trial].measured_force, &pc = current.pred[un.trial], &pe = out.pred[un.trial];
    for (int i : un.frames) score[u] += (y[i] - pc[i]) * (pe[i] - pc[i]);
  }
  const MeanInterval sm = meanInterval(score, c.o->level);
  cf.score_t = sm.n >= 2 && sm.sd > 0 ? sm.mean / (sm.sd / std::sqrt(sm.n)) : 0;
  cf.score_critical = studentQuantile(1 - c.o->alpha / std::max(1, n_screened), std::max(1, sm.n - 1));
  const double nfr = std::max(2.0, current.fit.effective_frames);
  int ke = 0;
  std::vector<int> ecols;
  for (int j = first; j < out.law.getNumParameters(); ++j)
    if (out.fit.parameters[j].status == identify::ParameterStatus::Identified) ++ke, ecols.push_back(j);
  const double ratio = std::log(std::max(out.fit.solver.objective, 1e-300) / std::max(current.fit.solver.objective, 1e-300));
  cf.d_aic = nfr * ratio + 2 * ke;
  cf.d_bic = nfr * ratio + ke * std::log(nfr);
  const int kf = static_cast<int>(out.fold_params.size());
  for (int j = first; j < out.law.getNumParameters(); ++j) {
    const identify::ParameterResult& pr = out.fit.parameters[j];
    if (pr.status == identify::ParameterStatus::FixedBySetup) continue;
    EffectParameter ep;
    ep.name = pr.name;
    ep.unit = pr.unit;
    ep.value = pr.value;
    ep.ci = pr.ci_asymptotic;
    ep.at_bound = pr.at_bound;
    ep.identified = pr.status == identify::ParameterStatus::Identified;
    if (!ep.identified) cf.notes.push_back("'" + pr.name + "' is not identifiable from these data: held at " + fmt(pr.value));
    std::vector<double> v;
    for (const auto& fp : out.fold_params) v.push_back(fp[j]);
    const MeanInterval mi = meanInterval(v, c.o->level);
    ep.fold_mean = mi.mean;
    ep.fold_sd = mi.sd;
    int same = 0;
    for (double x : v) same += (x >= 0) == (pr.value >= 0);
    ep.sign_consistency = v.empty() ? 1.0 : double(same) / v.size();
    if (kf >= 2) {
      double ss = 0;
      for (double x : v) ss += (x - mi.mean) * (x - mi.mean);
      const double se = std::sqrt((kf - 1.0) / kf * ss);
      const double tq = studentQuantile(0.5 + c.o->level / 2, kf - 1);
      ep.ci_jackknife = {pr.value - tq * se, pr.value + tq * se};
    }
    cf.parameters.push_back(ep);
  }
  return cf;
}

// ---- where-analysis helpers

// Bin means of per-frame values over the normalised cycle, per unit: [unit][bin] (NaN: no frame).
std::vector<std::vector<double>> unitBins(const Context& c, const std::vector<std::vector<double>>& v, int bins) {
  std::vector<std::vector<double>> out(c.units.size(), std::vector<double>(bins, kNaN));
  for (size_t u = 0; u < c.units.size(); ++u) {
    std::vector<double> sum(bins, 0.0);
    std::vector<int> cnt(bins, 0);
    const GapTrial& g = (*c.gap_trials)[c.units[u].trial];
    for (int i : c.units[u].frames) {
      if (!std::isfinite(v[c.units[u].trial][i]) || !std::isfinite(g.cycle_phase[i])) continue;
      const int b = std::min(bins - 1, static_cast<int>(g.cycle_phase[i] * bins));
      sum[b] += v[c.units[u].trial][i];
      ++cnt[b];
    }
    for (int b = 0; b < bins; ++b)
      if (cnt[b] > 0) out[u][b] = sum[b] / cnt[b];
  }
  return out;
}

std::vector<std::string> activitiesOf(const Context& c) {
  std::vector<std::string> a;
  for (const auto& u : c.units)
    if (std::find(a.begin(), a.end(), u.activity) == a.end()) a.push_back(u.activity);
  return a;
}

std::vector<BandCurve> makeBands(const Context& c, const std::vector<std::vector<double>>& gap,
                                 const std::vector<std::vector<double>>& pred, int bins) {
  std::vector<std::vector<double>> meas(c.trials.size());
  for (size_t t = 0; t < c.trials.size(); ++t) meas[t] = c.trials[t].measured_force;
  const auto gb = unitBins(c, gap, bins), mb = unitBins(c, meas, bins), pb = unitBins(c, pred, bins);
  std::vector<BandCurve> out;
  for (const auto& act : activitiesOf(c)) {
    BandCurve bc;
    bc.activity = act;
    for (int b = 0; b < bins; ++b) {
      std::vector<double> g, m, p;
      for (size_t u = 0; u < c.units.size(); ++u) {
        if (c.units[u].activity != act || !std::isfinite(gb[u][b])) continue;
        g.push_back(gb[u][b]);
        m.push_back(mb[u][b]);
        p.push_back(pb[u][b]);
      }
      const MeanInterval gi = meanInterval(g), mi = meanInterval(m), pi = meanInterval(p);
      bc.phase.push_back((b + 0.5) / bins);
      bc.mean_gap.push_back(gi.mean);
      bc.sd_gap.push_back(gi.sd);
      bc.mean_measured.push_back(mi.mean);
      bc.sd_measured.push_back(mi.sd);
      bc.mean_predicted.push_back(pi.mean);
      bc.n_cycles.push_back(static_cast<int>(g.size()));
    }
    out.push_back(bc);
  }
  return out;
}

std::vector<SignalCorrelation> correlate(const Context& c, const std::vector<std::vector<double>>& gap,
                                         const std::vector<std::vector<double>>& pred) {
  // Candidate signals; each is correlated over the trials that have it (GRF and EMG need a C3D).
  std::set<std::string> names;
  for (const auto& t : c.trials)
    for (const auto& [k, v] : t.channels)
      if (k == "knee_flexion" || k == "knee_flexion_rate" || k == "S" || k == "dS_dt" ||
          startsWith(k, "GRF:vertical") || startsWith(k, "EMG:"))
        names.insert(k);
  std::vector<std::pair<std::string, std::vector<std::vector<double>>>> signals;
  for (const auto& nm : names) {
    std::vector<std::vector<double>> s(c.trials.size());
    for (size_t t = 0; t < c.trials.size(); ++t) {
      auto it = c.trials[t].channels.find(nm);
      s[t] = it != c.trials[t].channels.end() ? it->second
                                              : std::vector<double>(c.trials[t].time.size(), kNaN);
    }
    signals.emplace_back(nm, s);
  }
  signals.emplace_back("predicted force", pred);
  std::vector<std::vector<double>> dpred(c.trials.size());
  for (size_t t = 0; t < c.trials.size(); ++t) {
    std::vector<double> p = pred[t];
    for (double& x : p)
      if (!std::isfinite(x)) x = 0;
    dpred[t] = derivative(c.trials[t].time, p);
  }
  signals.emplace_back("rate of the predicted force", dpred);
  std::vector<SignalCorrelation> out;
  const double rg = pooledLag1(c, gap);
  for (const auto& [nm, s] : signals) {
    std::vector<double> x, y;
    for (const auto& u : c.units)
      for (int i : u.frames)
        if (std::isfinite(s[u.trial][i]) && std::isfinite(gap[u.trial][i])) {
          x.push_back(gap[u.trial][i]);
          y.push_back(s[u.trial][i]);
        }
    SignalCorrelation sc;
    sc.signal = nm;
    sc.n = static_cast<int>(x.size());
    sc.r = pearson(x, y);
    sc.n_eff = effectiveSampleSize(sc.n, rg, pooledLag1(c, s));
    const auto ci = correlationInterval(sc.r, sc.n_eff, c.o->level);
    sc.lower = ci.first;
    sc.upper = ci.second;
    out.push_back(sc);
  }
  std::sort(out.begin(), out.end(), [](const SignalCorrelation& a, const SignalCorrelation& b) {
    const double x = std::isfinite(a.r) ? std::abs(a.r) : -1, y = std::isfinite(b.r) ? std::abs(b.r) : -1;
    return x > y;
  });
  return out;
}

// The shift of the prediction that best matches the measured force: measured(t) ~ pred(t - lag).
std::pair<double, double> bestLag(const Context& c, const std::vector<std::vector<double>>& pred, double max_lag) {
  const auto& t0 = c.trials.front().time;
  const double dt = t0.size() > 1 ? (t0.back() - t0.front()) / (t0.size() - 1) : 1.0 / 120;
  const int steps = static_cast<int>(std::round(max_lag / dt));
  double best = 0, best_r = -2;
  for (int k = -steps; k <= steps; ++k) {
    const double lag = k * dt;
    std::vector<double> x, y;
    for (size_t t = 0; t < c.trials.size(); ++t) {
      std::vector<double> at(c.trials[t].time.size());
      for (size_t i = 0; i < at.size(); ++i) at[i] = c.trials[t].time[i] - lag;
      std::vector<double> p = pred[t];
      // Held-out predictions exist only on unit frames: interpolate those.
      std::vector<double> tt, pp;
      for (size_t i = 0; i < p.size(); ++i)
        if (std::isfinite(p[i])) tt.push_back(c.trials[t].time[i]), pp.push_back(p[i]);
      if (tt.size() < 2) continue;
      const std::vector<double> shifted = interpolate(tt, pp, at);
      for (const auto& u : c.units) {
        if (u.trial != static_cast<int>(t)) continue;
        for (int i : u.frames)
          if (std::isfinite(shifted[i])) x.push_back(c.trials[t].measured_force[i]), y.push_back(shifted[i]);
      }
    }
    const double r = pearson(x, y);
    if (std::isfinite(r) && r > best_r) best_r = r, best = lag;
  }
  return {best, best_r};
}

ReferencePredictors references(const Context& c, const Model& base) {
  ReferencePredictors rp;
  const int bins = c.o->bins;
  std::vector<std::vector<double>> meas(c.trials.size());
  for (size_t t = 0; t < c.trials.size(); ++t) meas[t] = c.trials[t].measured_force;
  const auto mb = unitBins(c, meas, bins);
  double sse_mc = 0, sse_base_mc = 0, sse_iso = 0, sse_base = 0;
  int n_mc = 0, n_all = 0;
  for (const auto& fold : c.folds) {
    std::vector<int> train;
    for (size_t u = 0; u < c.units.size(); ++u)
      if (std::find(fold.begin(), fold.end(), static_cast<int>(u)) == fold.end()) train.push_back(static_cast<int>(u));
    std::vector<double> xs, ys;
    for (int u : train)
      for (int i : c.units[u].frames) {
        xs.push_back(c.trials[c.units[u].trial].channels.at("S")[i]);
        ys.push_back(meas[c.units[u].trial][i]);
      }
    const IsotonicFit iso = fitIsotonic(xs, ys);
    for (int u : fold) {
      const Unit& un = c.units[u];
      // Training-mean curve of the activity: bin means over training cycles, gaps filled linearly.
      std::vector<double> curve(bins, kNaN);
      for (int b = 0; b < bins; ++b) {
        double s = 0;
        int k = 0;
        for (int v : train)
          if (c.units[v].activity == un.activity && std::isfinite(mb[v][b])) s += mb[v][b], ++k;
        if (k > 0) curve[b] = s / k;
      }
      std::vector<double> bx, by;
      for (int b = 0; b < bins; ++b)
        if (std::isfinite(curve[b])) bx.push_back((b + 0.5) / bins), by.push_back(curve[b]);
      const GapTrial& g = (*c.gap_trials)[un.trial];
      for (int i : un.frames) {
        const double m = meas[un.trial][i];
        const double pb = base.pred[un.trial][i];
        sse_base += (m - pb) * (m - pb);
        const double pi = iso.evaluate(c.trials[un.trial].channels.at("S")[i]);
        sse_iso += (m - pi) * (m - pi);
        ++n_all;
        if (bx.size() >= 2 && std::isfinite(g.cycle_phase[i])) {
          const double pm = interpolate(bx, by, {g.cycle_phase[i]}, 1.0)[0];
          sse_mc += (m - pm) * (m - pm);
          sse_base_mc += (m - pb) * (m - pb);
          ++n_mc;
        }
      }
    }
  }
  rp.baseline_rmse = std::sqrt(sse_base / std::max(1, n_all));
  rp.isotonic_rmse = std::sqrt(sse_iso / std::max(1, n_all));
  rp.mean_curve_frames = n_mc;
  rp.mean_curve_rmse = n_mc > 0 ? std::sqrt(sse_mc / n_mc) : kNaN;
  rp.baseline_rmse_on_mean_curve_frames = n_mc > 0 ? std::sqrt(sse_base_mc / n_mc) : kNaN;
  std::vector<double> xs, ys;
  for (const auto& u : c.units)
    for (int i : u.frames) xs.push_back(c.trials[u.trial].channels.at("S")[i]), ys.push_back(meas[u.trial][i]);
  rp.isotonic_in_sample_rmse = std::sqrt(fitIsotonic(xs, ys).sse / std::max<size_t>(1, xs.size()));
  return rp;
}

std::vector<PhaseGap> phaseGaps(const Context& c, const std::vector<std::vector<double>>& gap,
                                const std::vector<BandCurve>& bands) {
  std::vector<PhaseGap> out;
  for (const auto& bc : bands) {
    const ActivityDefinition act = getActivityDefinition(bc.activity);
    for (const auto& ph : act.phases) {
      PhaseGap pg;
      pg.activity = bc.activity;
      pg.phase = ph.name;
      double ss = 0, s = 0;
      std::set<int> cyc;
      for (size_t u = 0; u < c.units.size(); ++u) {
        if (c.units[u].activity != bc.activity) continue;
        const GapTrial& g = (*c.gap_trials)[c.units[u].trial];
        for (int i : c.units[u].frames) {
          if (!(g.cycle_phase[i] >= ph.begin && g.cycle_phase[i] < ph.end)) continue;
          const double r = gap[c.units[u].trial][i];
          ss += r * r;
          s += r;
          ++pg.n_frames;
          cyc.insert(static_cast<int>(u));
        }
      }
      pg.n_cycles = static_cast<int>(cyc.size());
      pg.rmse = pg.n_frames ? std::sqrt(ss / pg.n_frames) : kNaN;
      pg.rmse_bw = c.body_weight > 0 ? pg.rmse / c.body_weight : kNaN;
      pg.bias = pg.n_frames ? s / pg.n_frames : kNaN;
      double sys = 0, band = 0;
      int nb = 0, nband = 0;
      for (size_t b = 0; b < bc.phase.size(); ++b) {
        if (bc.phase[b] < ph.begin || bc.phase[b] >= ph.end || !std::isfinite(bc.mean_gap[b])) continue;
        sys += bc.mean_gap[b] * bc.mean_gap[b];
        ++nb;
        if (std::isfinite(bc.sd_measured[b])) band += bc.sd_measured[b] * bc.sd_measured[b], ++nband;
      }
      pg.systematic = nb ? std::sqrt(sys / nb) : kNaN;
      pg.band = nband ? std::sqrt(band / nband) : kNaN;
      if (pg.n_frames == 0) pg.verdict = "no frames";
      else if (!std::isfinite(pg.band)) pg.verdict = "no repeatability band (one cycle)";
      else pg.verdict = pg.systematic > pg.band ? "gap" : "within noise";
      out.push_back(pg);
    }
  }
  return out;
}

StructureTest structureTest(const Context& c, const Model& m) {
  StructureTest st;
  const int bins = c.o->structure_bins;
  // In-sample residuals: with k-fold cross-validation the cycles of a fold share that fold's
  // parameter error, which would break the exchangeability of signs between cycles; the fit on all
  // cycles only removes structure along the model's own directions (conservative).
  std::vector<std::vector<double>> gap(c.trials.size()), resid(c.trials.size());
  for (size_t t = 0; t < c.trials.size(); ++t) {
    gap[t].assign(c.trials[t].time.size(), kNaN);
    resid[t].assign(c.trials[t].time.size(), kNaN);
    for (size_t i = 0; i < gap[t].size(); ++i) {
      gap[t][i] = c.trials[t].measured_force[i] - m.pred[t][i];
      resid[t][i] = c.trials[t].measured_force[i] - m.fitted[t][i];
    }
  }
  const auto gb = unitBins(c, resid, bins);
  const auto acts = activitiesOf(c);
  auto statistic = [&](const std::vector<int>& sign) {
    double tstat = 0;
    for (const auto& act : acts)
      for (int b = 0; b < bins; ++b) {
        double s = 0;
        int k = 0;
        for (size_t u = 0; u < c.units.size(); ++u)
          if (c.units[u].activity == act && std::isfinite(gb[u][b])) s += sign[u] * gb[u][b], ++k;
        if (k > 0) tstat += s * s / k;
      }
    return tstat;
  };
  st.cycles = static_cast<int>(c.units.size());
  std::vector<int> ones(c.units.size(), 1);
  st.statistic = statistic(ones);
  if (st.cycles < 6) {
    st.p_value = kNaN;
    st.note = "too few cycles (" + std::to_string(st.cycles) + ") for the sign-flip test";
  } else {
    std::mt19937_64 rng(c.o->seed);
    int ge = 0;
    std::vector<int> sign(c.units.size());
    for (int p = 0; p < c.o->permutations; ++p) {
      for (auto& s : sign) s = (rng() & 1) ? 1 : -1;
      if (statistic(sign) >= st.statistic) ++ge;
    }
    st.p_value = (1.0 + ge) / (1.0 + c.o->permutations);
  }
  st.remaining = makeBands(c, gap, m.pred, c.o->bins);
  double sys = 0, band = 0;
  int nb = 0;
  for (const auto& b : st.remaining)
    for (size_t k = 0; k < b.phase.size(); ++k)
      if (b.n_cycles[k] >= 2 && std::isfinite(b.mean_gap[k]) && std::isfinite(b.sd_measured[k])) {
        sys += b.mean_gap[k] * b.mean_gap[k];
        band += b.sd_measured[k] * b.sd_measured[k];
        ++nb;
      }
  st.systematic_gap = nb ? std::sqrt(sys / nb) : kNaN;
  st.repeatability_band = nb ? std::sqrt(band / nb) : kNaN;
  st.exceeds_band = nb > 0 && st.systematic_gap > st.repeatability_band;
  st.significant = (std::isfinite(st.p_value) && st.p_value < c.o->structure_alpha) || st.exceeds_band;
  st.correlations = correlate(c, gap, m.pred);
  return st;
}

double bootstrapRatio(const std::vector<double>& a, const std::vector<double>& b, std::mt19937_64& rng, int samples,
                      double q) {
  std::vector<double> v;
  const size_t n = a.size();
  for (int s = 0; s < samples; ++s) {
    double sa = 0, sb = 0;
    for (size_t k = 0; k < n; ++k) {
      const size_t u = rng() % n;
      sa += a[u];
      sb += b[u];
    }
    if (sa > 0) v.push_back(1 - std::sqrt(sb / sa));
  }
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double pos = q * (v.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  return i + 1 < v.size() ? v[i] + (pos - i) * (v[i + 1] - v[i]) : v[i];
}

ShrinkageRow shrinkRow(const Context& c, const std::string& scheme, const std::string& scope, const std::string& train,
                       const std::vector<double>& sse_base, const std::vector<double>& sse_final, int frames,
                       std::mt19937_64& rng) {
  ShrinkageRow r;
  r.scheme = scheme;
  r.scope = scope;
  r.train = train;
  r.n_frames = frames;
  r.n_cycles = static_cast<int>(sse_base.size());
  const double sb = std::accumulate(sse_base.begin(), sse_base.end(), 0.0),
               sf = std::accumulate(sse_final.begin(), sse_final.end(), 0.0);
  r.rmse_base = std::sqrt(sb / std::max(1, frames));
  r.rmse_final = std::sqrt(sf / std::max(1, frames));
  r.rmse_base_bw = c.body_weight > 0 ? r.rmse_base / c.body_weight : kNaN;
  r.rmse_final_bw = c.body_weight > 0 ? r.rmse_final / c.body_weight : kNaN;
  r.reduction = r.rmse_base > 0 ? 1 - r.rmse_final / r.rmse_base : kNaN;
  if (sse_base.size() >= 2) {
    const double a = (1 - c.o->level) / 2;
    r.ci = {bootstrapRatio(sse_base, sse_final, rng, c.o->bootstrap, a),
            bootstrapRatio(sse_base, sse_final, rng, c.o->bootstrap, 1 - a)};
  }
  return r;
}


TargetDiagnosis diagnoseTarget(Context& c, const std::vector<Effect>& catalogue, const std::string& target) {
  const DiagnosisOptions& o = *c.o;
  TargetDiagnosis d;
  d.target = target;

  // ---- baseline: the user's identification on all cycles, then cross-validated
  Model base(*c.base);
  {
    identify::FitOptions fo = o.fit;
    fo.phases.clear();
    d.baseline = identify::fit(base.law, restrict(c, allUnits(c)), fo);
  }
  base.params = d.baseline.getValues();
  for (const auto& p : d.baseline.parameters)
    if (p.status == identify::ParameterStatus::Identified) base.free.push_back(p.name);
  fitAndValidate(c, base);
  base.fit = d.baseline;  // keep the user's report (with its intervals)
  d.baseline_rmse_heldout = std::sqrt(base.cvMse(c.units));
  {
    std::vector<std::vector<double>> res(c.trials.size());
    for (size_t t = 0; t < c.trials.size(); ++t) {
      res[t].resize(c.trials[t].time.size());
      for (size_t i = 0; i < res[t].size(); ++i) res[t][i] = c.trials[t].measured_force[i] - base.fitted[t][i];
    }
    c.ar = fitPrewhitening(c, cycleDeviations(c, res, std::max(10, o.bins)), o.prewhiten_order);
    d.prewhitening = c.ar;
    updateWhitened(c, base);
  }

  std::vector<std::vector<double>> gap(c.trials.size());
  for (size_t t = 0; t < c.trials.size(); ++t) {
    gap[t].assign(c.trials[t].time.size(), kNaN);
    for (size_t i = 0; i < gap[t].size(); ++i) gap[t][i] = c.trials[t].measured_force[i] - base.pred[t][i];
  }

  // ---- where
  if (o.where) {
    d.bands = makeBands(c, gap, base.pred, o.bins);
    d.phases = phaseGaps(c, gap, d.bands);
    d.correlations = correlate(c, gap, base.pred);
    std::tie(d.best_lag, d.best_lag_r) = bestLag(c, base.pred, o.max_lag);
    d.reference = references(c, base);
  }

  // ---- which: forward selection
  for (const auto& e : catalogue) {
    std::string why;
    if (!testable(c, e, why)) d.untestable.push_back(e.getName() + ": " + why);
  }
  Model current = base;
  std::vector<std::string> chosen;
  std::map<std::string, std::vector<double>> sigs;
  for (int step = 1; step <= o.max_effects; ++step) {
    std::vector<Screening> scr;
    std::map<std::string, VisibleBasis> visible;
    for (const auto& e : catalogue)
      if (std::find(chosen.begin(), chosen.end(), e.getName()) == chosen.end())
        scr.push_back(screen(c, current, e, &visible[e.getName()]));
    std::stable_sort(scr.begin(), scr.end(), [](const Screening& a, const Screening& b) {
      if (a.testable != b.testable) return a.testable;
      return a.z > b.z;
    });
    d.screening.push_back(scr);
    std::vector<const Effect*> top;
    for (const auto& s : scr) {
      if (!s.testable || static_cast<int>(top.size()) >= o.screen_top) continue;
      for (const auto& e : catalogue)
        if (e.getName() == s.effect) top.push_back(&e);
    }
    if (top.empty()) break;
    const int n_screened =
        static_cast<int>(std::count_if(scr.begin(), scr.end(), [](const Screening& x) { return x.testable; }));
    std::vector<CandidateFit> fits;
    std::vector<Model> models(top.size(), Model(*c.base));
    for (size_t k = 0; k < top.size(); ++k) {
      fits.push_back(evaluate(c, current, *top[k], step, static_cast<int>(top.size()), n_screened, models[k]));
      sigs[top[k]->getName() + "@" + std::to_string(step)] = signature(c, models[k], current);
    }
    int best = -1;
    for (size_t k = 0; k < fits.size(); ++k)
      if (fits[k].converged && (best < 0 || fits[k].relative_improvement > fits[best].relative_improvement))
        best = static_cast<int>(k);
    // The step needs a gate: a candidate that would be accepted on its own, i.e. significant by its
    // withheld improvement or its cross-fitted score (CandidateFit::isSignificant) and removing at least
    // min_relative_improvement (a steady but negligible improvement does not make a step). Which effect the
    // step adds is then chosen among the significant candidates that remove at least
    // min_relative_improvement and those whose withheld error is not significantly worse than the gate's
    // while their prewhitened error is significantly lower (two-sided intervals of the relative reduction
    // of the pooled MSE over cycles), by the prewhitened errors: they weigh the fast differences between
    // rivals, which the smooth gap does not hide, where raw squared errors are dominated by the slow ones,
    // which it does. A larger effect whose reduction varies more from cycle to cycle (the proximity
    // threshold acts most on a few loud cycles) otherwise lost to a smaller, steadier rival.
    int significant = -1;  // the gate
    for (size_t k = 0; k < fits.size(); ++k)
      if (fits[k].converged && fits[k].isSignificant() && fits[k].relative_improvement >= o.min_relative_improvement &&
          (significant < 0 || fits[k].whitened_improvement > fits[significant].whitened_improvement))
        significant = static_cast<int>(k);
    std::vector<bool> eligible(fits.size(), false);
    std::vector<std::string> left_out(fits.size());  // why a candidate not significant on its own was not eligible
    bool by_whitened = false;
    const int best_raw = best;
    if (significant >= 0) {
      best = significant;
      const std::string& g = fits[significant].effect;
      for (size_t k = 0; k < fits.size(); ++k) {
        if (!fits[k].converged) continue;
        if (fits[k].relative_improvement < o.min_relative_improvement) {
          left_out[k] = "it removes under " + fmt(100 * o.min_relative_improvement, 2) + " % of the withheld error";
          continue;
        }
        // One not significant on its own must be comparable in raw error and significantly better than
        // the gate in prewhitened error: a close call between them stays with the significant one.
        if (fits[k].isSignificant())
          eligible[k] = true;
        else if (relativeReductionInterval(models[significant].unit_sse, models[k].unit_sse, o.level).upper < 0)
          left_out[k] = "its withheld error is significantly worse than " + g + "'s";
        else if (!(relativeReductionInterval(models[significant].unit_wsse, models[k].unit_wsse, o.level).lower > 0))
          left_out[k] = "its prewhitened withheld error is not significantly lower than " + g + "'s";
        else
          eligible[k] = true;
        if (eligible[k] && fits[k].whitened_improvement > fits[best].whitened_improvement) best = static_cast<int>(k);
      }
      by_whitened = best != best_raw;
    } else {
      // No gate: the step fails; the decision names the significant candidate (if any) it would have been.
      for (size_t k = 0; k < fits.size(); ++k)
        if (best >= 0 && fits[k].converged && fits[k].isSignificant() &&
            (!fits[best].isSignificant() || fits[k].whitened_improvement > fits[best].whitened_improvement)) {
          by_whitened = by_whitened || static_cast<int>(k) != best;
          best = static_cast<int>(k);
        }
      for (size_t k = 0; k < fits.size(); ++k) eligible[k] = fits[k].converged && fits[k].isSignificant();
    }
    auto separatedBy = [&](const std::string& a, const std::string& b, const std::string& evidence) {
      std::string sa, sb;
      for (const auto& e : catalogue) {
        if (e.getName() == a) sa = e.getSeparatedBy();
        if (e.getName() == b) sb = e.getSeparatedBy();
      }
      return evidence + "; trials where they differ would separate them: " + a + ": " + sa + "; " + b + ": " + sb;
    };
    // Confusable pairs: both significant, withheld errors alike, force changes nearly proportional.
    for (size_t a = 0; a < fits.size(); ++a)
      for (size_t b = a + 1; b < fits.size(); ++b) {
        if (!(fits[a].isSignificant() && fits[b].isSignificant())) continue;
        const MeanInterval diff = meanInterval(unitLogRatios(models[b].unit_sse, models[a].unit_sse), o.level);
        const double r = pearson(sigs[fits[a].effect + "@" + std::to_string(step)],
                                 sigs[fits[b].effect + "@" + std::to_string(step)]);
        if (diff.lower <= 0 && diff.upper >= 0 && std::abs(r) >= 0.8) {
          ConfusablePair cp;
          cp.a = fits[a].effect;
          cp.b = fits[b].effect;
          cp.signature_r = r;
          cp.difference = diff;
          cp.separated_by = separatedBy(cp.a, cp.b, "their force changes correlate at r = " + fmt(r, 2) + " on these trials");
          d.confusable.push_back(cp);
        }
      }
    // Both significance tests of a candidate, in words.
    auto tests = [&](const CandidateFit& f) {
      return "MSE reduction " + fmt(100 * f.relative_improvement, 3) + " %, one-sided lower bound " +
             fmt(100 * f.one_sided_lower, 3) + " % at level " + fmt(1 - o.alpha / fits.size(), 3) +
             "; cross-fitted score t = " + fmt(f.score_t, 3) + " against " + fmt(f.score_critical, 3);
    };
    bool accept = false;
    if (best >= 0) {
      CandidateFit& f = fits[best];
      std::vector<std::string> why;
      if (!(f.isSignificant() || significant >= 0))
        why.push_back("neither its withheld improvement nor its cross-fitted score is significant (" + tests(f) + ")");
      if (f.relative_improvement < o.min_relative_improvement)
        why.push_back("it removes only " + fmt(100 * f.relative_improvement, 2) + " % of the withheld mean square error");
      if (!(f.d_bic < 0)) why.push_back("BIC does not favour it (dBIC " + fmt(f.d_bic, 3) + ")");
      for (const auto& p : f.parameters)
        if (!p.identified) why.push_back("its parameter '" + p.name + "' is not identifiable");
      accept = why.empty();
      f.accepted = accept;
      const std::string whitened = "best prewhitened withheld improvement (" + fmt(100 * f.whitened_improvement, 3) +
                                   "%; MSE " + fmt(100 * f.relative_improvement, 3) + "%)";
      std::string how;
      if (f.isSignificant() && !by_whitened)
        how = "best withheld improvement (" + fmt(100 * f.relative_improvement, 3) + "% of the MSE), significant (" +
              tests(f) + ")";
      else if (f.isSignificant() || significant < 0)
        how = whitened + " among the significant ones (" + tests(f) + ")";
      else
        how = whitened + ", not significant on its own (" + tests(f) +
              ") but significantly lower in prewhitened error than " + fits[significant].effect +
              ", which is significant, and not significantly worse in raw error";
      f.decision = accept ? "selected: " + how + ", dBIC " + fmt(f.d_bic, 3) : "not selected: " + join(why, "; ");
    }
    for (size_t k = 0; k < fits.size(); ++k)
      if (static_cast<int>(k) != best)
        fits[k].decision =
            by_whitened && !eligible[k]
                ? (fits[k].isSignificant() ? "not eligible at step " + std::to_string(step) + ": " + left_out[k]
                                           : "not significant at step " + std::to_string(step) + " (" + tests(fits[k]) +
                                                 ")" + (left_out[k].empty() ? "" : ", and " + left_out[k]))
                : std::string("not the best ") + (by_whitened ? "prewhitened " : "") + "withheld improvement at step " +
                      std::to_string(step);
    if (accept) {
      // Rivals of the selected effect: effects whose force change, as far as the baseline leaves it
      // visible, nearly spans the same direction on these trials (canonical correlation of the
      // visible bases >= o.confusable_correlation). Each is fitted fully (unless it was) and
      // reported confusable when the withheld errors of the two cannot be told apart.
      const std::string sel = fits[best].effect;
      const Model& sel_model = models[best];
      for (const auto& sc : scr) {
        if (!sc.testable || sc.effect == sel) continue;
        const bool listed = std::any_of(d.confusable.begin(), d.confusable.end(), [&](const ConfusablePair& p) {
          return (p.a == sel && p.b == sc.effect) || (p.b == sel && p.a == sc.effect);
        });
        if (listed) continue;
        const double rho = canonicalCorrelation(visible[sel], visible[sc.effect]);
        if (rho < o.confusable_correlation) continue;
        const Model* rival = nullptr;
        double rival_reduction = 0;
        Model extra(*c.base);
        for (size_t k = 0; k < fits.size(); ++k)
          if (fits[k].effect == sc.effect) {
            rival = &models[k];
            rival_reduction = fits[k].relative_improvement;
          }
        if (!rival) {
          const Effect* e = nullptr;
          for (const auto& x : catalogue)
            if (x.getName() == sc.effect) e = &x;
          const CandidateFit rf = evaluate(c, current, *e, step, static_cast<int>(top.size()), n_screened, extra);
          if (!rf.converged) continue;
          rival = &extra;
          rival_reduction = rf.relative_improvement;
        }
        // A rival must explain the gap itself, as much as a selected effect must: one that its bounds
        // hold at the baseline (adhesion cannot pull) reproduces nothing, however alike its direction.
        if (!(rival_reduction >= o.min_relative_improvement)) continue;
        const MeanInterval diff = meanInterval(unitLogRatios(rival->unit_sse, sel_model.unit_sse), o.level);
        if (!(diff.lower <= 0 && diff.upper >= 0)) continue;
        ConfusablePair cp;
        cp.a = sel;
        cp.b = sc.effect;
        cp.signature_r = rho;
        cp.difference = diff;
        cp.separated_by = separatedBy(
            cp.a, cp.b,
            "what the baseline leaves visible of their force changes correlates at " + fmt(rho, 3) +
                " (canonical correlation at step " + std::to_string(step) +
                ") and their withheld errors do not differ (per-cycle log SSE ratio " + fmt(diff.mean, 3) + " [" +
                fmt(diff.lower, 3) + ", " + fmt(diff.upper, 3) + "])");
        d.confusable.push_back(cp);
      }
    }
    d.candidates.insert(d.candidates.end(), fits.begin(), fits.end());
    if (!accept) break;
    chosen.push_back(fits[best].effect);
    current = std::move(models[best]);
  }
  d.selected = chosen;
  d.undecided = findUndecided(d.candidates, static_cast<int>(chosen.size()) + 1, o.min_relative_improvement);
  d.final_law = current.law.getName();
  d.final_fit = current.fit;

  // ---- remaining structure and verdict
  d.structure = structureTest(c, current);
  const std::string sel = join(chosen, " + ");
  const std::string pstr = std::isfinite(d.structure.p_value) ? fmt(d.structure.p_value, 3) : "n/a";
  const std::string evidence =
      "sign-flip p = " + pstr + "; systematic gap " + fmt(d.structure.systematic_gap, 3) + " N against a repeatability band of " +
      fmt(d.structure.repeatability_band, 3) + " N";
  std::string remaining_hint;
  if (!d.structure.correlations.empty() && std::isfinite(d.structure.correlations[0].r))
    remaining_hint = " The remaining gap correlates most with " + d.structure.correlations[0].signal + " (r = " +
                     fmt(d.structure.correlations[0].r, 2) + ").";
  if (d.structure.significant) {
    d.verdict = "none of the candidates";
    d.verdict_text = (chosen.empty()
                          ? "None of the candidates explains the gap: no effect improved the withheld error enough, "
                            "and systematic structure remains over the cycle ("
                          : "None of the candidates explains the whole gap: " + sel +
                                " improve(s) the withheld error, but systematic structure remains over the cycle (") +
                     evidence + ")." + remaining_hint;
  } else if (chosen.empty()) {
    d.verdict = "baseline";
    d.verdict_text = "The baseline law is adequate at this noise level: no effect improves the withheld error "
                     "significantly, and no systematic structure remains (" + evidence + ").";
  } else {
    d.verdict = sel;
    d.verdict_text = "The gap is explained by " + sel + ": withheld error " + fmt(d.baseline_rmse_heldout, 4) +
                     " N -> " + fmt(std::sqrt(current.cvMse(c.units)), 4) + " N, and no systematic structure remains (" +
                     evidence + ").";
  }
  if (!d.undecided.effect.empty()) {
    const UndecidedCandidate& u = d.undecided;
    d.verdict_text +=
        " Undecided at step " + std::to_string(u.step) + ": " + u.effect + " removes " + fmt(100 * u.reduction, 3) +
        " % of the withheld error, but not significantly (one-sided lower bound " + fmt(100 * u.lower, 3) +
        " %; prewhitened " + fmt(100 * u.whitened, 3) + " %, bound " + fmt(100 * u.whitened_lower, 3) +
        " %). If that reduction and its spread over cycles held, about " + std::to_string(u.cycles_needed) +
        " cycles (instead of " + std::to_string(u.cycles) + ") would make it significant.";
  }
  if (!d.untestable.empty() && d.structure.significant)
    d.verdict_text += " Not testable on these inputs: " + join(d.untestable, "; ") + ".";
  if (!std::isfinite(d.structure.p_value)) d.verdict_text += " (The sign-flip test needs six cycles: " + d.structure.note + ".)";

  // ---- series for the plots
  for (size_t t = 0; t < c.trials.size(); ++t) {
    TrialSeries s;
    s.trial = c.trials[t].name;
    s.activity = (*c.gap_trials)[t].activity;
    s.time = c.trials[t].time;
    s.phase = (*c.gap_trials)[t].cycle_phase;
    s.cycle = (*c.gap_trials)[t].cycle_index;
    s.measured = c.trials[t].measured_force;
    s.baseline = base.pred[t];
    s.final_model = current.pred[t];
    d.series.push_back(std::move(s));
  }

  // ---- shrinkage
  std::mt19937_64 rng(o.seed);
  int frames = 0;
  for (const auto& u : c.units) frames += static_cast<int>(u.frames.size());
  d.shrinkage.push_back(shrinkRow(c, "leave one cycle out", "overall", "all other cycles", base.unit_sse,
                                  current.unit_sse, frames, rng));
  for (const auto& act : activitiesOf(c)) {
    for (const auto& ph : getActivityDefinition(act).phases) {
      std::vector<double> sb, sf;
      int n = 0;
      for (const auto& u : c.units) {
        if (u.activity != act) continue;
        const GapTrial& g = (*c.gap_trials)[u.trial];
        double a = 0, b = 0;
        bool any = false;
        for (int i : u.frames) {
          if (!(g.cycle_phase[i] >= ph.begin && g.cycle_phase[i] < ph.end)) continue;
          const double m = c.trials[u.trial].measured_force[i];
          a += (m - base.pred[u.trial][i]) * (m - base.pred[u.trial][i]);
          b += (m - current.pred[u.trial][i]) * (m - current.pred[u.trial][i]);
          ++n;
          any = true;
        }
        if (any) sb.push_back(a), sf.push_back(b);
      }
      if (n > 0)
        d.shrinkage.push_back(shrinkRow(c, "leave one cycle out", act + ": " + ph.name, "all other cycles", sb, sf, n, rng));
    }
  }
  const auto acts = activitiesOf(c);
  if (o.shrinkage && acts.size() >= 2) {
    for (const auto& act : acts) {
      std::vector<int> train, test;
      for (size_t u = 0; u < c.units.size(); ++u) (c.units[u].activity == act ? test : train).push_back(static_cast<int>(u));
      std::vector<std::string> others;
      for (const auto& a : acts)
        if (a != act) others.push_back(a);
      // Forces of both models, fitted on the other activities, on the left-out activity's trials.
      std::map<int, Eigen::VectorXd> forces[2];
      bool failed = false;
      for (int k = 0; k < 2 && !failed; ++k) {
        const Model& m = k == 0 ? base : current;
        identify::FitReport fr;
        try {
          fr = identify::fit(m.law, restrict(c, train), fitOptionsFor(c, m.law, m.free, m.params, /*warm=*/true));
        } catch (const InputError&) {
          failed = true;  // e.g. a parameter the other activities cannot determine
          break;
        }
        const Eigen::VectorXd p = fr.getValues();
        for (int u : test) {
          const int t = c.units[u].trial;
          if (forces[k].count(t)) continue;
          const identify::LawInputs in(m.law, c.trials[t].channels, c.trials[t].time, c.trials[t].name);
          m.law.calcForce(p, in, forces[k][t]);
        }
      }
      if (failed) continue;
      // Overall, then per phase of the left-out activity: per-cycle SSEs of both models.
      const auto phases = getActivityDefinition(act).phases;
      for (int ph = -1; ph < static_cast<int>(phases.size()); ++ph) {
        std::vector<double> sb, sf;
        int n = 0;
        for (int u : test) {
          const int t = c.units[u].trial;
          const GapTrial& g = (*c.gap_trials)[t];
          double a = 0, b = 0;
          bool any = false;
          for (int i : c.units[u].frames) {
            if (ph >= 0 && !(g.cycle_phase[i] >= phases[ph].begin && g.cycle_phase[i] < phases[ph].end)) continue;
            const double m = c.trials[t].measured_force[i];
            a += (m - forces[0][t][i]) * (m - forces[0][t][i]);
            b += (m - forces[1][t][i]) * (m - forces[1][t][i]);
            ++n;
            any = true;
          }
          if (any) sb.push_back(a), sf.push_back(b);
        }
        if (n == 0) continue;
        d.shrinkage.push_back(shrinkRow(c, "leave one activity out", ph < 0 ? act : act + ": " + phases[ph].name,
                                        join(others, " + "), sb, sf, n, rng));
      }
    }
  }
  return d;
}

}  // namespace

identify::Trial makeTargetTrial(const GapTrial& g, const std::string& target) {
  identify::Trial t = g.trial;
  if (target == "total") return t;
  const std::string side = target;  // "medial" or "lateral"
  t.measured_force = target == "medial" ? g.medial : g.lateral;
  t.name = g.trial.name;
  identify::ChannelMap& ch = t.channels;
  auto remap = [&](const std::string& dst, const std::string& src) {
    auto it = g.trial.channels.find(src);
    if (it == g.trial.channels.end()) ch.erase(dst);
    else ch[dst] = it->second;
  };
  remap("S", "S_" + side);
  remap("dS_dt", "dS_" + side + "_dt");
  remap("dmin", "dmin_" + side);
  remap("dS_dflexion", "dS_" + side + "_dflexion");
  remap("dS_dap", "dS_" + side + "_dap");
  for (const auto& [name, v] : g.trial.channels)
    if (startsWith(name, "S@")) remap(name, "S_" + side + name.substr(1));
  return t;
}

UndecidedCandidate findUndecided(const std::vector<CandidateFit>& candidates, int step, double min_improvement) {
  UndecidedCandidate u;
  const CandidateFit* best = nullptr;
  for (const auto& c : candidates) {
    if (c.step != step) continue;
    if (c.accepted) return u;  // the step added an effect: nothing was left undecided by it
    if (c.converged && c.relative_improvement >= min_improvement && !c.isSignificant() &&
        (!best || c.one_sided_lower > best->one_sided_lower))
      best = &c;
  }
  if (!best || !(best->reduction.mean > 0) || best->reduction.n < 2) return u;
  u.effect = best->effect;
  u.step = step;
  u.reduction = best->relative_improvement;
  u.lower = best->one_sided_lower;
  u.whitened = best->whitened_improvement;
  u.whitened_lower = best->whitened_one_sided_lower;
  u.cycles = best->reduction.n;
  const double ratio = (best->reduction.mean - best->one_sided_lower) / best->reduction.mean;
  u.cycles_needed = static_cast<int>(std::ceil(u.cycles * ratio * ratio));
  // The score's t grows with the square root of the cycles too.
  if (best->score_t > 0)
    u.cycles_needed = std::min(
        u.cycles_needed, static_cast<int>(std::ceil(u.cycles * std::pow(best->score_critical / best->score_t, 2))));
  return u;
}

std::string findTargetProblem(const std::string& target) {
  if (target == "total" || target == "medial" || target == "lateral") return "";
  return "expected total, medial or lateral, got '" + target + "'";
}

GapReport diagnose(const identify::ContactLaw& base, const std::vector<Effect>& catalogue,
                   const std::vector<GapTrial>& trials, const DiagnosisOptions& o) {
  const SourceLocation& where = o.fit.where;
  if (trials.empty()) throw InputError(where, "gap diagnosis: expected at least one trial, got none");
  if (o.cv_folds < 0 || o.cv_folds == 1)
    throw InputError(where, "gap diagnosis: cv_folds: expected 0 (leave one cycle out) or at least 2 folds, got " +
                                std::to_string(o.cv_folds));
  GapReport rep;
  rep.law = base.getName();
  rep.law_origin = base.getOrigin();
  rep.body_mass = o.fit.body_mass;
  for (const auto& e : catalogue) rep.effects.push_back(e.getName());
  for (const auto& g : trials) {
    rep.trials.push_back(g.trial.name);
    if (std::find(rep.activities.begin(), rep.activities.end(), g.activity) == rep.activities.end())
      rep.activities.push_back(g.activity);
    rep.interim_inputs = rep.interim_inputs || g.interim_inputs;
  }
  if (rep.interim_inputs)
    rep.notes.push_back("INTERIM INPUTS: some contact areas are the interim stand-in derived from the measured force "
                        "(files marked kneesim_interim=true); this is not a real-data result.");
  for (const auto& target : o.targets) {
    if (const std::string why = findTargetProblem(target); !why.empty())
      throw InputError(where, "gap diagnosis: target: " + why);
    Context c;
    c.base = &base;
    c.gap_trials = &trials;
    c.o = &o;
    c.body_weight = o.fit.body_mass * identify::kStandardGravity;
    for (size_t t = 0; t < trials.size(); ++t) {
      c.trials.push_back(makeTargetTrial(trials[t], target));
      const GapTrial& g = trials[t];
      for (size_t k = 0; k < g.cycles.size(); ++k) {
        Unit u;
        u.trial = static_cast<int>(t);
        u.activity = g.activity;
        for (int i = 0; i < g.getNumFrames(); ++i)
          if (g.cycle_index[i] == static_cast<int>(k)) {
            if (!std::isfinite(c.trials[t].measured_force[i]))
              throw InputError(where, "trial '" + g.trial.name + "': measured " + target + " force at t = " +
                                          fmt(g.trial.time[i], 6) + " s: expected a finite value, got NaN");
            u.frames.push_back(i);
          }
        if (!u.frames.empty()) c.units.push_back(std::move(u));
      }
    }
    // A partial cycle at a recording's edge much shorter than a whole one says little on its own:
    // merge it into its neighbour in the same trial (units are only the blocks of cross-validation
    // and of the sign-flip test; frames keep their own cycle position).
    {
      std::map<std::string, std::vector<double>> sizes;
      for (const auto& u : c.units) sizes[u.activity].push_back(static_cast<double>(u.frames.size()));
      std::map<std::string, double> median;
      for (auto& [a, v] : sizes) {
        std::sort(v.begin(), v.end());
        median[a] = v[v.size() / 2];
      }
      for (size_t k = 0; k < c.units.size();) {
        const bool tiny = c.units[k].frames.size() < 0.4 * median[c.units[k].activity];
        const bool next_same = k + 1 < c.units.size() && c.units[k + 1].trial == c.units[k].trial;
        const bool prev_same = k > 0 && c.units[k - 1].trial == c.units[k].trial;
        if (tiny && (next_same || prev_same)) {
          Unit& into = next_same ? c.units[k + 1] : c.units[k - 1];
          into.frames.insert(into.frames.end(), c.units[k].frames.begin(), c.units[k].frames.end());
          std::sort(into.frames.begin(), into.frames.end());
          c.units.erase(c.units.begin() + static_cast<long>(k));
          continue;
        }
        ++k;
      }
      for (auto& u : c.units) {
        u.begin = trials[u.trial].trial.time[u.frames.front()];
        u.end = trials[u.trial].trial.time[u.frames.back()];
      }
    }
    if (c.units.size() < 2)
      throw InputError(where, "gap diagnosis: expected at least two cycles to hold one out, got " +
                                  std::to_string(c.units.size()));
    const int nu = static_cast<int>(c.units.size());
    std::vector<int> order(nu);
    std::iota(order.begin(), order.end(), 0);
    if (o.cv_folds > 1 && o.cv_folds < nu) {
      std::mt19937_64 rng(o.seed);
      for (int i = nu - 1; i > 0; --i) std::swap(order[i], order[rng() % (i + 1)]);
      c.folds.assign(o.cv_folds, {});
      for (int i = 0; i < nu; ++i) c.folds[i % o.cv_folds].push_back(order[i]);
      rep.cv_scheme = std::to_string(o.cv_folds) + " folds of cycles";
    } else {
      for (int i = 0; i < nu; ++i) c.folds.push_back({i});
      rep.cv_scheme = "leave one cycle out";
    }
    rep.cycles = nu;
    rep.targets.push_back(diagnoseTarget(c, catalogue, target));
  }
  return rep;
}

}  // namespace kneesim::gap
