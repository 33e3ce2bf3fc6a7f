#include "identify/fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <set>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "core/strings.hpp"
#include "identify/least_squares.hpp"
#include "identify/statistics.hpp"

namespace kneesim::identify {

std::string toString(ParameterStatus s) {
  switch (s) {
    case ParameterStatus::Identified: return "identified";
    case ParameterStatus::FixedBySetup: return "fixed";
    case ParameterStatus::FixedUnidentifiable: return "fixed: not identifiable";
  }
  return "?";
}

Eigen::VectorXd FitReport::getValues() const {
  Eigen::VectorXd v(parameters.size());
  for (size_t i = 0; i < parameters.size(); ++i) v[i] = parameters[i].value;
  return v;
}

const ParameterResult& FitReport::getParameter(const std::string& name) const {
  for (const auto& p : parameters)
    if (p.name == name) return p;
  KNEESIM_CHECK(false, "no parameter '" + name + "' in the fit report");
  throw;  // unreachable
}

const DerivedResult& FitReport::getDerived(const std::string& name) const {
  for (const auto& d : derived)
    if (d.name == name) return d;
  KNEESIM_CHECK(false, "no derived quantity '" + name + "' in the fit report");
  throw;  // unreachable
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string fmt(double v, int digits = 6) { return formatSignificant(v, digits); }

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double pos = q * (v.size() - 1);
  const size_t i = static_cast<size_t>(std::floor(pos));
  const double f = pos - i;
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

// One trial prepared for evaluation: the law's input view, the selected frames and the buffers a
// force/Jacobian evaluation of the whole trial needs (allocated once).
struct TrialData {
  const Trial* trial = nullptr;
  LawInputs inputs;
  std::vector<int> frames;
  std::vector<double> weight;  // per selected frame
  Eigen::VectorXd force;
  Eigen::MatrixXd jac;
  int offset = 0;  // first residual of this trial
};

// Residuals F_law - F_measured of the selected frames of all trials as a function of the free
// parameters; the fixed ones are held at `full`.
class Dataset : public LeastSquaresProblem {
 public:
  Dataset(const ContactLaw& law, std::vector<TrialData> trials, Eigen::VectorXd full)
      : law_(law), trials_(std::move(trials)), full_(std::move(full)) {
    n_res_ = 0;
    for (auto& t : trials_) {
      t.offset = n_res_;
      n_res_ += static_cast<int>(t.frames.size());
      t.force.resize(t.inputs.getNumFrames());
      t.jac.resize(t.inputs.getNumFrames(), law_.getNumParameters());
    }
  }

  void setFree(std::vector<int> free) { free_ = std::move(free); }
  const std::vector<int>& getFree() const { return free_; }
  void setFull(const Eigen::VectorXd& full) { full_ = full; }
  const Eigen::VectorXd& getFull() const { return full_; }
  Eigen::VectorXd withFree(const double* x) const {
    Eigen::VectorXd p = full_;
    for (size_t k = 0; k < free_.size(); ++k) p[free_[k]] = x[k];
    return p;
  }
  std::vector<TrialData>& getTrials() { return trials_; }

  int getNumParameters() const override { return static_cast<int>(free_.size()); }
  int getNumResiduals() const override { return n_res_; }

  void calcResiduals(const double* x, double* r, double* jacobian) override {
    for (size_t k = 0; k < free_.size(); ++k) full_[free_[k]] = x[k];
    for (auto& t : trials_) {
      law_.calcForce(full_.data(), t.inputs, t.force.data(), jacobian ? t.jac.data() : nullptr);
      const auto& meas = t.trial->measured_force;
      for (size_t s = 0; s < t.frames.size(); ++s) {
        const int i = t.frames[s];
        r[t.offset + s] = t.force[i] - meas[i];
        if (jacobian)
          for (size_t k = 0; k < free_.size(); ++k)
            jacobian[k * n_res_ + t.offset + s] = t.jac(i, free_[k]);
      }
    }
  }

  // Jacobian of all residuals with respect to the parameters in `cols` at `full`.
  Eigen::MatrixXd calcJacobian(const Eigen::VectorXd& full, const std::vector<int>& cols) {
    Eigen::MatrixXd j(n_res_, cols.size());
    for (auto& t : trials_) {
      law_.calcForce(full.data(), t.inputs, t.force.data(), t.jac.data());
      for (size_t s = 0; s < t.frames.size(); ++s)
        for (size_t k = 0; k < cols.size(); ++k) j(t.offset + s, k) = t.jac(t.frames[s], cols[k]);
    }
    return j;
  }

  std::vector<double> getBaseWeights() const {
    std::vector<double> w(n_res_);
    for (const auto& t : trials_)
      for (size_t s = 0; s < t.frames.size(); ++s) w[t.offset + s] = t.weight[s];
    return w;
  }

 private:
  const ContactLaw& law_;
  std::vector<TrialData> trials_;
  Eigen::VectorXd full_;
  std::vector<int> free_;
  int n_res_ = 0;
};

// Scale of parameter j for sensitivities: |value|, or the typical scale at zero.
double sensitivityScale(const ContactLaw& law, const Eigen::VectorXd& full, int j) {
  return full[j] != 0 ? std::abs(full[j]) : law.getParameter(j).typical_scale;
}

IdentifiabilityReport analyze(Dataset& data, const ContactLaw& law, const Eigen::VectorXd& full,
                              const std::vector<int>& cols, const std::vector<double>& w, const FitOptions& o,
                              const std::string& label) {
  Eigen::MatrixXd s = data.calcJacobian(full, cols);
  for (Eigen::Index i = 0; i < s.rows(); ++i) s.row(i) *= std::sqrt(w[i]);
  std::vector<std::string> names;
  std::vector<double> values;
  for (size_t k = 0; k < cols.size(); ++k) {
    s.col(k) *= sensitivityScale(law, full, cols[k]);
    names.push_back(law.getParameter(cols[k]).name);
    values.push_back(full[cols[k]]);
  }
  return analyzeSensitivity(s, names, values, o.identifiability_tolerance, o.weak_identifiability_tolerance, label);
}

// Gradient of every derived quantity with respect to the parameters in `cols`, each column scaled
// like the sensitivities (d derived / d p_j * |p_j|). Central differences inside the bounds.
Eigen::MatrixXd derivedGradient(const ContactLaw& law, const Eigen::VectorXd& full, const std::vector<int>& cols,
                                const std::vector<double>& lower, const std::vector<double>& upper, bool scaled) {
  Eigen::MatrixXd g(law.getNumDerived(), cols.size());
  if (law.getNumDerived() == 0) return g;
  for (size_t k = 0; k < cols.size(); ++k) {
    const int j = cols[k];
    const double sc = sensitivityScale(law, full, j);
    double h = 1e-6 * sc;
    double up = std::min(full[j] + h, upper[j]), lo = std::max(full[j] - h, lower[j]);
    if (!(up > lo)) {
      up = full[j] + h;
      lo = full[j] - h;
    }
    Eigen::VectorXd p = full;
    p[j] = up;
    const Eigen::VectorXd dp = law.calcDerived(p);
    p[j] = lo;
    const Eigen::VectorXd dm = law.calcDerived(p);
    g.col(k) = (dp - dm) / (up - lo) * (scaled ? sc : 1.0);
  }
  return g;
}

// Lag-1 autocorrelation of residuals pooled over trials (consecutive selected frames only).
double lag1Correlation(Dataset& data, const Eigen::VectorXd& r) {
  double num = 0, den = 0;
  for (const auto& t : data.getTrials()) {
    for (size_t s = 0; s < t.frames.size(); ++s) {
      const double a = r[t.offset + s];
      den += a * a;
      if (s + 1 < t.frames.size() && t.frames[s + 1] == t.frames[s] + 1) num += a * r[t.offset + s + 1];
    }
  }
  return den > 0 ? num / den : 0.0;
}

std::string joinNames(const std::vector<std::string>& v) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i == 0 ? "" : (i + 1 == v.size() ? " and " : ", ")) + v[i];
  return s;
}

