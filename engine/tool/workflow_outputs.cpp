// The outputs of the knee contact workflow: each trial's contact-area and force storage files, and
// summary.json (setup, contact-area options, the identification, the threshold refits, per trial
// its events, window, area peaks, errors per phase and calibration).

#include <algorithm>
#include <filesystem>

#include "contact/contact_output.hpp"
#include "identify/report_json.hpp"
#include "tool/workflow_detail.hpp"

namespace kneesim::tool::detail {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

json metricsJson(const identify::FitMetrics& m) { return identify::toJson(m); }

// Peak of @p v over the frames of @p time inside [begin, end]: (value, time).
std::pair<double, double> peakOver(const std::vector<double>& time, const std::vector<double>& v, double begin,
                                   double end) {
  double best = -HUGE_VAL, at = kNaN;
  for (size_t i = 0; i < time.size(); ++i)
    if (time[i] >= begin - 1e-9 && time[i] <= end + 1e-9 && v[i] > best) {
      best = v[i];
      at = time[i];
    }
  return {std::isfinite(at) ? best : kNaN, at};
}

// A trial's contact areas with its flexion, kinematics columns and area derivatives.
io::Storage contactAreaStorage(const WorkflowSetup& setup, const WorkflowInputs& in, const WorkflowTrialResult& r) {
  const bool flex_rot = in.flex_rot;
  std::vector<std::pair<std::string, std::vector<double>>> extra = {{setup.flexion_coordinate, r.flexion}};
  for (const auto& c : r.kinematics_columns)
    if (c.first != "flexion") extra.push_back(c);
  for (const auto& c : r.area_derivatives) extra.push_back(c);
  std::vector<std::pair<std::string, std::string>> header = {{"setup_file", setup.setup_file},
                                                             {"kinematics", r.kinematics_description},
                                                             {"flexion_column", setup.flexion_coordinate + (flex_rot ? " (rad)" : "")}};
  if (!r.area_derivatives.empty())
    header.emplace_back("area_derivatives",
                        std::string("dS*_dflexion (m^2/") + (flex_rot ? "rad" : "m") +
                            "): central differences of the areas at the main threshold with " +
                            setup.flexion_coordinate + " shifted by +-" +
                            (flex_rot ? fmt(getFlexionStep(setup, true) / kDeg, 4) + " deg"
                                      : fmt(getFlexionStep(setup, false), 4) + " m") +
                            " (" + setup.kinematics + " kinematics); dS*_dap (m^2/m): with the femoral component "
                            "translated by +-" + fmt(setup.ap_step * 1e3, 4) + " mm along the insert's anterior direction");
  return contact::makeContactStorage(r.contact, *in.calculator, r.name + "_contact_area", extra, header);
}

// A trial's measured and predicted knee forces.
io::Storage forceStorage(const identify::ContactLaw& law, bool per_compartment, const TrialState& st) {
  const WorkflowTrialResult& r = st.result;
  io::Storage f;
  f.name = r.name + " measured and predicted knee force";
  f.header = {{"units", "N; gait_cycle_percent in %; GON as recorded"},
              {"measured", "eKnee load cells (lbf -> N), Dao & Pouletaut 2015 equation 4, at the motion's frames"},
              {"law", law.getName() + " identified on the training trials (see summary.json)"},
              {"knee_forces_file", st.spec.knee_forces_file}};
  f.labels = {"time", "gait_cycle_percent", "in_window", "measured_total", "measured_medial", "measured_lateral",
              "AM", "PM", "AL", "PL", "GON", "predicted_total", "residual"};
  if (per_compartment) {
    f.labels.push_back("predicted_medial");
    f.labels.push_back("predicted_lateral");
  }
  for (const auto& c : r.knee_loads.at_frames) f.labels.push_back(c.first);
  const bool muscles = !r.muscle_loads.total.empty();
  if (muscles) {
    for (const char* c : {"muscle_total", "muscle_medial", "muscle_lateral"}) f.labels.push_back(c);
    f.header.emplace_back("muscle", "the compressive knee force from static optimization and the joint reaction "
                                    "(MuscleChain; N), split by the frontal moment about the contact centroids");
  }
  if (!r.knee_loads.at_frames.empty())
    f.header.emplace_back("knee_loads", "the knee's net loads from inverse dynamics (" + r.knee_loads.id_setup_file +
                                            "; N and N m, no muscles), at these frames");
  const size_t n = r.time.size();
  f.data.resize(Eigen::Index(n), Eigen::Index(f.labels.size()));
  const auto in = [&](double t) {
    if (r.trial.windows.empty()) return 1.0;
    return t >= r.trial.windows[0].begin - 1e-9 && t <= r.trial.windows[0].end + 1e-9 ? 1.0 : 0.0;
  };
  for (size_t i = 0; i < n; ++i) {
    const double t = r.time[i];
    const double pct = r.cycle.isComplete() && t >= r.cycle.strike - 1e-9 && t <= r.cycle.next_strike + 1e-9
                           ? r.cycle.getPercent(t)
                           : kNaN;
    const double p = r.trial_prediction.predicted[i];
    std::vector<double> row = {t,
                               pct,
                               in(t),
                               r.forces.total[i],
                               r.forces.medial[i],
                               r.forces.lateral[i],
                               r.forces.am[i],
                               r.forces.pm[i],
                               r.forces.al[i],
                               r.forces.pl[i],
                               r.forces.goniometer.empty() ? kNaN : r.forces.goniometer[i],
                               p,
                               p - r.forces.total[i]};
    if (per_compartment) {
      row.push_back(r.predicted_medial[i]);
      row.push_back(r.predicted_lateral[i]);
    }
    for (const auto& c : r.knee_loads.at_frames) row.push_back(c.second[i]);
    if (muscles) row.insert(row.end(), {r.muscle_loads.total[i], r.muscle_loads.medial[i], r.muscle_loads.lateral[i]});
    for (size_t c = 0; c < row.size(); ++c) f.data(Eigen::Index(i), Eigen::Index(c)) = row[c];
  }
  return f;
}

// The identification report with the quantities the data determine stated plainly.
json identificationJson(const WorkflowReport& report, const identify::ContactLaw& law) {
  json law_j = identify::toJson(report.fit);
  // The quantities the data determine, stated plainly next to the full report.
  json stated;
  for (const auto& d : report.fit.derived)
    stated[d.name] = {{"value", d.value}, {"unit", d.unit}, {"identified", d.identified},
                      {"ci_asymptotic", d.ci_asymptotic.isValid() ? json::array({d.ci_asymptotic.lower, d.ci_asymptotic.upper}) : json(nullptr)},
                      {"ci_profile", d.ci_profile.isValid() ? json::array({d.ci_profile.lower, d.ci_profile.upper}) : json(nullptr)},
                      {"ci_bootstrap", d.ci_bootstrap.isValid() ? json::array({d.ci_bootstrap.lower, d.ci_bootstrap.upper}) : json(nullptr)}};
  for (const auto& p : report.fit.parameters)
    stated[p.name] = {{"value", p.value}, {"unit", p.unit}, {"status", identify::toString(p.status)},
                      {"value_source", p.value_source}};
  // E depends on the nu one assumes: the values at the paper's nu (0.25) and around UHMWPE's.
  {
    const int nu = law.findParameterIndex("nu");
    const auto k = std::find_if(report.fit.derived.begin(), report.fit.derived.end(),
                                [](const identify::DerivedResult& d) { return d.name == "K"; });
    if (nu >= 0 && k != report.fit.derived.end()) {
      json table = json::array();
      for (double v : {0.25, 0.3, 0.35, 0.4, 0.45, 0.49})
        table.push_back({{"nu", v}, {"E_Pa", k->value * (1 - v * v)}});
      stated["E_at_nu"] = table;
    }
  }
  law_j["stated"] = stated;
  return law_j;
}

json refitsJson(const WorkflowReport& report) {
  json refits = json::array();
  for (const ThresholdRefit& t : report.threshold_refits) {
    json j{{"channel", t.channel}, {"threshold_m", t.threshold}, {"solver_status", t.solver_status}};
    for (const auto& [name, v] : t.derived) j[name] = v;
    json pt = json::object();
    for (const auto& [trial, m] : t.per_trial) pt[trial] = metricsJson(m);
    j["per_trial_window"] = pt;
    refits.push_back(j);
  }
  return refits;
}

// Contact-area peaks: over the trial and the window, at the threshold and the extra ones.
json areaPeaksJson(const WorkflowSetup& setup, const WorkflowTrialResult& r) {
  json areas = json::array();
  const double wb = r.trial.windows.empty() ? -HUGE_VAL : r.trial.windows[0].begin;
  const double we = r.trial.windows.empty() ? HUGE_VAL : r.trial.windows[0].end;
  for (int e = -1; e < int(r.contact.extra_thresholds.size()); ++e) {
    const std::vector<double> s = areaSeries(r.contact, e);
    const auto [pk, tpk] = peakOver(r.time, s, -HUGE_VAL, HUGE_VAL);
    const auto [pw, tpw] = peakOver(r.time, s, wb, we);
    double lo = HUGE_VAL;
    for (size_t i = 0; i < s.size(); ++i)
      if (r.time[i] >= wb - 1e-9 && r.time[i] <= we + 1e-9) lo = std::min(lo, s[i]);
    areas.push_back({{"channel", e < 0 ? std::string("S") : contact::areaChannelName(r.contact.extra_thresholds[size_t(e)])},
                     {"threshold_m", e < 0 ? setup.contact.options.threshold : r.contact.extra_thresholds[size_t(e)]},
                     {"peak_m2", jsonNumber(pk)},
                     {"peak_time_s", jsonNumber(tpk)},
                     {"window_peak_m2", jsonNumber(pw)},
                     {"window_peak_time_s", jsonNumber(tpw)},
                     {"window_lowest_m2", jsonNumber(lo)}});
  }
  return areas;
}

// One trial's entry of summary.json.
json trialJson(const WorkflowSetup& setup, bool flex_rot, const TrialState& st) {
  const WorkflowTrialResult& r = st.result;
  json j;
  j["name"] = r.name;
  j["role"] = r.fit ? "fit" : "predict";
  j["kinematics"] = r.kinematics_description;
  j["frames"] = r.time.size();
  j["time_s"] = {r.time.front(), r.time.back()};
  j["ik_mean_marker_rms_m"] = jsonNumber(r.ik_mean_rms);
  j["notes"] = r.notes;
  json ev;
  ev["heel_strike_s"] = jsonNumber(r.cycle.strike);
  ev["toe_off_s"] = jsonNumber(r.cycle.toe_off);
  ev["next_heel_strike_s"] = jsonNumber(r.cycle.next_strike);
  ev["toe_off_percent_of_cycle"] = r.cycle.isComplete() ? jsonNumber(r.cycle.getToeOffPercent()) : json(nullptr);
  ev["source"] = st.spec.gait_events.empty() ? "force plates (" + st.spec.heel_marker + " over the plate)" : "setup";
  json plates = json::array();
  for (const auto& c : r.contacts) plates.push_back({{"plate", c.plate}, {"strike_s", c.strike}, {"off_s", jsonNumber(c.off)}});
  ev["plate_contacts"] = plates;
  j["gait_events"] = ev;
  json win;
  if (!r.trial.windows.empty()) win = {r.trial.windows[0].begin, r.trial.windows[0].end};
  j["window"] = {{"kind", st.spec.window}, {"s", win}};
  j["contact_area"] = areaPeaksJson(setup, r);
  const auto mm = std::minmax_element(r.flexion.begin(), r.flexion.end());
  j["flexion_range"] = {flex_rot ? *mm.first / kDeg : *mm.first, flex_rot ? *mm.second / kDeg : *mm.second};
  j["window_metrics"] = metricsJson(r.window_prediction.metrics);
  {
    // The error of the best constant force over the window (the measured force's standard
    // deviation): a law that does not beat it explains nothing of the force's variation.
    const auto& meas = r.window_prediction.measured;
    double mean = 0, ss = 0;
    for (double v : meas) mean += v / double(meas.size());
    for (double v : meas) ss += (v - mean) * (v - mean);
    j["window_metrics"]["constant_force_rmse_N"] = jsonNumber(std::sqrt(ss / double(meas.size())));
  }
  j["trial_metrics"] = metricsJson(r.trial_prediction.metrics);
  j["agreement"] = {{"tolerance_N", setup.agreement_fraction * r.window_prediction.metrics.peak_measured},
                    {"tolerance_fraction_of_window_peak", setup.agreement_fraction},
                    {"window_fraction", jsonNumber(r.window_agreement)},
                    {"cycle_fraction", jsonNumber(r.cycle_agreement)}};
  json ph = json::array();
  for (const PhaseError& e : r.phases) ph.push_back(phaseJson(e));
  j["phases"] = ph;
  json bins = json::array();
  for (const PhaseError& e : r.cycle_bins) bins.push_back(phaseJson(e));
  j["cycle_bins"] = bins;
  if (st.spec.source == WorkflowTrialSpec::Source::goniometer) {
    const io::GoniometerCalibration& g = r.goniometer;
    j["goniometer_calibration"] = {{"signal_units", r.goniometer_in_volts ? "volts" : "degrees"},
                                   {"volts_to_goniometer_degrees", {{"gain_deg_per_volt", g.volts_gain}, {"offset_deg", g.volts_offset_deg}}},
                                   {"flexion_deg", {{"offset_deg", g.offset_deg}, {"gain_per_goniometer_deg", g.gain}}},
                                   {"source", g.source}, {"r", jsonNumber(g.r)}, {"rms_deg", jsonNumber(g.rms_deg)}, {"frames", g.frames}};
  }
  if (!r.knee_loads.at_frames.empty()) j["knee_loads"] = toJson(r.knee_loads, setup.timings);
  if (!r.muscle_loads.total.empty()) j["muscle_chain"] = toJson(r.muscle_loads, setup.timings);
  if (setup.timings) j["seconds"] = {{"ik", r.seconds_ik}, {"kinematics", r.seconds_kinematics}, {"contact_area", r.seconds_area}};
  return j;
}

}  // namespace

