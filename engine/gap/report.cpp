#include "gap/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/json.hpp"
#include "core/paths.hpp"
#include "core/strings.hpp"
#include "gap/prediction.hpp"
#include "identify/report_json.hpp"

namespace kneesim::gap {

namespace {

using nlohmann::json;
namespace fs = std::filesystem;

json interval(const identify::Interval& i) { return json::array({jsonNumber(i.lower), jsonNumber(i.upper)}); }

json meanInterval(const MeanInterval& m) {
  return {{"mean", jsonNumber(m.mean)}, {"lower", jsonNumber(m.lower)}, {"upper", jsonNumber(m.upper)}, {"sd", jsonNumber(m.sd)}, {"n", m.n}};
}

std::string fmt(double v, int digits = 3) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream s;
  s.precision(digits);
  s << v;
  return s.str();
}

std::string fixed(double v, int decimals) {
  if (!std::isfinite(v)) return "n/a";
  std::ostringstream s;
  s << std::fixed << std::setprecision(decimals) << v;
  return s.str();
}

std::string pct(double v) { return std::isfinite(v) ? fixed(100 * v, 1) + " %" : "n/a"; }

json bandJson(const BandCurve& b) {
  json j;
  j["activity"] = b.activity;
  json rows = json::array();
  for (size_t k = 0; k < b.phase.size(); ++k)
    rows.push_back({jsonNumber(b.phase[k]), jsonNumber(b.mean_gap[k]), jsonNumber(b.sd_gap[k]), jsonNumber(b.mean_measured[k]),
                    jsonNumber(b.sd_measured[k]), jsonNumber(b.mean_predicted[k]), b.n_cycles[k]});
  j["columns"] = {"phase", "mean_gap_N", "sd_gap_N", "mean_measured_N", "repeatability_sd_N", "mean_predicted_N",
                  "cycles"};
  j["rows"] = rows;
  return j;
}

json correlationsJson(const std::vector<SignalCorrelation>& cs) {
  json a = json::array();
  for (const auto& c : cs)
    a.push_back({{"signal", c.signal}, {"r", jsonNumber(c.r)}, {"ci", {jsonNumber(c.lower), jsonNumber(c.upper)}},
                 {"n", c.n}, {"n_eff", jsonNumber(c.n_eff)}});
  return a;
}

json noiseFloorJson(const NoiseFloor& n) {
  return {{"run", n.run},
          {"note", n.note},
          {"matched_on", n.matched_on},
          {"cycles", n.units},
          {"matched_frames", n.pairs},
          {"floor_N", jsonNumber(n.floor)},
          {"withheld_rmse_N", jsonNumber(n.rmse)},
          {"excess_share", jsonNumber(n.excess)},
          {"excess_share_lower", jsonNumber(n.excess_lower)},
          {"excess_share_upper", jsonNumber(n.excess_upper)},
          {"tolerance_rmse_over_floor", jsonNumber(n.tolerance)},
          {"above", n.above},
          {"consistent", n.consistent},
          {"cycles_needed", n.cycles_needed}};
}

json agnosticJson(const AgnosticCheck& a) {
  json imp = json::array(), dep = json::array();
  for (const auto& i : a.importance) imp.push_back({{"signal", i.signal}, {"share", jsonNumber(i.share)}});
  for (const auto& p : a.dependence) {
    json x = json::array(), y = json::array();
    for (double v : p.x) x.push_back(jsonNumber(v));
    for (double v : p.y) y.push_back(jsonNumber(v));
    dep.push_back({{"signal", p.signal}, {"x", x}, {"fitted_residual_N", y}});
  }
  return {{"run", a.run},
          {"note", a.note},
          {"cycles", a.units},
          {"frames", a.frames},
          {"features", a.features},
          {"signals", a.signals},
          {"relative_mse_reduction", jsonNumber(a.reduction)},
          {"relative_mse_reduction_one_sided_lower", jsonNumber(a.reduction_lower)},
          {"cross_fitted_score_t", jsonNumber(a.score_t)},
          {"cross_fitted_score_critical_t", jsonNumber(a.score_critical)},
          {"p_value", jsonNumber(a.p_value)},
          {"significant", a.significant},
          {"importance", imp},
          {"partial_dependence", dep}};
}

json heterogeneityJson(const CycleHeterogeneity& h) {
  return {{"run", h.run},          {"note", h.note},           {"cycles", h.units},
          {"statistic", jsonNumber(h.statistic)}, {"p_value", jsonNumber(h.p_value)}, {"significant", h.significant},
          {"gain_sd", jsonNumber(h.gain_sd)},     {"offset_sd_N", jsonNumber(h.offset_sd)}};
}

json wanderJson(const RecordingWander& w) {
  return {{"run", w.run},         {"note", w.note},           {"recordings", w.recordings},
          {"cycles", w.units},    {"statistic", jsonNumber(w.statistic)}, {"quarters", w.cells},
          {"draws", w.draws}, {"p_value", jsonNumber(w.p_value)},
          {"significant", w.significant}, {"wander_sd_N", jsonNumber(w.wander_sd)}};
}

// Title prefix of the plots: what kind of data they show when it is not real data.
std::string banner(const GapReport& r) {
  return std::string(r.synthetic ? "SYNTHETIC TRIALS - " : "") + (r.interim_inputs ? "INTERIM INPUTS - " : "");
}

std::string bw(double n, double body_weight) { return body_weight > 0 ? fixed(n / body_weight, 2) + " BW" : "n/a"; }

// Where the gap lies: phases, correlations, the best time shift, the reference predictors, bands.
json whereJson(const TargetDiagnosis& d) {
  json where;
  json phases = json::array();
  for (const auto& p : d.phases)
    phases.push_back({{"activity", p.activity}, {"phase", p.phase}, {"frames", p.n_frames}, {"cycles", p.n_cycles},
                      {"rmse_N", jsonNumber(p.rmse)}, {"rmse_BW", jsonNumber(p.rmse_bw)}, {"bias_N", jsonNumber(p.bias)},
                      {"systematic_gap_N", jsonNumber(p.systematic)}, {"repeatability_band_N", jsonNumber(p.band)},
                      {"verdict", p.verdict}});
  where["phases"] = phases;
  where["correlations"] = correlationsJson(d.correlations);
  where["best_time_shift_s"] = jsonNumber(d.best_lag);
  where["best_time_shift_r"] = jsonNumber(d.best_lag_r);
  where["reference_predictors"] = {
      {"baseline_heldout_rmse_N", jsonNumber(d.reference.baseline_rmse)},
      {"training_mean_curve_heldout_rmse_N", jsonNumber(d.reference.mean_curve_rmse)},
      {"training_mean_curve_frames", d.reference.mean_curve_frames},
      {"baseline_heldout_rmse_on_those_frames_N", jsonNumber(d.reference.baseline_rmse_on_mean_curve_frames)},
      {"isotonic_area_to_force_heldout_rmse_N", jsonNumber(d.reference.isotonic_rmse)},
      {"isotonic_area_to_force_in_sample_rmse_N", jsonNumber(d.reference.isotonic_in_sample_rmse)}};
  json bands = json::array();
  for (const auto& b : d.bands) bands.push_back(bandJson(b));
  where["bands"] = bands;
  return where;
}

// Which effect: the screening steps, the full fits and the confusable pairs, into @p t.
void writeSelectionJson(const TargetDiagnosis& d, json& t) {
  json screening = json::array();
  for (size_t s = 0; s < d.screening.size(); ++s) {
    json step = json::array();
    for (const auto& x : d.screening[s]) {
      json one = {{"effect", x.effect}, {"testable", x.testable}, {"lm_statistic", jsonNumber(x.statistic)},
                  {"dof", x.dof}, {"p_value", jsonNumber(x.p_value)}, {"z", jsonNumber(x.z)},
                  {"predicted_sse_reduction", jsonNumber(x.predicted_reduction)}};
      if (!x.reason.empty()) one["reason"] = x.reason;
      json os = json::object();
      for (const auto& [n, v] : x.one_step) os[n] = jsonNumber(v);
      one["one_step_estimate"] = os;
      step.push_back(one);
    }
    screening.push_back({{"step", s + 1}, {"ranking", step}});
  }
  t["screening"] = screening;
  json cands = json::array();
  for (const auto& c : d.candidates) {
    json ps = json::array();
    for (const auto& p : c.parameters)
      ps.push_back({{"name", p.name}, {"unit", p.unit}, {"value", jsonNumber(p.value)}, {"ci_asymptotic", interval(p.ci)},
                    {"ci_jackknife", interval(p.ci_jackknife)}, {"fold_mean", jsonNumber(p.fold_mean)},
                    {"fold_sd", jsonNumber(p.fold_sd)}, {"sign_consistency", jsonNumber(p.sign_consistency)},
                    {"at_bound", p.at_bound}, {"identified", p.identified}});
    cands.push_back({{"effect", c.effect},
                     {"law", c.law},
                     {"step", c.step},
                     {"converged", c.converged},
                     {"rmse_in_sample_N", jsonNumber(c.rmse_in_sample)},
                     {"rmse_heldout_N", jsonNumber(c.rmse_heldout)},
                     {"heldout_log_sse_ratio", meanInterval(c.log_ratio)},
                     {"relative_mse_reduction", jsonNumber(c.relative_improvement)},
                     {"relative_mse_reduction_interval", meanInterval(c.reduction)},
                     {"relative_mse_reduction_one_sided_lower", jsonNumber(c.one_sided_lower)},
                     {"prewhitened_relative_mse_reduction", jsonNumber(c.whitened_improvement)},
                     {"prewhitened_relative_mse_reduction_one_sided_lower", jsonNumber(c.whitened_one_sided_lower)},
                     {"cross_fitted_score_t", jsonNumber(c.score_t)},
                     {"cross_fitted_score_critical_t", jsonNumber(c.score_critical)},
                     {"significant", c.isSignificant()},
                     {"d_aic", jsonNumber(c.d_aic)},
                     {"d_bic", jsonNumber(c.d_bic)},
                     {"parameters", ps},
                     {"accepted", c.accepted},
                     {"decision", c.decision},
                     {"notes", c.notes}});
  }
  t["candidates"] = cands;
  t["prewhitening_ar"] = d.prewhitening;
  json conf = json::array();
  for (const auto& c : d.confusable)
    conf.push_back({{"a", c.a}, {"b", c.b}, {"signature_r", jsonNumber(c.signature_r)},
                    {"heldout_log_sse_ratio_a_over_b", meanInterval(c.difference)},
                    {"separated_by", c.separated_by}});
  t["confusable_pairs"] = conf;
}

// What remains and how far the gap shrinks, into @p t.
void writeRemainingJson(const TargetDiagnosis& d, json& t) {
  json rem = json::array();
  for (const auto& b : d.structure.remaining) rem.push_back(bandJson(b));
  t["remaining_structure"] = {{"statistic", jsonNumber(d.structure.statistic)}, {"p_value", jsonNumber(d.structure.p_value)},
                              {"cycles", d.structure.cycles}, {"significant", d.structure.significant},
                              {"evidence", d.structure.evidence},
                              {"systematic_gap_N", jsonNumber(d.structure.systematic_gap)},
                              {"mean_gap_uncertainty_N", jsonNumber(d.structure.mean_uncertainty)},
                              {"repeatability_band_N", jsonNumber(d.structure.repeatability_band)},
                              {"exceeds_band", d.structure.exceeds_band},
                              {"note", d.structure.note}, {"bands", rem},
                              {"correlations", correlationsJson(d.structure.correlations)},
                              {"noise_floor", noiseFloorJson(d.structure.noise_floor)},
                              {"model_agnostic_check", agnosticJson(d.structure.agnostic)},
                              {"cycle_heterogeneity", heterogeneityJson(d.structure.cycle_heterogeneity)},
                              {"recording_wander", wanderJson(d.structure.recording_wander)}};
  auto rows = [](const std::vector<ShrinkageRow>& v, const char* final_key, const char* final_bw_key) {
    json sh = json::array();
    for (const auto& s : v)
      sh.push_back({{"scheme", s.scheme}, {"scope", s.scope}, {"train", s.train}, {"frames", s.n_frames},
                    {"cycles", s.n_cycles}, {"rmse_baseline_N", jsonNumber(s.rmse_base)}, {final_key, jsonNumber(s.rmse_final)},
                    {"rmse_baseline_BW", jsonNumber(s.rmse_base_bw)}, {final_bw_key, jsonNumber(s.rmse_final_bw)},
                    {"reduction", jsonNumber(s.reduction)}, {"reduction_ci", interval(s.ci)}});
    return sh;
  };
  t["shrinkage"] = rows(d.shrinkage, "rmse_final_N", "rmse_final_BW");
  json cmp = json::array();
  for (const auto& c : d.comparisons)
    cmp.push_back({{"name", c.name}, {"kind", c.kind}, {"channel", c.channel}, {"note", c.note},
                   {"rows", rows(c.rows, "rmse_alternative_N", "rmse_alternative_BW")}});
  t["comparisons"] = cmp;
}

}  // namespace

