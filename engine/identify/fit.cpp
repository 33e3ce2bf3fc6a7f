// Identification of a contact law on measured forces (identify/fit.hpp): the order of a fit's steps,
// the solve, the parameter and derived results, the fit statistics and the notes in plain
// language; and predict(). The steps are in fit_*.cpp (identify/fit_detail.hpp lists them).

#include "identify/fit.hpp"

#include <algorithm>
#include <cmath>

#include "identify/fit_detail.hpp"

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

using namespace detail;

std::string joinNames(const std::vector<std::string>& v) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i == 0 ? "" : (i + 1 == v.size() ? " and " : ", ")) + v[i];
  return s;
}

// The parameters' and derived quantities' values and statuses at the optimum; a derived quantity is
// identified when it does not change along the null directions of the freed parameters (evaluated
// where those were analysed, at the start point).
void fillResults(const ContactLaw& law, const FitParameters& par, const Eigen::VectorXd& full,
                 const Eigen::VectorXd& start_full, const std::vector<ParameterStatus>& status,
                 const std::vector<std::string>& value_source, const std::vector<int>& free,
                 const LeastSquaresResult& sol, FitReport& rep) {
  const int np = law.getNumParameters();
  const std::vector<double>& lower = par.lower;
  const std::vector<double>& upper = par.upper;
  const std::vector<int>& freed = par.freed;
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
}

}  // namespace

void detail::FitState::calcStatistics(FitReport& rep) {
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
  rho = std::clamp(lag1Correlation(data, resid), 0.0, 0.99);
  rep.residual_lag1_correlation = lag1Correlation(data, resid);
  n_pos = 0;
  for (double w : w0) n_pos += w > 0;
  rep.effective_frames = std::max(1.0, n_pos * (1 - rho) / (1 + rho));
}

void detail::FitState::addNotes(const std::vector<std::string>& start_notes, const LeastSquaresResult& sol,
                                FitReport& rep) const {
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
}

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
  checkRequest(law, trials, o);

  // ---- parameters: values, bounds, free set
  FitParameters par = resolveParameters(law, o);
  Eigen::VectorXd& full = par.full;
  const std::vector<double>& lower = par.lower;
  const std::vector<double>& upper = par.upper;
  const std::vector<int>& freed = par.freed;

  // ---- trials; the start point must give finite forces on every selected frame
  Dataset data(law, makeTrialData(law, trials, o), full);
  const std::vector<double> w0 = data.getBaseWeights();
  const int n = data.getNumResiduals();
  checkStartForces(data, law, full);

  FitReport rep;
  rep.law = law.getName();
  rep.law_origin = law.getOrigin();
  for (const auto& t : trials) rep.trials.push_back(t.name);
  rep.confidence_level = o.confidence.level;

  // ---- identifiability before solving
  rep.identifiability_start = analyze(data, law, full, freed, w0, o, "start point");
  std::vector<ParameterStatus> status(np, ParameterStatus::FixedBySetup);
  std::vector<std::string> value_source = par.source;
  for (int j : freed) status[j] = ParameterStatus::Identified;
  const std::vector<int> free = fixUnidentifiable(data, law, o, par, w0, rep, status, value_source);

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
  fillResults(law, par, full, start_full, status, value_source, free, sol, rep);

  // ---- identifiability at the optimum, fit statistics, confidence intervals
  FitState s{law, o, data, full, lower, upper, free, w0, n, lso, xhat, sol.sse};
  s.calcStatistics(rep);
  s.calcIntervals(trials, rep);

  // ---- notes in plain language
  s.addNotes(par.start_notes, sol, rep);
  return rep;
}

}  // namespace kneesim::identify
