// The gap diagnosis's entry point (gap/diagnosis.hpp): checks the request, builds each target's
// context and runs its steps in order (baseline, where, forward selection, verdict, series,
// shrinkage), each in its own diagnosis_*.cpp.

#include "gap/diagnosis.hpp"

#include <algorithm>
#include <cmath>

#include "core/strings.hpp"
#include "gap/diagnosis_detail.hpp"

namespace kneesim::gap {

namespace {

using namespace detail;

// The baseline: the user's identification on all cycles, then cross-validated; fits the
// prewhitening filter on its residuals (into c.ar).
Model fitBaseline(Context& c, TargetDiagnosis& d) {
  const DiagnosisOptions& o = *c.o;
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
  return base;
}

// Per trial, the series behind the plots.
std::vector<TrialSeries> makeSeries(const Context& c, const Model& base, const Model& current) {
  std::vector<TrialSeries> out;
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
    out.push_back(std::move(s));
  }
  return out;
}

TargetDiagnosis diagnoseTarget(Context& c, const std::vector<Effect>& catalogue, const std::string& target) {
  TargetDiagnosis d;
  d.target = target;
  const Model base = fitBaseline(c, d);
  if (c.o->where) analyseWhere(c, base, d);
  const Model current = selectEffects(c, catalogue, base, d);
  d.final_law = current.law.getName();
  d.final_fit = current.fit;
  writeVerdict(c, current, d);
  d.series = makeSeries(c, base, current);
  d.shrinkage = shrinkage(c, base, current);
  d.comparisons = compare(c, catalogue, base, target);
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
  for (const auto& [name, v] : g.trial.channels) {
    if (startsWith(name, "S@")) remap(name, "S_" + side + name.substr(1));
    // A whole-knee channel <p>_total (knee_muscle_total: the musculoskeletal force) reads as the
    // compartment's <p>_medial or <p>_lateral, and is dropped where the file has none.
    if (endsWith(name, "_total")) remap(name, name.substr(0, name.size() - 5) + side);
  }
  return t;
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
  for (const auto& name : o.compared_effects)
    if (std::none_of(catalogue.begin(), catalogue.end(), [&](const Effect& e) { return e.getName() == name; }))
      throw InputError(where, "gap diagnosis: compared_effects: expected an effect of the catalogue, got '" + name + "'");
  for (const auto& target : o.targets) {
    if (const std::string why = findTargetProblem(target); !why.empty())
      throw InputError(where, "gap diagnosis: target: " + why);
    Context c = makeContext(base, trials, o, target, rep.cv_scheme);
    rep.cycles = static_cast<int>(c.units.size());
    rep.targets.push_back(diagnoseTarget(c, catalogue, target));
  }
  return rep;
}

}  // namespace kneesim::gap