void addTrialOutputs(const WorkflowSetup& setup, const WorkflowInputs& in, const identify::ContactLaw& law,
                     const std::vector<TrialState>& states, AtomicFileSet& outputs) {
  const bool per_compartment = isPerCompartment(law);
  for (const TrialState& st : states) {
    const WorkflowTrialResult& r = st.result;
    const std::string dir = trialDirectory(setup, r.name);
    outputs.addContents((fs::path(dir) / (r.name + "_contact_area.sto")).string(),
                        io::formatStorage(contactAreaStorage(setup, in, r)));
    outputs.addContents((fs::path(dir) / (r.name + "_forces.sto")).string(),
                        io::formatStorage(forceStorage(law, per_compartment, st)));
    if (!r.muscle_loads.total.empty()) {
      const fs::path base = fs::path(dir) / (r.name + "_muscle");
      outputs.addContents(base.string() + "_activation.sto", io::formatStorage(r.muscle_loads.activations));
      outputs.addContents(base.string() + "_force.sto", io::formatStorage(r.muscle_loads.forces));
      outputs.addContents(base.string() + "_knee_reaction.sto", io::formatStorage(r.muscle_loads.reaction));
      if (r.knee_loads.table.getNumRows() > 0)
        outputs.addContents((fs::path(dir) / (r.name + "_knee_loads_muscles.sto")).string(),
                            io::formatStorage(makeGapLoadTable(r.knee_loads.table, r.muscle_loads)));
    }
  }
}

