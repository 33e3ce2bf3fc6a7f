#include "identify/report_json.hpp"

#include <cmath>

#include <nlohmann/json.hpp>

#include "core/atomic_file.hpp"
#include "core/json.hpp"

namespace kneesim::identify {

using nlohmann::json;

namespace {

json interval(const Interval& i) {
  if (!i.isValid()) return nullptr;
  return json::array({jsonNumber(i.lower), jsonNumber(i.upper)});
}

json phases(const std::vector<std::pair<std::string, FitMetrics>>& v) {
  json a = json::array();
  for (const auto& [name, m] : v) {
    json j = toJson(m);
    j["phase"] = name;
    a.push_back(j);
  }
  return a;
}

}  // namespace

json toJson(const FitMetrics& m) {
  return {{"frames", m.n_frames},
          {"rmse_N", jsonNumber(m.rmse)},
          {"rmse_BW", jsonNumber(m.rmse_bw)},
          {"r2", jsonNumber(m.r2)},
          {"max_abs_error_N", jsonNumber(m.max_abs_error)},
          {"time_of_max_error_s", jsonNumber(m.time_of_max_error)},
          {"trial_of_max_error", m.trial_of_max_error},
          {"bias_N", jsonNumber(m.bias)},
          {"mean_measured_N", jsonNumber(m.mean_measured)},
          {"peak_measured_N", jsonNumber(m.peak_measured)},
          {"nrmse_peak", jsonNumber(m.nrmse_peak)}};
}

json toJson(const IdentifiabilityReport& r) {
  auto dirs = [&](const std::vector<SensitivityDirection>& v) {
    json a = json::array();
    for (const auto& d : v) {
      json c = json::object();
      for (size_t j = 0; j < r.parameters.size(); ++j) c[r.parameters[j]] = d.components[j];
      a.push_back({{"relative_singular_value", d.relative},
                   {"singular_value_N", d.singular_value},
                   {"direction", r.describe(d)},
                   {"components", c}});
    }
    return a;
  };
  return {{"evaluated_at", r.label},
          {"parameters", r.parameters},
          {"values", r.values},
          {"sensitivity_rms_N", r.column_rms},
          {"singular_values_N", r.singular_values},
          {"condition_number", jsonNumber(r.condition_number)},
          {"tolerance", r.tolerance},
          {"weak_tolerance", r.weak_tolerance},
          {"identifiable", r.isIdentifiable()},
          {"null_directions", dirs(r.null_directions)},
          {"weak_directions", dirs(r.weak_directions)}};
}

json toJson(const FitReport& r) {
  json params = json::array();
  for (const auto& p : r.parameters) {
    json j = {{"name", p.name},
              {"unit", p.unit},
              {"value", p.value},
              {"start", p.start},
              {"bounds", json::array({p.lower, p.upper})},
              {"status", toString(p.status)},
              {"at_bound", p.at_bound},
              {"ci_asymptotic", interval(p.ci_asymptotic)},
              {"ci_profile", interval(p.ci_profile)},
              {"ci_bootstrap", interval(p.ci_bootstrap)}};
    if (!p.value_source.empty()) j["value_source"] = p.value_source;
    params.push_back(j);
  }
  json derived = json::array();
  for (const auto& d : r.derived)
    derived.push_back({{"name", d.name},
                       {"unit", d.unit},
                       {"value", jsonNumber(d.value)},
                       {"identified", d.identified},
                       {"ci_asymptotic", interval(d.ci_asymptotic)},
                       {"ci_profile", interval(d.ci_profile)},
                       {"ci_bootstrap", interval(d.ci_bootstrap)}});
  json fixed = json::array();
  for (const auto& f : r.fixed_by_identifiability)
    fixed.push_back({{"name", f.name},
                     {"value", f.value},
                     {"value_source", f.value_source},
                     {"null_direction", f.direction},
                     {"relative_singular_value", f.relative_singular_value}});
  json trials = json::array();
  for (const auto& t : r.per_trial) {
    json j = toJson(t.metrics);
    j["trial"] = t.trial;
    j["phases"] = phases(t.phases);
    trials.push_back(j);
  }
  return {{"law", r.law},
          {"law_origin", r.law_origin},
          {"trials", r.trials},
          {"parameters", params},
          {"derived", derived},
          {"identifiability",
           {{"start", toJson(r.identifiability_start)},
            {"fixed", fixed},
            {"final", toJson(r.identifiability_final)}}},
          {"solver",
           {{"status", r.solver.status},
            {"status_code", r.solver.status_code},
            {"success", r.solver.success},
            {"iterations", r.solver.iterations},
            {"objective_N2", r.solver.objective},
            {"start_objective_N2", r.solver.start_objective}}},
          {"metrics", toJson(r.overall)},
          {"per_trial", trials},
          {"per_phase", phases(r.per_phase)},
          {"residual_lag1_correlation", jsonNumber(r.residual_lag1_correlation)},
          {"effective_frames", r.effective_frames},
          {"confidence_level", r.confidence_level},
          {"bootstrap",
           {{"mode", r.bootstrap.mode},
            {"samples", r.bootstrap.samples},
            {"block_length", r.bootstrap.block_length},
            {"failures", r.bootstrap.failures},
            {"seed", r.bootstrap.seed}}},
          {"notes", r.notes}};
}

json toJson(const PredictionReport& r, bool with_series) {
  json j = {{"trial", r.trial}, {"metrics", toJson(r.metrics)}, {"phases", phases(r.phases)}};
  if (with_series) {
    j["time_s"] = r.time;
    j["measured_N"] = r.measured;
    j["predicted_N"] = r.predicted;
  }
  return j;
}

void writeFitReport(const std::string& path, const FitReport& report) {
  const std::string text = toJson(report).dump(2);
  writeFileAtomically(path, [&](std::ostream& os) { os << text << "\n"; });
}

}  // namespace kneesim::identify
