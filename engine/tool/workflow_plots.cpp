// The plots of the knee contact workflow (drawn with gnuplot): the paper's Figures 6-8 for the
// trials with a gait cycle (flexion, contact area, compartment forces), Figure 9 per trial (measured
// and predicted force), flexion and area over time for the trials without a cycle, and each
// goniometer calibration.

#include <algorithm>
#include <filesystem>

#include "contact/contact_output.hpp"
#include "tool/plot.hpp"
#include "tool/workflow_detail.hpp"

namespace kneesim::tool::detail {

namespace fs = std::filesystem;

namespace {

// x axis of a trial's plots: percent of its gait cycle when complete, else time.
std::vector<double> plotAxis(const WorkflowTrialResult& r, bool cycle) {
  std::vector<double> x;
  for (double t : r.time) x.push_back(cycle ? r.cycle.getPercent(t) : t);
  return x;
}

const char* kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#17becf"};

// Figures 6-8: the main trials against the shared x axis, limited to the cycle with its toe-offs.
struct MainAxis {
  std::string pdir;
  bool by_cycle = false;
  std::vector<const WorkflowTrialResult*> main;  // the trials with a gait cycle, else the others
  std::string xl;

  Plot start(const std::string& name, const std::string& title, const std::string& ylabel) const {
    Plot p;
    p.file = pdir + "/" + name + ".png";
    p.title = title;
    p.xlabel = xl;
    p.ylabel = ylabel;
    return p;
  }
  void add(Plot& p, std::vector<Plot>& plots) const {
    if (by_cycle) {
      p.xmin = 0;
      p.xmax = 100;
      for (const auto* r : main)
        if (std::isfinite(r->cycle.toe_off))
          p.vlines.push_back({r->cycle.getToeOffPercent(), main.size() == 1 ? "toe-off" : "toe-off " + r->name});
    }
    plots.push_back(std::move(p));
  }
};

Plot flexionPlot(const WorkflowSetup& setup, bool flex_rot, const std::vector<TrialState>& states, const MainAxis& axis) {
  Plot p = axis.start("fig6_knee_flexion", "Knee flexion (after Dao & Pouletaut 2015, Fig. 6)",
                      setup.flexion_coordinate + (flex_rot ? " (deg)" : ""));
  int c = 0;
  for (const auto* r : axis.main) {
    std::vector<double> y;
    for (double v : r->flexion) y.push_back(flex_rot ? v / kDeg : v);
    const auto src = std::find_if(states.begin(), states.end(), [&](const TrialState& o) { return o.spec.name == r->name; })->spec.source;
    p.series.push_back({r->name + (src == WorkflowTrialSpec::Source::ik ? " (IK)"
                                   : src == WorkflowTrialSpec::Source::motion ? " (motion)"
                                                                               : " (goniometer, calibrated)"),
                        plotAxis(*r, axis.by_cycle), y, "lines", kColors[c % 7]});
    // A goniometer in degrees (spanning more than 10 units) is drawn for comparison.
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (double g : r->forces.goniometer)
      if (std::isfinite(g)) {
        lo = std::min(lo, g);
        hi = std::max(hi, g);
      }
    if (hi - lo > 10)
      p.series.push_back({r->name + " goniometer (GON)", plotAxis(*r, axis.by_cycle), r->forces.goniometer, "lines",
                          kColors[c % 7], 2, 1.5});
    ++c;
  }
  return p;
}

Plot areaPlot(const std::string& thr_label, const MainAxis& axis) {
  Plot p = axis.start("fig7_contact_area", "Implant contact area (after Dao & Pouletaut 2015, Fig. 7)",
                      "contact area (mm²)");
  int c = 0;
  for (const auto* r : axis.main) {
    const auto x = plotAxis(*r, axis.by_cycle);
    std::vector<double> y;
    for (double v : areaSeries(r->contact, -1)) y.push_back(v * 1e6);
    p.series.push_back({r->name + " S (" + thr_label + ")", x, y, "lines", kColors[c % 7]});
    for (size_t e = 0; e < r->contact.extra_thresholds.size(); ++e) {
      std::vector<double> ye;
      for (double v : areaSeries(r->contact, int(e))) ye.push_back(v * 1e6);
      p.series.push_back({r->name + " " + contact::areaChannelName(r->contact.extra_thresholds[e]), x, ye,
                          "lines", kColors[c % 7], int(e) + 2, 1.5});
    }
    ++c;
  }
  p.hlines.push_back({kPaperPeakLow * 1e6, "paper's peaks 1016-1117 mm² (4 mm)"});
  p.hlines.push_back({kPaperPeakHigh * 1e6, ""});
  return p;
}

Plot compartmentForcePlot(const MainAxis& axis) {
  Plot p = axis.start("fig8_compartment_forces",
                      "Measured compartment forces, eKnee and equation 4 (after Dao & Pouletaut 2015, Fig. 8)",
                      "force (N)");
  int c = 0;
  for (const auto* r : axis.main) {
    const auto x = plotAxis(*r, axis.by_cycle);
    p.series.push_back({r->name + " medial", x, r->forces.medial, "lines", kColors[c % 7]});
    p.series.push_back({r->name + " lateral", x, r->forces.lateral, "lines", kColors[c % 7], 2});
    ++c;
  }
  return p;
}

// Figure 9 of one trial: measured and predicted force over its window.
Plot forcePlot(const identify::ContactLaw& law, bool per_compartment, const TrialState& st, const std::string& pdir) {
  const WorkflowTrialResult& r = st.result;
  const bool rc = r.cycle.isComplete();
  const auto& m = r.window_prediction.metrics;
  Plot p;
  p.file = pdir + "/fig9_force_" + r.name + ".png";
  p.title = "Knee force, " + r.name + (r.fit ? " (fitted)" : " (predicted)") + ": RMSE " + fmt(m.rmse, 4) +
            " N" + (std::isfinite(m.rmse_bw) ? " (" + fmt(m.rmse_bw, 3) + " BW)" : "") + ", R² " +
            fmt(m.r2, 3) + " over the " + (st.spec.window == "times" ? "window" : st.spec.window);
  p.xlabel = rc ? "gait cycle (%)" : "time (s)";
  p.ylabel = "total knee force (N)";
  const auto x = plotAxis(r, rc);
  p.series.push_back({"measured (eKnee, eq. 4)", x, r.forces.total, "lines", "#000000"});
  p.series.push_back({"predicted (" + law.getName() + ")", x, r.trial_prediction.predicted, "lines", "#d62728"});
  if (per_compartment) {
    p.series.push_back({"measured medial", x, r.forces.medial, "lines", "#1f77b4", 2, 1.5});
    p.series.push_back({"predicted medial", x, r.predicted_medial, "lines", "#1f77b4", 3, 1.5});
    p.series.push_back({"measured lateral", x, r.forces.lateral, "lines", "#2ca02c", 2, 1.5});
    p.series.push_back({"predicted lateral", x, r.predicted_lateral, "lines", "#2ca02c", 3, 1.5});
  }
  if (!r.trial.windows.empty())
    for (double t : {r.trial.windows[0].begin, r.trial.windows[0].end})
      p.vlines.push_back({rc ? r.cycle.getPercent(t) : t, "window"});
  if (rc) {
    p.vlines.push_back({0.0, "heel strike"});
    p.vlines.push_back({100.0, "heel strike"});
    p.xmin = std::min(0.0, x.front());
    p.xmax = std::max(100.0, x.back());
  }
  return p;
}

// Heel strikes and toe-off on a plot against the gait cycle (nothing without a complete cycle).
void addGaitEventLines(const WorkflowTrialResult& r, Plot& p) {
  if (!r.cycle.isComplete()) return;
  p.vlines.push_back({0.0, "heel strike"});
  if (std::isfinite(r.cycle.toe_off)) p.vlines.push_back({r.cycle.getToeOffPercent(), "toe-off"});
  p.vlines.push_back({100.0, "heel strike"});
}

// The musculoskeletal knee force of one trial beside the measured forces and the contact law's.
Plot muscleLoadPlot(const WorkflowTrialResult& r, const std::string& pdir) {
  const bool rc = r.cycle.isComplete();
  Plot p = makeMuscleLoadPlot(r.muscle_loads, r.forces, r.trial_prediction.predicted, plotAxis(r, rc),
                              rc ? "gait cycle (%)" : "time (s)", r.name);
  p.file = pdir + "/fig11_muscle_knee_force_" + r.name + ".png";
  addGaitEventLines(r, p);
  return p;
}

// The knee's net loads of one trial (inverse dynamics) beside its measured forces.
Plot kneeLoadPlot(const WorkflowTrialResult& r, const std::string& pdir) {
  const bool rc = r.cycle.isComplete();
  Plot p = makeKneeLoadPlot(r.knee_loads, r.forces, plotAxis(r, rc), rc ? "gait cycle (%)" : "time (s)", r.name);
  p.file = pdir + "/fig10_knee_loads_" + r.name + ".png";
  addGaitEventLines(r, p);
  return p;
}

// A trial without a gait cycle: flexion and area over time.
Plot flexionAreaPlot(const WorkflowSetup& setup, bool flex_rot, const std::string& thr_label,
                     const WorkflowTrialResult* r, const std::string& pdir) {
  Plot p;
  p.file = pdir + "/" + r->name + "_flexion_area.png";
  p.title = r->name + ": knee flexion and contact area over time";
  p.xlabel = "time (s)";
  p.ylabel = setup.flexion_coordinate + (flex_rot ? " (deg)" : "");
  p.y2label = "contact area S (mm²)";
  std::vector<double> y, s;
  for (double v : r->flexion) y.push_back(flex_rot ? v / kDeg : v);
  for (double v : areaSeries(r->contact, -1)) s.push_back(v * 1e6);
  p.series.push_back({"flexion", r->time, y, "lines", "#1f77b4"});
  PlotSeries ss{"S (" + thr_label + ")", r->time, s, "lines", "#d62728"};
  ss.right_axis = true;
  p.series.push_back(ss);
  return p;
}

// A goniometer calibration: the reference trials' flexion against the goniometer's degrees, the
// fitted line, the goniometer's own degrees (y = x) and the calibrated trial's range.
Plot goniometerPlot(const WorkflowSetup& setup, const std::vector<TrialState>& states, const TrialState& st,
                    const std::string& pdir) {
  const io::GoniometerCalibration& cal = st.result.goniometer;
  Plot p;
  p.file = pdir + "/goniometer_calibration_" + st.spec.name + ".png";
  p.title = "Goniometer to " + setup.flexion_coordinate + ": " + fmt(cal.offset_deg, 4) + " + " + fmt(cal.gain, 4) +
            " x goniometer deg (r = " + fmt(cal.r, 4) + ", " + fmt(cal.rms_deg, 3) + " deg RMS)";
  p.xlabel = "goniometer (deg; volts x " + fmt(cal.volts_gain, 6) + " " + fmt(cal.volts_offset_deg, 6) + ")";
  p.ylabel = setup.flexion_coordinate + " (deg)";
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  int c = 0;
  for (const std::string& ref : st.spec.calibrate_on) {
    const WorkflowTrialResult& rr =
        std::find_if(states.begin(), states.end(), [&](const TrialState& o) { return o.spec.name == ref; })->result;
    const std::vector<double> g = io::toGoniometerDegrees(rr.forces.goniometer, cal);
    std::vector<double> y;
    for (double f : rr.flexion) y.push_back(f / kDeg);
    for (double v : g)
      if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
    p.series.push_back({ref + " (IK)", g, y, "points", kColors[c++ % 7], 0, 1.0});
  }
  const std::vector<double> own = io::toGoniometerDegrees(st.result.forces.goniometer, cal);
  double olo = HUGE_VAL, ohi = -HUGE_VAL;
  for (double v : own)
    if (std::isfinite(v)) olo = std::min(olo, v), ohi = std::max(ohi, v);
  lo = std::min(lo, olo);
  hi = std::max(hi, ohi);
  p.series.push_back({"fitted line", {lo, hi}, {cal.calcFlexionDeg(lo), cal.calcFlexionDeg(hi)}, "lines", "#000000"});
  p.series.push_back({"goniometer's own degrees (y = x)", {lo, hi}, {lo, hi}, "lines", "#777777", 2, 1.5});
  p.vlines.push_back({olo, st.spec.name + " range"});
  p.vlines.push_back({ohi, ""});
  return p;
}

}  // namespace

std::vector<std::string> makeWorkflowPlots(const WorkflowSetup& setup, const WorkflowInputs& in,
                                           const identify::ContactLaw& law, const std::vector<TrialState>& states,
                                           WorkflowReport& report, AtomicFileSet& outputs) {
  std::vector<std::string> plot_files;
  if (!setup.plots) return plot_files;
  const Gnuplot gp = findGnuplot(setup.gnuplot);
  if (!gp.isUsable()) {
    report.plots_problem = gp.problem;
    report.warnings.push_back("no plots: " + gp.problem);
    return plot_files;
  }
  const bool flex_rot = in.flex_rot, per_compartment = isPerCompartment(law);
  const std::string thr_label = fmt(setup.contact.options.threshold * 1e3, 4) + " mm";
  const std::string pdir = (fs::path(setup.results_directory) / "plots").string();
  std::vector<Plot> plots;
  std::vector<const WorkflowTrialResult*> cyc, other;
  for (const TrialState& st : states) (st.result.cycle.isComplete() ? cyc : other).push_back(&st.result);
  MainAxis axis;
  axis.pdir = pdir;
  axis.by_cycle = !cyc.empty();
  axis.main = axis.by_cycle ? cyc : other;
  axis.xl = axis.by_cycle ? "gait cycle (%, heel strike to heel strike, from the force plates)" : "time (s)";
  for (Plot p : {flexionPlot(setup, flex_rot, states, axis), areaPlot(thr_label, axis), compartmentForcePlot(axis)})
    axis.add(p, plots);
  for (const TrialState& st : states) plots.push_back(forcePlot(law, per_compartment, st, pdir));
  for (const TrialState& st : states)
    if (!st.result.knee_loads.at_frames.empty()) plots.push_back(kneeLoadPlot(st.result, pdir));
  for (const TrialState& st : states)
    if (!st.result.muscle_loads.total.empty()) plots.push_back(muscleLoadPlot(st.result, pdir));
  for (const auto* r : other) plots.push_back(flexionAreaPlot(setup, flex_rot, thr_label, r, pdir));
  for (const TrialState& st : states) {
    if (st.spec.source != WorkflowTrialSpec::Source::goniometer || st.spec.calibrate_on.empty() || !flex_rot) continue;
    plots.push_back(goniometerPlot(setup, states, st, pdir));
  }
  renderPlots(plots, gp, outputs, setup.plot_scripts);
  for (const Plot& p : plots) plot_files.push_back(p.file);
  return plot_files;
}

}  // namespace kneesim::tool::detail