json toJson(const GapReport& r, const Anchors& a) {
  json j;
  j["kind"] = "kneesim gap diagnosis";
  j["interim_inputs"] = r.interim_inputs;
  j["synthetic"] = r.synthetic;
  if (r.interim_inputs)
    j["warning"] = "INTERIM INPUTS: contact areas derived from the measured force, not the contact-area tool's "
                   "output; not a real-data result";
  j["law"] = r.law;
  j["law_origin"] = r.law_origin;
  j["trials"] = r.trials;
  j["activities"] = r.activities;
  j["effects"] = r.effects;
  j["body_mass_kg"] = jsonNumber(r.body_mass);
  j["cycles"] = r.cycles;
  j["cross_validation"] = r.cv_scheme;
  j["notes"] = r.notes;
  j["anchors"] = {{"source", "Knee Grand Challenge"},
                  {"winners_rms_per_compartment_N", {a.winners_rms_low, a.winners_rms_high}},
                  {"elastic_foundation_cosimulation_total_BW", a.elastic_foundation_bw},
                  {"jw_body_mass_kg", a.jw_body_mass}};
  const double bwN = r.body_mass * identify::kStandardGravity;
  json targets = json::array();
  for (const auto& d : r.targets) {
    json t;
    t["target"] = d.target;
    t["verdict_class"] = d.verdict_class;
    t["verdict"] = d.verdict;
    t["verdict_text"] = d.verdict_text;
    t["selected"] = d.selected;
    if (d.undecided.effect.empty()) {
      t["undecided"] = nullptr;
    } else {
      const UndecidedCandidate& u = d.undecided;
      t["undecided"] = {{"effect", u.effect},
                        {"step", u.step},
                        {"relative_mse_reduction", jsonNumber(u.reduction)},
                        {"relative_mse_reduction_one_sided_lower", jsonNumber(u.lower)},
                        {"prewhitened_relative_mse_reduction", jsonNumber(u.whitened)},
                        {"prewhitened_relative_mse_reduction_one_sided_lower", jsonNumber(u.whitened_lower)},
                        {"cycles", u.cycles},
                        {"cycles_needed", u.cycles_needed}};
    }
    t["final_law"] = d.final_law;
    t["baseline"] = identify::toJson(d.baseline);
    t["baseline_heldout_rmse_N"] = jsonNumber(d.baseline_rmse_heldout);
    t["baseline_heldout_rmse_BW"] = jsonNumber(bwN > 0 ? d.baseline_rmse_heldout / bwN : NAN);
    t["final_fit"] = identify::toJson(d.final_fit);
    t["where"] = whereJson(d);
    writeSelectionJson(d, t);
    t["untestable"] = d.untestable;
    writeRemainingJson(d, t);
    targets.push_back(t);
  }
  j["targets"] = targets;
  return j;
}