// The free parameters f but f[held] (a solve with that one held): their indices into rest, their
// start values from p into y0, their bounds and scales into lo (replacing lo's).
void holdOneOut(const ContactLaw& law, const std::vector<int>& f, int held, const Eigen::VectorXd& p,
                const std::vector<double>& lower, const std::vector<double>& upper, std::vector<int>& rest,
                std::vector<double>& y0, LeastSquaresOptions& lo) {
  lo.lower.clear();
  lo.upper.clear();
  lo.scale.clear();
  for (size_t b = 0; b < f.size(); ++b)
    if (static_cast<int>(b) != held) {
      rest.push_back(f[b]);
      y0.push_back(p[f[b]]);
      lo.lower.push_back(lower[f[b]]);
      lo.upper.push_back(upper[f[b]]);
      lo.scale.push_back(law.getParameter(f[b]).typical_scale);
    }
}

}  // namespace

PredictionReport predict(const ContactLaw& law, const Eigen::VectorXd& params, const Trial& trial,
                         const FitOptions& o) {
  checkTrial(trial, o.where);
  const SourceLocation& where = locate(trial, o.where);
  KNEESIM_CHECK(params.size() == law.getNumParameters(), "parameter vector of the wrong size");
  const LawInputs in(law, trial.channels, trial.time, trial.name, where);
  PredictionReport rep;
  rep.trial = trial.name;
  rep.frames = selectFrames(trial, o.where);
  Eigen::VectorXd f;
  law.calcForce(params, in, f);
  for (int i : rep.frames) {
    rep.time.push_back(trial.time[i]);
    rep.measured.push_back(trial.measured_force[i]);
    rep.predicted.push_back(f[i]);
  }
  MetricsAccumulator all(o.body_mass);
  all.add(trial.name, trial.time, f.data(), trial.measured_force.data(), rep.frames);
  rep.metrics = all.calc();
  for (const auto& ph : o.phases) {
    MetricsAccumulator acc(o.body_mass);
    acc.add(trial.name, trial.time, f.data(), trial.measured_force.data(), selectPhase(trial, rep.frames, ph));
    rep.phases.emplace_back(ph.name, acc.calc());
  }
  return rep;
}

