// One candidate of the gap diagnosis: the current model plus one effect fitted fully and
// cross-validated, its significance tests (withheld MSE reduction, cross-fitted score), dAIC/dBIC
// and its parameters' stability across folds; and the candidate left undecided where the selection
// stopped.

#include <algorithm>
#include <cmath>

#include "gap/diagnosis_detail.hpp"

namespace kneesim::gap {
namespace detail {

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

}  // namespace detail

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

}  // namespace kneesim::gap