namespace {

// The "What remains" section: each test, the noise floor and the signals carrying what is left.
void writeRemaining(std::ostringstream& s, const TargetDiagnosis& d) {
  const StructureTest& st = d.structure;
  s << "### What remains after `" << d.final_law << "`\n\n"
    << "Verdict class: **" << d.verdict_class << "**. Each test at a fifth of the family level (Bonferroni); "
    << (st.evidence.empty() ? std::string("none finds structure") : "structure found by: " + join(st.evidence, ", "))
    << ".\n\n| test | result |\n|---|---|\n";
  s << "| mean gap over the cycle (F-type test over " << st.cycles << " cycles) | p = " << fmt(st.p_value, 3)
    << "; " << fixed(st.systematic_gap, 0) << " N RMS against its uncertainty of " << fixed(st.mean_uncertainty, 0)
    << " N (the measured force's repeatability band: " << fixed(st.repeatability_band, 0) << " N)"
    << (st.note.empty() ? "" : "; " + st.note) << " |\n";
  const AgnosticCheck& a = st.agnostic;
  s << "| model-agnostic check | ";
  if (a.run)
    s << "removes " << pct(a.reduction) << " of the withheld error (lower bound " << pct(a.reduction_lower)
      << "); cross-fitted score t " << fixed(a.score_t, 2) << " (needed " << fixed(a.score_critical, 2) << "); "
      << (a.significant ? "**significant**" : "not significant") << " (" << a.note << ") |\n";
  else
    s << "not run: " << a.note << " |\n";
  const NoiseFloor& n = st.noise_floor;
  s << "| noise floor | ";
  if (n.run)
    s << fixed(n.floor, 0) << " N against a withheld error of " << fixed(n.rmse, 0) << " N; " << pct(n.excess)
      << " of the mean square above it [" << pct(n.excess_lower) << ", " << pct(n.excess_upper) << "]: "
      << (n.above ? "**above**" : n.consistent ? "consistent" : "cannot tell")
      << (n.cycles_needed > 0 ? " (about " + std::to_string(n.cycles_needed) + " cycles would tell)" : "") << "; "
      << n.note << " |\n";
  else
    s << "not estimated: " << n.note << " |\n";
  const CycleHeterogeneity& h = st.cycle_heterogeneity;
  s << "| cycle-to-cycle offset and gain | ";
  if (h.run)
    s << "p = " << fmt(h.p_value, 3) << (h.significant ? " (**significant**)" : "") << "; gain SD " << pct(h.gain_sd)
      << ", offset SD " << fixed(h.offset_sd, 0) << " N (" << h.note << ") |\n";
  else
    s << "not run: " << h.note << " |\n";
  const RecordingWander& w = st.recording_wander;
  s << "| offset or wander within a recording | ";
  if (w.run)
    s << "p = " << fmt(w.p_value, 3) << (w.significant ? " (**significant**)" : "") << "; " << fixed(w.wander_sd, 0)
      << " N (" << w.note << ") |\n";
  else
    s << "not run: " << w.note << " |\n";
  s << "\nThe noise floor is the scatter of the withheld residual between cycles at matched phase, kinematics and "
       "load: anything that changes from cycle to cycle at the same kinematics and load counts as noise there.\n\n";
  if (a.run && !a.importance.empty()) {
    s << "Signals carrying what the model-agnostic check fits (share of its trees' gain, on all cycles):\n\n"
         "| signal | share |\n|---|---:|\n";
    for (size_t k = 0; k < a.importance.size() && k < 8; ++k)
      s << "| " << a.importance[k].signal << " | " << pct(a.importance[k].share) << " |\n";
    s << "\n";
  }
  if (!st.correlations.empty())
    s << "Strongest remaining correlation: " << st.correlations[0].signal << " (r = " << fixed(st.correlations[0].r, 2)
      << ").\n\n";
}

// The "Where the gap lies" section: phases, correlations, time shift, reference predictors.
void writeWhereMarkdown(std::ostringstream& s, const TargetDiagnosis& d) {
  s << "### Where the gap lies\n\n";
  s << "| activity | phase | cycles | withheld RMSE | bias (measured - predicted) | systematic gap | repeatability band "
       "| verdict |\n|---|---|---:|---:|---:|---:|---:|---|\n";
  for (const auto& p : d.phases)
    s << "| " << p.activity << " | " << p.phase << " | " << p.n_cycles << " | " << fixed(p.rmse, 0) << " N ("
      << fixed(p.rmse_bw, 2) << " BW) | " << fixed(p.bias, 0) << " N | " << fixed(p.systematic, 0) << " N | "
      << (std::isfinite(p.band) ? fixed(p.band, 0) + " N" : std::string("n/a")) << " | " << p.verdict << " |\n";
  s << "\nSystematic gap: RMS over the phase of the mean withheld gap across cycles. Repeatability band: SD of the "
       "measured force across cycles at the same point of the cycle; a systematic gap inside it is noise.\n\n";
  s << "Correlation of the withheld gap with candidate signals (95 % intervals on the effective sample size):\n\n"
       "| signal | r | interval |\n|---|---:|---|\n";
  for (size_t k = 0; k < d.correlations.size() && k < 10; ++k) {
    const auto& c = d.correlations[k];
    s << "| " << c.signal << " | " << fixed(c.r, 2) << " | [" << fixed(c.lower, 2) << ", " << fixed(c.upper, 2)
      << "] |\n";
  }
  s << "\nBest time shift of the prediction: " << fixed(1000 * d.best_lag, 1) << " ms (r = " << fixed(d.best_lag_r, 3)
    << "; positive: the measured force lags the prediction).\n\n";
  s << "Reference predictors (withheld RMSE): baseline " << fixed(d.reference.baseline_rmse, 1)
    << " N; training-mean curve of the activity " << fixed(d.reference.mean_curve_rmse, 1) << " N (on "
    << d.reference.mean_curve_frames << " frames, where the baseline has " << fixed(d.reference.baseline_rmse_on_mean_curve_frames, 1)
    << " N); best monotone map area -> force " << fixed(d.reference.isotonic_rmse, 1)
    << " N (in sample " << fixed(d.reference.isotonic_in_sample_rmse, 1)
    << " N: no law driven by the contact area alone can do better on these data).\n\n";

}

// The "Which effect" section: screening, full fits, confusable pairs, untestable effects.
void writeWhichMarkdown(std::ostringstream& s, const TargetDiagnosis& d) {
  s << "### Which effect\n\n";
  for (size_t st = 0; st < d.screening.size(); ++st) {
    s << "Screening, step " << st + 1 << " (score test at the current model; z = (LM - dof) / sqrt(2 dof)):\n\n"
      << "| effect | z | p | SSE removed by one Gauss-Newton step | one-step estimate |\n|---|---:|---:|---:|---|\n";
    for (const auto& x : d.screening[st]) {
      if (!x.testable) continue;
      std::string os;
      for (const auto& [n, v] : x.one_step) os += (os.empty() ? "" : ", ") + n + " = " + fmt(v);
      s << "| " << x.effect << " | " << fixed(x.z, 2) << " | " << fmt(x.p_value, 2) << " | "
        << pct(x.predicted_reduction) << " | " << os << " |\n";
    }
    s << "\n";
  }
  s << "Full fits (withheld error against the current model: reduction of the pooled MSE with its one-sided lower "
       "bound at the step's Bonferroni level, which decides significance; the same reduction of the prewhitened "
       "errors, which chooses among the significant ones; and the mean per-cycle log ratio of SSE, > 0 is "
       "better).";
  if (d.prewhitening.empty()) {
    s << " No prewhitening.";
  } else {
    s << " Prewhitening filter: AR(" << d.prewhitening.size()
      << ") of the baseline's residuals less their mean over the cycle, up to 6 Hz, phi =";
    for (double v : d.prewhitening) s << " " << fixed(v, 3);
    s << ".";
  }
  s << "\n\n| step | effect | withheld RMSE | MSE reduction (lower bound) | prewhitened (lower bound) | "
       "cross-fitted score t (needed) | log ratio [95 % CI] | dAIC | dBIC | parameters | decision |\n"
       "|---:|---|---:|---:|---:|---:|---|---:|---:|---|---|\n";
  for (const auto& c : d.candidates) {
    std::string ps;
    for (const auto& p : c.parameters)
      ps += (ps.empty() ? "" : "; ") + p.name + " = " + fmt(p.value) + " " + p.unit + " [" + fmt(p.ci.lower) + ", " +
            fmt(p.ci.upper) + "] (folds: jackknife [" + fmt(p.ci_jackknife.lower) + ", " +
            fmt(p.ci_jackknife.upper) + "], same sign " + pct(p.sign_consistency) + ")";
    s << "| " << c.step << " | " << c.effect << " | " << fixed(c.rmse_heldout, 1) << " N | "
      << pct(c.relative_improvement) << " (" << pct(c.one_sided_lower) << ") | " << pct(c.whitened_improvement)
      << " (" << pct(c.whitened_one_sided_lower) << ") | " << fixed(c.score_t, 2) << " ("
      << fixed(c.score_critical, 2) << ") | " << fixed(c.log_ratio.mean, 3) << " [" << fixed(c.log_ratio.lower, 3)
      << ", " << fixed(c.log_ratio.upper, 3) << "] | " << fixed(c.d_aic, 1) << " | " << fixed(c.d_bic, 1) << " | "
      << ps << " | " << c.decision << " |\n";
  }
  s << "\n";
  if (!d.confusable.empty()) {
    s << "Confusable pairs (the data at hand cannot tell them apart: both improve the withheld error alike with "
         "nearly proportional force changes, or what the baseline leaves visible of them is nearly the same):\n\n";
    for (const auto& c : d.confusable) s << "- **" << c.a << " ~ " << c.b << "**: " << c.separated_by << "\n";
    s << "\n";
  }
  if (!d.untestable.empty()) {
    s << "Not testable with these inputs:\n\n";
    for (const auto& u : d.untestable) s << "- " << u << "\n";
    s << "\n";
  }
}

// The alternative baselines and compared effects beside the baseline law, on withheld data.
void writeComparisons(std::ostringstream& s, const TargetDiagnosis& d) {
  if (d.comparisons.empty()) return;
  s << "### Beside other estimates\n\n"
       "The baseline law's withheld error beside an alternative baseline (a channel taken as the force, nothing "
       "fitted) and beside the law with an effect added, whether or not the selection chose it.\n\n"
       "| alternative | scheme | withheld | trained on | cycles | baseline RMSE | alternative RMSE | reduction [95 % CI] "
       "|\n|---|---|---|---|---:|---:|---:|---|\n";
  for (const auto& c : d.comparisons) {
    const std::string who = c.kind == "alternative baseline" ? "`" + c.channel + "` (alternative baseline)"
                                                            : "baseline + `" + c.name + "`";
    if (c.rows.empty()) s << "| " << who << " | | | | | | | " << c.note << " |\n";
    for (const auto& x : c.rows)
      s << "| " << who << " | " << x.scheme << " | " << x.scope << " | " << x.train << " | " << x.n_cycles << " | "
        << fixed(x.rmse_base, 1) << " N (" << fixed(x.rmse_base_bw, 2) << " BW) | " << fixed(x.rmse_final, 1) << " N ("
        << fixed(x.rmse_final_bw, 2) << " BW) | " << pct(x.reduction) << " [" << pct(x.ci.lower) << ", "
        << pct(x.ci.upper) << "] |\n";
  }
  s << "\n";
}

}  // namespace