FitReport fit(const ContactLaw& law, const std::vector<Trial>& trials, const FitOptions& o) {
  const int np = law.getNumParameters();
  const std::string lawq = "contact law '" + law.getName() + "'";
  if (trials.empty()) throw InputError(o.where, lawq + ": expected at least one trial to fit, got none");
  {
    std::set<std::string> seen;
    for (const auto& t : trials)
      if (!seen.insert(t.name).second)
        throw InputError(o.where, "trial names: expected unique names, got '" + t.name + "' twice");
  }
  if (!(o.confidence.level > 0 && o.confidence.level < 1))
    throw InputError(o.where, "confidence level: expected a value in (0, 1), got " + fmt(o.confidence.level));

  // ---- parameters: values, bounds, free set
  Eigen::VectorXd full = law.getDefaultValues();
  std::vector<double> lower(np), upper(np);
  std::vector<std::string> source(np, "law default");
  for (int j = 0; j < np; ++j) {
    lower[j] = law.getParameter(j).lower;
    upper[j] = law.getParameter(j).upper;
  }
  for (const auto& [name, v] : o.parameter_values) {
    const int j = law.getParameterIndex(name, o.where);
    if (!std::isfinite(v))
      throw InputError(o.where, lawq + ": parameter '" + name + "': expected a finite value, got " + fmt(v));
    full[j] = v;
    source[j] = "setup";
  }
  for (const auto& [name, b] : o.bounds) {
    const int j = law.getParameterIndex(name, o.where);
    if (!(b.first < b.second))
      throw InputError(o.where, lawq + ": parameter '" + name + "': expected bounds lower < upper, got [" +
                                    fmt(b.first) + ", " + fmt(b.second) + "]");
    lower[j] = b.first;
    upper[j] = b.second;
  }
  for (const auto& [name, v] : o.assumed_values) {
    const int j = law.getParameterIndex(name, o.where);
    if (!(v >= lower[j] && v <= upper[j]))
      throw InputError(o.where, lawq + ": assumed value of '" + name + "': expected a value in [" + fmt(lower[j]) +
                                    ", " + fmt(upper[j]) + "], got " + fmt(v));
  }
  std::vector<int> freed;
  if (o.free_parameters.empty()) {
    for (int j = 0; j < np; ++j)
      if (!law.getParameter(j).fixed_by_default) freed.push_back(j);
  } else {
    for (const auto& name : o.free_parameters) {
      const int j = law.getParameterIndex(name, o.where);
      if (std::find(freed.begin(), freed.end(), j) == freed.end()) freed.push_back(j);
    }
    std::sort(freed.begin(), freed.end());
  }
  std::vector<std::string> start_notes;
  for (int j : freed)
    if (source[j] == "law default" && !(full[j] >= lower[j] && full[j] <= upper[j])) {
      // The setup narrowed the bounds past the law's default start: start on the nearest bound.
      const double v = std::clamp(full[j], lower[j], upper[j]);
      start_notes.push_back("start value of '" + law.getParameter(j).name + "' moved from the law default " +
                            fmt(full[j]) + " into the bounds: " + fmt(v));
      full[j] = v;
    }
  for (int j : freed)
    if (!(full[j] >= lower[j] && full[j] <= upper[j]))
      throw InputError(o.where, lawq + ": parameter '" + law.getParameter(j).name + "': expected a start value in [" +
                                    fmt(lower[j]) + ", " + fmt(upper[j]) + "], got " + fmt(full[j]));

  // ---- trials
  std::vector<TrialData> tds;
  for (const auto& t : trials) {
    const SourceLocation& where = locate(t, o.where);
    checkTrial(t, o.where);
    TrialData td{&t, LawInputs(law, t.channels, t.time, t.name, where), selectFrames(t, o.where), {}, {}, {}, 0};
    for (int i : td.frames) {
      if (!std::isfinite(t.measured_force[i]))
        throw InputError(where, "trial '" + t.name + "': measured force at t = " + fmt(t.time[i]) +
                                    " s: expected a finite force, got " + fmt(t.measured_force[i]) +
                                    " (leave such frames out with a time window)");
      td.weight.push_back(t.weight.empty() ? 1.0 : t.weight[i]);
    }
    tds.push_back(std::move(td));
  }
  Dataset data(law, std::move(tds), full);
  const std::vector<double> w0 = data.getBaseWeights();
  const int n = data.getNumResiduals();

  // The start point must give finite forces on every selected frame.
  for (auto& t : data.getTrials()) {
    law.calcForce(full.data(), t.inputs, t.force.data(), nullptr);
    for (int i : t.frames)
      if (!std::isfinite(t.force[i]))
        throw InputError(t.inputs.getSource(), lawq + " gives a non-finite force (" + fmt(t.force[i]) + ") at t = " +
                                                   fmt(t.trial->time[i]) + " s of trial '" + t.trial->name +
                                                   "' at the start values: check its input channels there");
  }

  FitReport rep;
  rep.law = law.getName();
  rep.law_origin = law.getOrigin();
  for (const auto& t : trials) rep.trials.push_back(t.name);
  rep.confidence_level = o.confidence.level;

  // ---- identifiability before solving
  std::vector<int> free = freed;
  rep.identifiability_start = analyze(data, law, full, freed, w0, o, "start point");
  std::vector<ParameterStatus> status(np, ParameterStatus::FixedBySetup);
  std::vector<std::string> value_source = source;
  for (int j : freed) status[j] = ParameterStatus::Identified;
  IdentifiabilityReport current = rep.identifiability_start;
  // Best weighted SSE with free[c] held at its assumed (or start) value and the rest of `f` solved.
  auto sseHolding = [&](const std::vector<int>& f, int c) {
    Eigen::VectorXd p = full;
    const std::string& name = law.getParameter(f[c]).name;
    if (auto it = o.assumed_values.find(name); it != o.assumed_values.end()) p[f[c]] = it->second;
    std::vector<int> rest;
    std::vector<double> y0;
    LeastSquaresOptions lo;
    holdOneOut(law, f, c, p, lower, upper, rest, y0, lo);
    lo.weights = w0;
    lo.max_iterations = o.max_iterations;
    lo.tolerance = o.tolerance;
    data.setFull(p);
    data.setFree(rest);
    return solveLeastSquares(data, y0, lo).sse;
  };
  while (!current.isIdentifiable()) {
    const SensitivityDirection& worst = current.null_directions.front();
    if (!o.fix_unidentifiable)
      throw InputError(o.where, lawq + ": parameters not identifiable from these data: the forces do not change along " +
                                    current.describe(worst) + " (relative singular value " + fmt(worst.relative, 3) +
                                    "); fix one of them or allow fixing unidentifiable parameters");
    // Which parameter of the null direction to hold: the data cannot say, so this is a modelling
    // choice, made in this order among the parameters with a real share of the null space:
    //  1. one the setup states an assumed value for;  2. one the law fixes by default (a geometric
    //  constant);  3. the one whose fixing leaves the best fit (holding E of Hertz at its default
    //  would force nu out of its bounds, holding nu does not);  4. the largest share.
    const std::vector<double> lev = current.calcNullSpaceLeverage();
    const double top = *std::max_element(lev.begin(), lev.end());
    std::vector<int> cand;
    for (int c = 0; c < static_cast<int>(free.size()); ++c)
      if (lev[c] >= 0.1 * top) cand.push_back(c);
    auto prefer = [&](int c) {
      const LawParameter& lp = law.getParameter(free[c]);
      return std::make_pair(o.assumed_values.count(lp.name) > 0, lp.fixed_by_default);
    };
    const auto best_pref = prefer(*std::max_element(cand.begin(), cand.end(),
                                                    [&](int a, int b) { return prefer(a) < prefer(b); }));
    cand.erase(std::remove_if(cand.begin(), cand.end(), [&](int c) { return prefer(c) != best_pref; }), cand.end());
    std::vector<double> cost(free.size(), 0.0);
    if (cand.size() > 1) {
      for (int c : cand) cost[c] = sseHolding(free, c);
      data.setFull(full);
    }
    int pick = cand.front();
    for (int c : cand) {
      const double tie = 1e-6 * std::max(cost[c], cost[pick]) + 1e-300;
      if (cost[c] < cost[pick] - tie || (std::abs(cost[c] - cost[pick]) <= tie && lev[c] > lev[pick])) pick = c;
    }
    const int j = free[pick];
    const std::string& name = law.getParameter(j).name;
    FixedByIdentifiability f;
    f.name = name;
    if (auto it = o.assumed_values.find(name); it != o.assumed_values.end()) {
      full[j] = it->second;
      f.value_source = "assumed value";
    } else {
      f.value_source = source[j];
    }
    f.value = full[j];
    f.direction = current.describe(worst);
    f.relative_singular_value = worst.relative;
    rep.fixed_by_identifiability.push_back(f);
    status[j] = ParameterStatus::FixedUnidentifiable;
    value_source[j] = f.value_source;
    free.erase(free.begin() + pick);
    data.setFull(full);
    current = analyze(data, law, full, free, w0, o, "start point, after fixing " + name);
  }

  // ---- solve
  data.setFull(full);
  data.setFree(free);
  LeastSquaresOptions lso;
  std::vector<double> x0;
  for (int j : free) {
    x0.push_back(full[j]);
    lso.lower.push_back(lower[j]);
    lso.upper.push_back(upper[j]);
    lso.scale.push_back(law.getParameter(j).typical_scale);
  }
  lso.weights = w0;
  lso.max_iterations = o.max_iterations;
  lso.tolerance = o.tolerance;
  lso.gauss_newton = o.gauss_newton;
  lso.verbose = o.verbose;
  if (o.warm_start) lso.warm_mu = 1e-6;
  const LeastSquaresResult sol = solveLeastSquares(data, x0, lso);
  rep.solver = {sol.status, sol.status_code, sol.success, sol.iterations, sol.sse, sol.start_sse};
  const Eigen::VectorXd start_full = full;
  for (size_t k = 0; k < free.size(); ++k) full[free[k]] = sol.x[k];
  data.setFull(full);
  const std::vector<double> xhat(sol.x);

  // ---- parameter and derived results
  for (int j = 0; j < np; ++j) {
    const LawParameter& lp = law.getParameter(j);
    ParameterResult pr;
    pr.name = lp.name;
    pr.unit = lp.unit;
    pr.value = full[j];
    pr.start = start_full[j];
    pr.lower = lower[j];
    pr.upper = upper[j];
    pr.status = status[j];
    if (status[j] != ParameterStatus::Identified) pr.value_source = value_source[j];
    rep.parameters.push_back(pr);
  }
  for (size_t k = 0; k < free.size(); ++k)
    rep.parameters[free[k]].at_bound = sol.at_lower[k] || sol.at_upper[k];
  {
    const Eigen::VectorXd d = law.calcDerived(full);
    // A derived quantity is identified when it does not change along the null directions of the
    // freed parameters (evaluated where those were analysed, at the start point).
    const Eigen::MatrixXd g = derivedGradient(law, start_full, freed, lower, upper, true);
    for (int q = 0; q < law.getNumDerived(); ++q) {
      DerivedResult dr;
      dr.name = law.getDerivedNames()[q];
      dr.unit = law.getDerivedUnits()[q];
      dr.value = d[q];
      const double gn = g.row(q).norm();
      for (const auto& nd : rep.identifiability_start.null_directions) {
        double dot = 0;
        for (size_t k = 0; k < freed.size(); ++k) dot += g(q, k) * nd.components[k];
        if (gn > 0 && std::abs(dot) > 1e-4 * gn) dr.identified = false;
      }
      rep.derived.push_back(dr);
    }
  }

  // ---- identifiability at the optimum, fit statistics
  rep.identifiability_final = analyze(data, law, full, free, w0, o, "optimum");
  Eigen::VectorXd resid(n);
  data.calcResiduals(xhat.data(), resid.data(), nullptr);
  {
    MetricsAccumulator overall(o.body_mass);
    std::vector<MetricsAccumulator> phase_acc(o.phases.size(), MetricsAccumulator(o.body_mass));
    for (auto& t : data.getTrials()) {
      const Trial& tr = *t.trial;
      // t.force holds the forces at the optimum after calcResiduals above.
      TrialFit tf;
      tf.trial = tr.name;
      MetricsAccumulator one(o.body_mass);
      one.add(tr.name, tr.time, t.force.data(), tr.measured_force.data(), t.frames);
      overall.add(tr.name, tr.time, t.force.data(), tr.measured_force.data(), t.frames);
      tf.metrics = one.calc();
      for (size_t p = 0; p < o.phases.size(); ++p) {
        const std::vector<int> sel = selectPhase(tr, t.frames, o.phases[p]);
        MetricsAccumulator acc(o.body_mass);
        acc.add(tr.name, tr.time, t.force.data(), tr.measured_force.data(), sel);
        phase_acc[p].add(tr.name, tr.time, t.force.data(), tr.measured_force.data(), sel);
        tf.phases.emplace_back(o.phases[p].name, acc.calc());
      }
      rep.per_trial.push_back(tf);
    }
    rep.overall = overall.calc();
    for (size_t p = 0; p < o.phases.size(); ++p) rep.per_phase.emplace_back(o.phases[p].name, phase_acc[p].calc());
  }
  const double rho = std::clamp(lag1Correlation(data, resid), 0.0, 0.99);
  rep.residual_lag1_correlation = lag1Correlation(data, resid);
  int n_pos = 0;
  for (double w : w0) n_pos += w > 0;
  rep.effective_frames = std::max(1.0, n_pos * (1 - rho) / (1 + rho));

  // ---- confidence intervals
  const int k = static_cast<int>(free.size());
  const double z = normalQuantile(0.5 + o.confidence.level / 2);
  const double sse_min = sol.sse;
  Eigen::VectorXd se = Eigen::VectorXd::Constant(k, kNaN);
  if (k > 0 && o.confidence.asymptotic && n_pos > k) {
    // Gauss-Newton covariance, inflated by n / n_eff for serially correlated residuals.
    Eigen::MatrixXd j = data.calcJacobian(full, free);
    Eigen::MatrixXd jtwj = Eigen::MatrixXd::Zero(k, k);
    for (int i = 0; i < n; ++i) jtwj.noalias() += w0[i] * j.row(i).transpose() * j.row(i);
    const double s2 = sse_min / (n_pos - k) * (1 + rho) / (1 - rho);
    // Invert in scaled parameters (D J^T W J D with D the sensitivity scales): parameters of very
    // different magnitudes (a modulus ~1e7 Pa next to a threshold shift ~1e-4 m) make J^T W J
    // look singular to a pivot threshold although it is well conditioned once scaled.
    Eigen::VectorXd dsc(k);
    for (int a = 0; a < k; ++a) dsc[a] = sensitivityScale(law, full, free[a]);
    const Eigen::MatrixXd scaled = dsc.asDiagonal() * jtwj * dsc.asDiagonal();
    Eigen::FullPivLU<Eigen::MatrixXd> lu(scaled);
    if (lu.isInvertible()) {
      const Eigen::MatrixXd cov = s2 * dsc.asDiagonal() * lu.inverse() * dsc.asDiagonal();
      for (int a = 0; a < k; ++a) {
        se[a] = std::sqrt(std::max(0.0, cov(a, a)));
        rep.parameters[free[a]].ci_asymptotic = {full[free[a]] - z * se[a], full[free[a]] + z * se[a]};
      }
      const Eigen::MatrixXd g = derivedGradient(law, full, free, lower, upper, false);
      for (int q = 0; q < law.getNumDerived(); ++q) {
        const double sd = std::sqrt(std::max(0.0, (g.row(q) * cov * g.row(q).transpose())(0, 0)));
        rep.derived[q].ci_asymptotic = {rep.derived[q].value - z * sd, rep.derived[q].value + z * sd};
      }
    }
  }

  // Minimum of the weighted SSE over the free parameters other than free[a] with free[a] = v,
  // starting from the optimum; also returns the parameter vector.
  auto profileAt = [&](int a, double v, Eigen::VectorXd& at) -> double {
    Eigen::VectorXd p = full;
    p[free[a]] = v;
    std::vector<int> others;
    std::vector<double> y0;
    LeastSquaresOptions po = lso;
    holdOneOut(law, free, a, full, lower, upper, others, y0, po);
    po.verbose = false;
    po.warm_mu = 1e-6;
    data.setFull(p);
    data.setFree(others);
    const LeastSquaresResult r = solveLeastSquares(data, y0, po);
    at = p;
    for (size_t b = 0; b < others.size(); ++b) at[others[b]] = r.x[b];
    return r.sse;
  };

  if (k > 0 && o.confidence.profile) {
    const double chi2 = z * z;
    const double threshold = sse_min * std::exp(chi2 / rep.effective_frames);
    std::vector<Eigen::VectorXd> ends;
    for (int a = 0; a < k; ++a) {
      const int j = free[a];
      const double v0 = full[j];
      double step = std::isfinite(se[a]) && se[a] > 0 ? se[a] : 1e-3 * sensitivityScale(law, full, j);
      step = std::max(step, 1e-9 * sensitivityScale(law, full, j));
      double bound[2];
      for (int side = 0; side < 2; ++side) {
        const double dir = side == 0 ? -1.0 : 1.0;
        const double limit = side == 0 ? lower[j] : upper[j];
        Eigen::VectorXd at;
        double inside = v0, outside = kNaN;
        double d = step;
        for (int it = 0; it < 60; ++it) {
          double v = v0 + dir * d;
          if ((side == 0 && v <= limit) || (side == 1 && v >= limit)) {
            v = limit;
            if (profileAt(a, v, at) <= threshold) break;  // the interval reaches the bound
            outside = v;
            break;
          }
          if (profileAt(a, v, at) > threshold) {
            outside = v;
            break;
          }
          inside = v;
          d *= 2;
        }
        if (std::isnan(outside)) {
          bound[side] = limit;
          profileAt(a, limit, at);
          ends.push_back(at);
          continue;
        }
        for (int it = 0; it < 60 && std::abs(outside - inside) > 1e-10 * std::max(std::abs(v0), step); ++it) {
          const double mid = 0.5 * (inside + outside);
          (profileAt(a, mid, at) > threshold ? outside : inside) = mid;
        }
        bound[side] = 0.5 * (inside + outside);
        profileAt(a, bound[side], at);
        ends.push_back(at);
      }
      rep.parameters[j].ci_profile = {bound[0], bound[1]};
    }
    for (int q = 0; q < law.getNumDerived(); ++q) {
      double lo = rep.derived[q].value, hi = lo;
      for (const auto& e : ends) {
        const double v = law.calcDerived(e)[q];
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
      rep.derived[q].ci_profile = {lo, hi};
    }
    data.setFull(full);
    data.setFree(free);
  }

  // ---- bootstrap
  const ConfidenceOptions& co = o.confidence;
  rep.bootstrap.mode = co.bootstrap_mode;
  rep.bootstrap.seed = co.seed;
  if (k > 0 && co.bootstrap_samples > 0) {
    if (co.bootstrap_mode != "frames" && co.bootstrap_mode != "trials")
      throw InputError(o.where, "bootstrap mode: expected 'frames' or 'trials', got '" + co.bootstrap_mode + "'");
    const bool by_trial = co.bootstrap_mode == "trials";
    if (by_trial && trials.size() < 2)
      throw InputError(o.where, "bootstrap mode 'trials': expected at least two trials, got " +
                                    std::to_string(trials.size()));
    int n_min = n;
    for (const auto& t : data.getTrials()) n_min = std::min<int>(n_min, static_cast<int>(t.frames.size()));
    int block = co.block_length;
    if (block <= 0) {
      // Long enough to keep the residuals' correlation inside blocks, at least n^(1/3).
      const double corr_len = (1 + rho) / (1 - rho);
      block = static_cast<int>(std::ceil(std::max(std::cbrt(static_cast<double>(n_min)), corr_len)));
    }
    block = std::clamp(block, 1, std::max(1, n_min / 2));
    rep.bootstrap.samples = co.bootstrap_samples;
    rep.bootstrap.block_length = by_trial ? 0 : block;
    std::mt19937_64 rng(co.seed);
    // Portable draws (std::uniform_int_distribution differs between standard libraries).
    auto draw = [&](int m) { return static_cast<int>(rng() % static_cast<unsigned long long>(m)); };
    std::vector<std::vector<double>> pv(k), dv(law.getNumDerived());
    LeastSquaresOptions bo = lso;
    bo.verbose = false;
    bo.warm_mu = 1e-6;
    std::vector<double> counts(n);
    for (int b = 0; b < co.bootstrap_samples; ++b) {
      std::fill(counts.begin(), counts.end(), 0.0);
      auto& tds2 = data.getTrials();
      if (by_trial) {
        for (size_t t = 0; t < tds2.size(); ++t) {
          const auto& td = tds2[draw(static_cast<int>(tds2.size()))];
          for (size_t s = 0; s < td.frames.size(); ++s) counts[td.offset + s] += 1;
        }
      } else {
        // Circular blocks (Politis & Romano 1992): a block may wrap from the last frame to the
        // first, so every frame is drawn equally often. Blocks that must fit inside the window
        // under-sample its first and last frames and bias the estimate.
        for (const auto& td : tds2) {
          const int m = static_cast<int>(td.frames.size());
          const int len = std::min(block, m);
          int filled = 0;
          while (filled < m) {
            const int start = draw(m);
            for (int s = 0; s < len && filled < m; ++s, ++filled) counts[td.offset + (start + s) % m] += 1;
          }
        }
      }
      for (int i = 0; i < n; ++i) bo.weights[i] = w0[i] * counts[i];
      data.setFull(full);
      data.setFree(free);
      const LeastSquaresResult r = solveLeastSquares(data, xhat, bo);
      if (!r.success) {
        ++rep.bootstrap.failures;
        continue;
      }
      Eigen::VectorXd p = full;
      for (int a = 0; a < k; ++a) {
        p[free[a]] = r.x[a];
        pv[a].push_back(r.x[a]);
      }
      const Eigen::VectorXd d = law.calcDerived(p);
      for (int q = 0; q < law.getNumDerived(); ++q) dv[q].push_back(d[q]);
    }
    const double lo_q = 0.5 - co.level / 2, hi_q = 0.5 + co.level / 2;
    for (int a = 0; a < k; ++a) rep.parameters[free[a]].ci_bootstrap = {percentile(pv[a], lo_q), percentile(pv[a], hi_q)};
    for (int q = 0; q < law.getNumDerived(); ++q) rep.derived[q].ci_bootstrap = {percentile(dv[q], lo_q), percentile(dv[q], hi_q)};
    data.setFull(full);
    data.setFree(free);
  }

  // ---- notes in plain language
  rep.notes.insert(rep.notes.end(), start_notes.begin(), start_notes.end());
  for (const auto& f : rep.fixed_by_identifiability) {
    std::string s = "'" + f.name + "' is not identifiable from force data (the forces do not change along " + f.direction +
                    ", relative singular value " + fmt(f.relative_singular_value, 2) + "): held at " + fmt(f.value) +
                    " (" + f.value_source + ")";
    rep.notes.push_back(s);
  }
  if (!rep.fixed_by_identifiability.empty()) {
    std::vector<std::string> ident, at_assumed;
    for (const auto& d : rep.derived)
      if (d.identified) ident.push_back(d.name + " = " + fmt(d.value) + " " + d.unit);
    for (int j : free) at_assumed.push_back(law.getParameter(j).name + " = " + fmt(full[j]) + " " +
                                            law.getParameter(j).unit);
    std::vector<std::string> assumed;
    for (const auto& f : rep.fixed_by_identifiability) assumed.push_back(f.name + " = " + fmt(f.value));
    if (!ident.empty()) rep.notes.push_back("identified: " + joinNames(ident));
    if (!at_assumed.empty())
      rep.notes.push_back(joinNames(at_assumed) + " hold(s) only at the assumed " + joinNames(assumed));
  }
  for (const auto& d : rep.identifiability_final.weak_directions)
    rep.notes.push_back("poorly determined combination " + rep.identifiability_final.describe(d) +
                        " (relative singular value " + fmt(d.relative, 2) + ")");
  for (int j : free)
    if (rep.parameters[j].at_bound)
      rep.notes.push_back("'" + law.getParameter(j).name + "' = " + fmt(full[j]) + " lies on its bound [" +
                          fmt(lower[j]) + ", " + fmt(upper[j]) + "]: the data push it further");
  if (!sol.success) rep.notes.push_back("the solver did not converge: " + sol.status);
  if (rho > 0.5)
    rep.notes.push_back("residuals are serially correlated (lag-1 r = " + fmt(rho, 3) + ", effective frames " +
                        fmt(rep.effective_frames, 4) + " of " + std::to_string(n_pos) +
                        "): asymptotic and profile intervals use the effective count; the block bootstrap is the "
                        "more reliable interval");
  return rep;
}

}  // namespace kneesim::identify