json makeSummary(const WorkflowSetup& setup, const WorkflowInputs& in, const identify::ContactLaw& law,
                 const std::vector<TrialState>& states, const std::vector<std::string>& plot_files,
                 const WorkflowReport& report) {
  json sj;
  sj["workflow"] = setup.name;
  sj["setup_file"] = setup.setup_file;
  sj["model_file"] = setup.model_file;
  sj["body_mass_kg"] = jsonNumber(setup.body_mass);
  sj["kinematics"] = setup.kinematics == "model"
                         ? "model: the components placed by the model at every frame"
                         : "hinge: flexion only about the fitted cylinder, seated (Dao & Pouletaut 2015)";
  json ca;
  ca["threshold_m"] = setup.contact.options.threshold;
  ca["extra_thresholds_m"] = setup.contact.options.extra_thresholds;
  ca["area_rule"] = contact::toString(setup.contact.options.rule);
  ca["distance_method"] = in.calculator->getDistanceMethod();
  ca["articular_area_m2"] = in.calculator->getArticularArea();
  ca["paper_peak_range_m2"] = {kPaperPeakLow, kPaperPeakHigh};
  sj["contact_area"] = ca;
  sj["identification"] = identificationJson(report, law);
  sj["threshold_refits"] = refitsJson(report);
  json trials = json::array();
  for (const TrialState& st : states) trials.push_back(trialJson(setup, in.flex_rot, st));
  sj["trials"] = trials;
  if (setup.muscles.on)
    sj["muscle_chain"] = {{"muscle_model_file", setup.muscles.muscle_model_file},
                          {"activation_exponent", setup.muscles.so.activation_exponent},
                          {"force_set_files", setup.muscles.force_set_files},
                          {"reserve_threshold", setup.muscles.reserve_threshold},
                          {"muscles", report.muscles_adopted},
                          {"left_out", report.muscles_left_out}};
  sj["plots"] = plot_files;
  sj["plots_problem"] = report.plots_problem;
  sj["warnings"] = report.warnings;
  if (setup.timings) sj["seconds"] = {{"total_before_writing", report.seconds_total}, {"fit", report.seconds_fit}, {"plots", report.seconds_plots}};
  return sj;
}

}  // namespace kneesim::tool::detail