std::string formatMarkdown(const GapReport& r, const std::vector<std::string>& plots, const Anchors& a) {
  std::ostringstream s;
  const double bwN = r.body_mass * identify::kStandardGravity;
  if (r.synthetic)
    s << "> **SYNTHETIC TRIALS - NOT A REAL-DATA RESULT.** The measured forces were made by `kneesim synth` with "
         "known injected effects (see the notes).\n\n";
  if (r.interim_inputs)
    s << "> **INTERIM INPUTS - NOT A REAL-DATA RESULT.** Some contact areas are the interim stand-in derived from "
         "the measured force (files marked kneesim_interim=true), not the contact-area tool's output.\n\n";
  s << "# Sim-to-real gap diagnosis: " << r.law << "\n\n";
  s << "Trials: ";
  for (size_t k = 0; k < r.trials.size(); ++k) s << (k ? ", " : "") << r.trials[k];
  s << " (" << r.cycles << " cycles; " << r.cv_scheme << "). Body mass " << fmt(r.body_mass) << " kg (1 BW = "
    << fixed(bwN, 0) << " N).\n\n";
  for (const auto& n : r.notes) s << "- " << n << "\n";
  s << "\n";
  for (const auto& d : r.targets) {
    s << "## Target: " << d.target << " force\n\n";
    s << "**Verdict: " << d.verdict << ".** " << d.verdict_text << "\n\n";
    s << "Baseline `" << r.law << "` withheld RMSE " << fixed(d.baseline_rmse_heldout, 1) << " N ("
      << bw(d.baseline_rmse_heldout, bwN) << ")";
    if (!d.shrinkage.empty())
      s << "; selected model `" << d.final_law << "`: " << fixed(d.shrinkage[0].rmse_final, 1) << " N ("
        << bw(d.shrinkage[0].rmse_final, bwN) << ")";
    s << ". Knee Grand Challenge anchors: winners' RMS errors " << fixed(a.winners_rms_low, 0) << "-"
      << fixed(a.winners_rms_high, 0) << " N per compartment; an elastic-foundation co-simulation "
      << fmt(a.elastic_foundation_bw) << " BW total (JW " << fmt(a.jw_body_mass) << " kg).\n\n";
    for (const auto& p : plots)
      if (p.rfind(d.target + "_", 0) == 0) s << "![" << p << "](" << p << ")\n\n";

    writeWhereMarkdown(s, d);
    writeWhichMarkdown(s, d);
    writeRemaining(s, d);
    s << "### How far it shrinks\n\n"
         "| scheme | scope | trained on | cycles | baseline RMSE | selected RMSE | reduction [95 % CI] |\n"
         "|---|---|---|---:|---:|---:|---|\n";
    for (const auto& x : d.shrinkage)
      s << "| " << x.scheme << " | " << x.scope << " | " << x.train << " | " << x.n_cycles << " | "
        << fixed(x.rmse_base, 1) << " N (" << fixed(x.rmse_base_bw, 2) << " BW) | " << fixed(x.rmse_final, 1) << " N ("
        << fixed(x.rmse_final_bw, 2) << " BW) | " << pct(x.reduction) << " [" << pct(x.ci.lower) << ", "
        << pct(x.ci.upper) << "] |\n";
    s << "\n";
    writeComparisons(s, d);
  }
  return s.str();
}

