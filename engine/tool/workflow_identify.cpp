// The identification step of the knee contact workflow: the law fitted on the training trials,
// every trial predicted (window, whole trial, compartments), the agreement and errors per gait
// phase and cycle bin, and the refits at the extra thresholds.

#include <algorithm>

#include "identify/report_json.hpp"
#include "tool/workflow_detail.hpp"

namespace kneesim::tool {

LineFit fitLine(const std::vector<double>& x, const std::vector<double>& y) {
  LineFit f;
  double sx = 0, sy = 0;
  for (size_t i = 0; i < x.size() && i < y.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) {
      sx += x[i];
      sy += y[i];
      ++f.n;
    }
  if (f.n < 2) return f;
  const double mx = sx / f.n, my = sy / f.n;
  double sxx = 0, sxy = 0, syy = 0;
  for (size_t i = 0; i < x.size() && i < y.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) {
      sxx += (x[i] - mx) * (x[i] - mx);
      sxy += (x[i] - mx) * (y[i] - my);
      syy += (y[i] - my) * (y[i] - my);
    }
  if (!(sxx > 0)) return f;
  f.b = sxy / sxx;
  f.a = my - f.b * mx;
  f.r = syy > 0 ? sxy / std::sqrt(sxx * syy) : 0.0;
  double ss = 0;
  for (size_t i = 0; i < x.size() && i < y.size(); ++i)
    if (std::isfinite(x[i]) && std::isfinite(y[i])) ss += std::pow(y[i] - f.a - f.b * x[i], 2);
  f.rms = std::sqrt(ss / f.n);
  return f;
}

namespace detail {

namespace {

// Gait phases (Perry's division with the measured toe-off) of a complete cycle; stance and the rest
// with one contact; nothing otherwise.
std::vector<PhaseError> makePhases(const WorkflowTrialResult& r) {
  std::vector<PhaseError> p;
  const io::GaitCycle& c = r.cycle;
  if (c.isComplete()) {
    double to = c.getToeOffPercent();
    if (!(to > 50 && to < 100)) to = 60;  // the textbook toe-off when the plates do not show it
    const std::pair<const char*, std::pair<double, double>> parts[] = {{"loading response", {0, 10}},
                                                                       {"mid-stance", {10, 30}},
                                                                       {"terminal stance", {30, 50}},
                                                                       {"pre-swing", {50, to}},
                                                                       {"swing", {to, 100}}};
    for (const auto& [name, range] : parts) {
      PhaseError e;
      e.name = name;
      e.begin_percent = range.first;
      e.end_percent = range.second;
      e.begin = c.getTime(range.first);
      e.end = c.getTime(range.second);
      p.push_back(e);
    }
  } else if (std::isfinite(c.strike) && !r.time.empty()) {
    const double off = std::isfinite(c.toe_off) ? c.toe_off : r.time.back();
    p.push_back({"before the contact", r.time.front(), c.strike});
    p.push_back({"stance", c.strike, off});
    if (off < r.time.back()) p.push_back({"after the contact", off, r.time.back()});
  }
  return p;
}

// Error statistics of predicted vs measured over the frames of @p r inside [begin, end], and the
// fraction of them within @p tolerance (N).
void measurePhase(const WorkflowTrialResult& r, const std::vector<double>& predicted, double body_mass,
                  double tolerance, PhaseError& e) {
  std::vector<int> frames;
  const double eps = 1e-9;
  for (size_t i = 0; i < r.time.size(); ++i)
    if (r.time[i] >= e.begin - eps && r.time[i] <= e.end + eps) frames.push_back(int(i));
  identify::MetricsAccumulator acc(body_mass);
  acc.add(r.name, r.time, predicted.data(), r.forces.total.data(), frames);
  e.metrics = acc.calc();
  int good = 0;
  for (int i : frames) good += std::abs(predicted[size_t(i)] - r.forces.total[size_t(i)]) <= tolerance ? 1 : 0;
  e.agreement = frames.empty() ? kNaN : double(good) / double(frames.size());
}

// Predicts trial @p r with the fitted @p params: the window and the whole trial (and each
// compartment for a per-compartment law), the agreement and the errors per phase and cycle bin.
void predictTrial(const WorkflowSetup& setup, const identify::ContactLaw& law, const Eigen::VectorXd& params,
                  bool per_compartment, WorkflowTrialResult& r) {
  identify::FitOptions po = setup.fit;
  po.phases.clear();
  r.window_prediction = identify::predict(law, params, r.trial, po);
  identify::Trial whole = r.trial;
  whole.windows.clear();
  r.trial_prediction = identify::predict(law, params, whole, po);
  if (per_compartment) {
    for (const char* side : {"S_medial", "S_lateral"}) {
      identify::Trial one = whole;
      std::fill(one.channels[side == std::string("S_medial") ? "S_lateral" : "S_medial"].begin(),
                one.channels[side == std::string("S_medial") ? "S_lateral" : "S_medial"].end(), 0.0);
      (side == std::string("S_medial") ? r.predicted_medial : r.predicted_lateral) =
          identify::predict(law, params, one, po).predicted;
    }
  }
  // Agreement and phases, with one tolerance per trial: a fraction of the window's peak force.
  const double tolerance = setup.agreement_fraction * r.window_prediction.metrics.peak_measured;
  const std::vector<double>& pred = r.trial_prediction.predicted;
  PhaseError win;
  win.name = "window";
  win.begin = r.window_prediction.time.front();
  win.end = r.window_prediction.time.back();
  measurePhase(r, pred, setup.body_mass, tolerance, win);
  r.window_agreement = win.agreement;
  r.phases = makePhases(r);
  for (PhaseError& e : r.phases) measurePhase(r, pred, setup.body_mass, tolerance, e);
  if (r.cycle.isComplete()) {
    PhaseError cyc;
    cyc.begin = r.cycle.strike;
    cyc.end = r.cycle.next_strike;
    measurePhase(r, pred, setup.body_mass, tolerance, cyc);
    r.cycle_agreement = cyc.agreement;
    for (int b = 0; b < 10; ++b) {
      PhaseError e;
      e.name = std::to_string(10 * b) + "-" + std::to_string(10 * b + 10) + "%";
      e.begin_percent = 10 * b;
      e.end_percent = 10 * b + 10;
      e.begin = r.cycle.getTime(e.begin_percent);
      e.end = r.cycle.getTime(e.end_percent);
      measurePhase(r, pred, setup.body_mass, tolerance, e);
      r.cycle_bins.push_back(e);
    }
  }
}

// The fit at the other thresholds (the law reads S; each extra threshold's area takes its place).
void refitAtThresholds(const WorkflowSetup& setup, const identify::ContactLaw& law, const std::vector<TrialState>& states,
                       WorkflowReport& report) {
  const std::vector<std::string>& inputs = law.getInputNames();
  if (setup.threshold_sensitivity && inputs.size() == 1 && inputs[0] == "S") {
    for (double thr : setup.contact.options.extra_thresholds) {
      ThresholdRefit tr;
      tr.channel = contact::areaChannelName(thr);
      tr.threshold = thr;
      std::vector<identify::Trial> train;
      for (const TrialState& st : states)
        if (st.spec.fit) {
          train.push_back(st.result.trial);
          train.back().channels["S"] = train.back().channels.at(tr.channel);
        }
      identify::FitOptions o = setup.fit;
      o.confidence.bootstrap_samples = 0;
      o.confidence.profile = false;
      const identify::FitReport f = identify::fit(law, train, o);
      tr.solver_status = f.solver.status;
      for (const auto& d : f.derived) tr.derived[d.name] = d.value;
      for (const TrialState& st : states) {
        identify::Trial t = st.result.trial;
        t.channels["S"] = t.channels.at(tr.channel);
        tr.per_trial.emplace_back(st.spec.name, identify::predict(law, f.getValues(), t, o).metrics);
      }
      report.threshold_refits.push_back(std::move(tr));
    }
  }
}

}  // namespace

// The window of a trial from its spec and gait events; throws when the events it needs are missing.
identify::TimeWindow resolveWindow(const WorkflowTrialSpec& spec, const io::GaitCycle& c) {
  const auto need = [&](double v, const char* what) {
    if (!std::isfinite(v))
      throw InputError(spec.where, "trial '" + spec.name + "': window '" + spec.window + "' needs the " + what +
                                       ", which neither the C3D's force plates (heel marker " + spec.heel_marker +
                                       ") nor <gait_events> give");
    return v;
  };
  if (spec.window == "stance") return {need(c.strike, "heel strike"), need(c.toe_off, "toe-off")};
  if (spec.window == "cycle") return {need(c.strike, "heel strike"), need(c.next_strike, "next heel strike")};
  if (spec.window == "times") return {spec.window_begin, spec.window_end};
  return {};
}

nlohmann::json phaseJson(const PhaseError& e) {
  nlohmann::json j = identify::toJson(e.metrics);
  j["phase"] = e.name;
  j["begin_s"] = jsonNumber(e.begin);
  j["end_s"] = jsonNumber(e.end);
  j["begin_percent_of_cycle"] = jsonNumber(e.begin_percent);
  j["end_percent_of_cycle"] = jsonNumber(e.end_percent);
  j["agreement_fraction"] = jsonNumber(e.agreement);
  return j;
}

bool isPerCompartment(const identify::ContactLaw& law) {
  const std::vector<std::string>& inputs = law.getInputNames();
  return inputs.size() == 2 && std::count(inputs.begin(), inputs.end(), "S_medial") == 1 &&
         std::count(inputs.begin(), inputs.end(), "S_lateral") == 1;
}

void identifyAndPredict(const WorkflowSetup& setup, const identify::ContactLaw& law, std::vector<TrialState>& states,
                        WorkflowReport& report, const Progress& progress) {
  const auto t0 = Clock::now();
  std::vector<identify::Trial> training;
  for (const TrialState& st : states)
    if (st.spec.fit) training.push_back(st.result.trial);
  progress("fit", 0, 1);
  report.fit = identify::fit(law, training, setup.fit);
  progress("fit", 1, 1);
  const Eigen::VectorXd params = report.fit.getValues();
  // Laws on the two compartments (hertz_ml) give each compartment's share with the other's area zeroed.
  const bool per_compartment = isPerCompartment(law);
  for (TrialState& st : states) predictTrial(setup, law, params, per_compartment, st.result);
  refitAtThresholds(setup, law, states, report);
  report.seconds_fit = secondsSince(t0);
}

}  // namespace detail
}  // namespace kneesim::tool