namespace {

// Runs gnuplot on `script` in `dir`; true on success.
bool runGnuplot(const ReportOptions& o, const std::string& dir, const std::string& script) {
  const std::string cmd = "cd '" + dir + "' && '" + o.gnuplot + "' '" + script + "' > /dev/null 2>&1";
  return std::system(cmd.c_str()) == 0;
}

std::string dq(const std::string& s) {
  std::string o;
  for (char c : s) o += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
  return o;
}

// What remains after the selected effects: the model-agnostic check's result and carrying signals (their
// share of the trees' gain), the partial dependence on the leading ones against +- the noise floor.
std::string remainingScript(const GapReport& r, const TargetDiagnosis& d) {
  const std::string tg = d.target;
  const AgnosticCheck& a = d.structure.agnostic;
  const NoiseFloor& n = d.structure.noise_floor;
  const int np = static_cast<int>(a.dependence.size());
  std::ostringstream g;
  g << "set terminal pngcairo size 1000," << (1 + np) * 280 << " font ',10' noenhanced\n"
    << "set output '" << tg << "_remaining.png.tmp'\nset multiplot layout " << 1 + np << ",1 title \""
    << dq(banner(r) + tg + " force: what remains after " + d.final_law + " (" + d.verdict_class + ")") << "\"\n"
    << "set grid ytics\nset style fill solid 0.8\nset boxwidth 0.7\nset xtics rotate by -30\n"
    << "set title \"" << dq("model-agnostic check: removes " + pct(a.reduction) + " of the withheld error (lower bound " +
                           pct(a.reduction_lower) + "), score t " + fixed(a.score_t, 2) + " (needed " +
                           fixed(a.score_critical, 2) + "): " + (a.significant ? "significant" : "not significant") +
                           "; signals' share of its fit")
    << "\"\nset ylabel '% of the gain'\nplot '" << tg << "_remaining.dat' index 0 using 0:2:xtic(1) with boxes lc rgb "
       "'#fd8d3c' notitle\nset xtics norotate\n";
  for (int k = 0; k < np; ++k) {
    g << "set title \"" << dq("partial dependence on " + a.dependence[k].signal + "; dashed: +- the noise floor (" +
                             fixed(n.floor, 0) + " N; withheld error " + fixed(n.rmse, 0) + " N)")
      << "\"\nset xlabel \"" << dq(a.dependence[k].signal) << "\"\nset ylabel 'fitted residual (N)'\n"
      << "plot '" << tg << "_remaining.dat' index " << k + 1
      << " using 1:2 with linespoints lw 2 lc rgb '#e6550d' notitle, " << (std::isfinite(n.floor) ? n.floor : 0.0)
      << " with lines dt 2 lc rgb '#555555' notitle, " << (std::isfinite(n.floor) ? -n.floor : 0.0)
      << " with lines dt 2 lc rgb '#555555' notitle, 0 with lines lc rgb 'black' notitle\n";
  }
  g << "unset multiplot\n";
  return g.str();
}

// The target's data files (series, bands, ranking and, when the model-agnostic check ran, what carries
// what remains), appended to @p written; true when the remaining plot has data.
bool writeTargetData(const std::string& directory, const TargetDiagnosis& d, std::vector<std::string>& written) {
  const std::string tg = d.target;
  writeFileAtomically(directory + "/" + tg + "_series.dat", [&](std::ostream& f) {
    f << "# per trial (blocks separated by two blank lines): time_s measured_N baseline_heldout_N "
         "selected_heldout_N cycle_phase\n";
    for (const auto& sr : d.series) {
      f << "# " << sr.trial << " (" << sr.activity << ")\n";
      for (size_t i = 0; i < sr.time.size(); ++i)
        f << sr.time[i] << " " << sr.measured[i] << " " << (std::isfinite(sr.baseline[i]) ? sr.baseline[i] : NAN)
          << " " << sr.final_model[i] << " " << sr.phase[i] << "\n";
      f << "\n\n";
    }
  });
  writeFileAtomically(directory + "/" + tg + "_bands.dat", [&](std::ostream& f) {
    f << "# per activity (blocks): phase mean_gap sd_gap mean_measured repeatability_sd mean_predicted cycles "
         "remaining_mean_gap\n";
    for (size_t k = 0; k < d.bands.size(); ++k) {
      const auto& b = d.bands[k];
      const BandCurve* rem = k < d.structure.remaining.size() ? &d.structure.remaining[k] : nullptr;
      f << "# " << b.activity << "\n";
      for (size_t i = 0; i < b.phase.size(); ++i)
        f << b.phase[i] << " " << b.mean_gap[i] << " " << (std::isfinite(b.sd_gap[i]) ? b.sd_gap[i] : 0.0) << " "
          << b.mean_measured[i] << " " << (std::isfinite(b.sd_measured[i]) ? b.sd_measured[i] : 0.0) << " "
          << b.mean_predicted[i] << " " << b.n_cycles[i] << " " << (rem ? rem->mean_gap[i] : NAN) << "\n";
      f << "\n\n";
    }
  });
  writeFileAtomically(directory + "/" + tg + "_ranking.dat", [&](std::ostream& f) {
    f << "# effect screening_z relative_mse_reduction_percent (step 1; NaN: not fitted)\n";
    if (d.screening.empty()) return;
    for (const auto& x : d.screening[0]) {
      if (!x.testable) continue;
      double rel = NAN;
      for (const auto& c : d.candidates)
        if (c.step == 1 && c.effect == x.effect) rel = 100 * c.relative_improvement;
      f << x.effect << " " << x.z << " " << rel << "\n";
    }
  });
  for (const char* suffix : {"_series.dat", "_bands.dat", "_ranking.dat"}) written.push_back(tg + suffix);
  const AgnosticCheck& ag = d.structure.agnostic;
  const bool remaining_plot = ag.run && !ag.importance.empty();
  if (remaining_plot) {
    writeFileAtomically(directory + "/" + tg + "_remaining.dat", [&](std::ostream& f) {
      f << "# block 0: signal share_percent (model-agnostic check's trees, all cycles); then one block per "
           "signal: value fitted_residual_N (partial dependence)\n";
      for (const auto& im : ag.importance) f << "\"" << im.signal << "\" " << 100 * im.share << "\n";
      for (const auto& pd : ag.dependence) {
        f << "\n\n# " << pd.signal << "\n";
        for (size_t k = 0; k < pd.x.size(); ++k) f << pd.x[k] << " " << pd.y[k] << "\n";
      }
    });
    written.push_back(tg + "_remaining.dat");
  }

  return remaining_plot;
}

// The bands plot: per activity, the withheld gap over the cycle before and after the selected effects,
// the repeatability band and +- the noise floor of what remains.
std::string bandsScript(const GapReport& r, const TargetDiagnosis& d) {
  const std::string tg = d.target;
  const NoiseFloor& nf = d.structure.noise_floor;
  const std::string floor =
      nf.run && std::isfinite(nf.floor)
          ? "  " + fixed(nf.floor, 1) + " with lines dt 2 lc rgb '#555555' title '" +
                dq("+- noise floor after the selected effects (" + fixed(nf.floor, 0) + " N)") + "', " +
                fixed(-nf.floor, 1) + " with lines dt 2 lc rgb '#555555' notitle, \\\n"
          : std::string();
  const int nb = static_cast<int>(d.bands.size());
  std::ostringstream bands;
  bands << "set terminal pngcairo size 1000," << std::max(1, nb) * 320 << " font ',10' noenhanced\n"
        << "set output '" << tg << "_bands.png.tmp'\nset multiplot layout " << std::max(1, nb) << ",1 title \""
        << dq(banner(r) + tg + " force: withheld gap over the cycle")
        << "\"\nset xlabel 'normalised cycle (%)'\nset ylabel 'N'\nset grid\nset key outside right\n";
  for (int k = 0; k < nb; ++k) {
    bands << "unset arrow\n";
    for (const auto& ph : getActivityDefinition(d.bands[k].activity).phases) {
      if (ph.begin > 0)
        bands << "set arrow from " << 100 * ph.begin << ", graph 0 to " << 100 * ph.begin
              << ", graph 1 nohead dt 3 lc rgb '#888888'\n";
    }
    bands << "set title \"" << dq(d.bands[k].activity) << "\"\n"
          << "plot '" << tg << "_bands.dat' index " << k
          << " using ($1*100):(-$5):($5) with filledcurves fc rgb '#dddddd' title 'repeatability band (SD of measured)', \\\n"
          << "  '' index " << k << " using ($1*100):($2-$3):($2+$3) with filledcurves fc rgb '#9ecae1' fs transparent solid 0.6 title 'gap +- SD over cycles', \\\n"
          << "  '' index " << k << " using ($1*100):2 with lines lw 2 lc rgb '#08519c' title 'baseline: mean withheld gap', \\\n"
          << "  '' index " << k << " using ($1*100):8 with lines lw 2 dt 2 lc rgb '#cb181d' title 'after selected effects', \\\n"
          << floor << "  0 with lines lc rgb 'black' notitle\n";
  }
  bands << "unset multiplot\n";
  return bands.str();
}

// The fits plot: measured and withheld predictions per trial, before and after.
std::string fitsScript(const GapReport& r, const TargetDiagnosis& d) {
  const std::string tg = d.target;
  const int ns = std::min<int>(8, static_cast<int>(d.series.size()));
  std::ostringstream fits;
  fits << "set terminal pngcairo size 1000," << std::max(1, ns) * 260 << " font ',10' noenhanced\n"
       << "set output '" << tg << "_fits.png.tmp'\nset multiplot layout " << std::max(1, ns) << ",1 title \""
       << dq(banner(r) + tg +
             " force: measured and withheld predictions, before and after")
       << "\"\nset xlabel 's'\nset ylabel 'N'\nset grid\nset key outside right\n";
  for (int k = 0; k < ns; ++k)
    fits << "set title \"" << dq(d.series[k].trial) << "\"\nplot '" << tg << "_series.dat' index " << k
         << " using 1:2 with lines lw 2 lc rgb 'black' title 'measured', '' index " << k
         << " using 1:3 with lines lc rgb '#08519c' title 'baseline (" << dq(r.law) << ")', '' index " << k
         << " using 1:4 with lines dt 2 lc rgb '#cb181d' title 'selected (" << dq(d.final_law) << ")'\n";
  fits << "unset multiplot\n";
  return fits.str();
}

// The ranking plot: screening scores and withheld improvements at step 1.
std::string rankingScript(const GapReport& r, const TargetDiagnosis& d) {
  const std::string tg = d.target;
  std::ostringstream rank;
  rank << "set terminal pngcairo size 1000,640 font ',10' noenhanced\nset output '" << tg
       << "_ranking.png.tmp'\nset multiplot layout 2,1 title \""
       << dq(banner(r) + tg + " force: effects at step 1")
       << "\"\nset style fill solid 0.8\nset boxwidth 0.7\nset xtics rotate by -30\nset grid ytics\n"
          "set title 'screening score (z of the Lagrange multiplier statistic)'\nset ylabel 'z'\n"
          "plot '" << tg << "_ranking.dat' using 0:2:xtic(1) with boxes lc rgb '#6baed6' notitle\n"
          "set title 'withheld mean-square-error reduction of the fully fitted candidates'\nset ylabel '%'\n"
          "plot '" << tg << "_ranking.dat' using 0:($3==$3?$3:0):xtic(1) with boxes lc rgb '#31a354' notitle\n"
          "unset multiplot\n";
  return rank.str();
}

}  // namespace

std::vector<std::string> writeGapReport(const std::string& directory, const GapReport& r, const ReportOptions& o) {
  createFolder(directory);
  std::vector<std::string> written, plots;
  const bool have_gnuplot =
      o.plots && std::system(("'" + o.gnuplot + "' --version > /dev/null 2>&1").c_str()) == 0;
  GapReport rep = r;  // notes about plots go into the report
  if (o.plots && !have_gnuplot) rep.notes.push_back("no plots: '" + o.gnuplot + "' could not be run");
  for (const auto& d : r.targets) {
    const std::string tg = d.target;
    const bool remaining_plot = writeTargetData(directory, d, written);
    std::vector<std::pair<std::string, std::string>> scripts = {
        {tg + "_bands", bandsScript(r, d)}, {tg + "_fits", fitsScript(r, d)}, {tg + "_ranking", rankingScript(r, d)}};
    if (remaining_plot) scripts.emplace_back(tg + "_remaining", remainingScript(r, d));
    for (const auto& [name, script] : scripts) {
      // C++17 lambdas cannot capture structured bindings (g++ allows it, clang does not).
      const std::string& text = script;
      writeFileAtomically(directory + "/" + name + ".gp", [&](std::ostream& f) { f << text; });
      written.push_back(name + ".gp");
      if (!have_gnuplot) continue;
      if (runGnuplot(o, directory, name + ".gp") && pathExists(directory + "/" + name + ".png.tmp")) {
        fs::rename(directory + "/" + name + ".png.tmp", directory + "/" + name + ".png");
        written.push_back(name + ".png");
        plots.push_back(name + ".png");
      } else {
        fs::remove(directory + "/" + name + ".png.tmp");
        rep.notes.push_back("gnuplot failed on " + name + ".gp");
      }
    }
  }
  writeFileAtomically(directory + "/gap_report.json",
                      [&](std::ostream& f) { f << toJson(rep, o.anchors).dump(2) << "\n"; });
  writeFileAtomically(directory + "/gap_model.json", [&](std::ostream& f) { f << formatGapModel(makeGapModel(rep)); });
  written.push_back("gap_model.json");
  writeFileAtomically(directory + "/gap_report.md",
                      [&](std::ostream& f) { f << formatMarkdown(rep, plots, o.anchors); });
  written.push_back("gap_report.json");
  written.push_back("gap_report.md");
  return written;
}

}  // namespace kneesim::gap
