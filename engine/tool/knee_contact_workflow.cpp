// The knee contact workflow (tool/knee_contact_workflow.hpp): the order of its steps, from the
// inputs shared by every trial to the gap diagnoses on its outputs, and its printed summary. Each
// step is in its own workflow_*.cpp (tool/workflow_detail.hpp lists them).

#include "tool/knee_contact_workflow.hpp"

#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <tuple>

#include "core/paths.hpp"
#include "model/osim_reader.hpp"
#include "model/urdf.hpp"
#include "tool/workflow_detail.hpp"

namespace kneesim::tool {

namespace fs = std::filesystem;
using namespace detail;

namespace {

// The implant meshes, the contact-area calculator and one workspace per thread (and, for the area
// derivatives, a calculator at the main threshold only).
void readContactInputs(const WorkflowSetup& setup, WorkflowInputs& in) {
  in.meshes = readImplantMeshes(setup.contact);
  in.calculator = makeContactAreaCalculator(setup.contact, in.meshes, in.registry);
  for (int j = 0; j < std::max(1, setup.threads); ++j) in.wss.push_back(in.calculator->createWorkspace());
  if (setup.area_derivatives) {
    ContactAreaSetup ds = setup.contact;
    ds.options.extra_thresholds.clear();
    in.derivative_calculator = makeContactAreaCalculator(ds, in.meshes, in.registry);
    for (int j = 0; j < std::max(1, setup.threads); ++j)
      in.derivative_wss.push_back(in.derivative_calculator->createWorkspace());
  }
}

// The model and whether its flexion coordinate is rotational.
void readModel(const WorkflowSetup& setup, WorkflowInputs& in) {
  if (!pathExists(setup.model_file)) throw InputError({setup.setup_file, 0, "model_file"}, "model file not found: " + setup.model_file);
  in.model = endsWith(toLower(setup.model_file), ".urdf") ? model::readUrdf(setup.model_file)
                                                          : model::readOsim(setup.model_file);
  const int flex_coord = in.model->findCoordinate(setup.flexion_coordinate);
  if (flex_coord < 0)
    throw InputError({setup.setup_file, 0, "flexion_coordinate"},
                     "no coordinate '" + setup.flexion_coordinate + "' in " + setup.model_file);
  in.flex_rot = in.model->coordinates[size_t(flex_coord)].motion_type == model::MotionType::Rotational;
}

// The musculoskeletal estimate's errors over the trial and window, and the reserves that carry load.
void printMuscleLoads(const TrialMuscleLoads& m, std::ostream& os) {
  for (const ChainPhase& p : m.phases) {
    if (p.name != "trial" && p.name != "window") continue;
    os << "      muscles, " << p.name << ":";
    for (const auto& [side, fm, r] : {std::tuple{"total", &p.total, p.r_total}, std::tuple{"medial", &p.medial, p.r_medial},
                                      std::tuple{"lateral", &p.lateral, p.r_lateral}})
      os << " " << side << " RMSE " << std::setprecision(0) << fm->rmse << " N (" << std::setprecision(2) << fm->rmse_bw
         << " BW), R^2 " << fm->r2 << ", r " << r << ";";
    os << "\n";
  }
  for (const ChainReserve& r : m.reserves)
    if (!r.residual && r.frames_loaded > 0)
      os << "      reserve " << r.name << " carries load in " << r.frames_loaded << " frames (peak " << std::setprecision(1)
         << r.peak << " at " << std::setprecision(3) << r.time_of_peak << " s)\n";
  if (m.short_frames > 0) os << "      " << m.short_frames << " frames short of inverse dynamics\n";
  for (size_t i = 0; i < m.warnings.size() && i < 5; ++i) os << "      warning: " << m.warnings[i] << "\n";
}

}  // namespace

WorkflowReport runWorkflow(const WorkflowSetup& setup, const RunOptions& options) {
  const auto t_start = Clock::now();
  WorkflowReport report;
  report.name = setup.name;
  const Progress progress = [&](const std::string& what, int d, int t) {
    if (options.progress) options.progress(what, d, t);
  };

  // ---- shared inputs: meshes, contact-area calculator, law, model
  WorkflowInputs in;
  readContactInputs(setup, in);
  for (const std::string& p : setup.law_plugins) in.registry.loadPlugin(p, {setup.setup_file, 0, "ContactLaw/plugins"});
  const identify::ContactLaw law =
      identify::ContactLaw::fromRegistry(in.registry, setup.law, {setup.setup_file, 0, "ContactLaw/name"});
  report.law_description = law.getDescription();
  readModel(setup, in);
  if (setup.muscles.on) {
    in.muscle_chain = buildMuscleChainModel(setup.muscles, in.model);
    report.muscles_adopted = in.muscle_chain.adopted;
    report.muscles_left_out = in.muscle_chain.left_out;
  }

  AtomicFileSet outputs;
  std::vector<TrialState> states;
  for (const WorkflowTrialSpec& s : setup.trials) {
    states.emplace_back();
    states.back().spec = s;
  }
  // Goniometer trials last: a calibration needs its reference trial's flexion.
  std::vector<size_t> order;
  for (size_t i = 0; i < states.size(); ++i)
    if (states[i].spec.source != WorkflowTrialSpec::Source::goniometer) order.push_back(i);
  for (size_t i = 0; i < states.size(); ++i)
    if (states[i].spec.source == WorkflowTrialSpec::Source::goniometer) order.push_back(i);

  for (size_t oi : order) processTrial(setup, in, states, oi, report, outputs, progress);

  // ---- identification on the training trials, predictions, refits at the other thresholds
  identifyAndPredict(setup, law, states, report, progress);
  for (TrialState& st : states) compareTrialMuscleLoads(setup, st);

  // ---- per-trial outputs, plots (the paper's Figures 6-9), summary.json
  addTrialOutputs(setup, in, law, states, outputs);
  auto t0 = Clock::now();
  const std::vector<std::string> plot_files = makeWorkflowPlots(setup, in, law, states, report, outputs);
  report.seconds_plots = secondsSince(t0);
  report.seconds_total = secondsSince(t_start);
  report.summary_file = (fs::path(setup.results_directory) / "summary.json").string();
  outputs.addContents(report.summary_file, makeSummary(setup, in, law, states, plot_files, report).dump(2) + "\n");

  outputs.commit();
  report.outputs = outputs.getPaths();
  for (TrialState& st : states) report.trials.push_back(std::move(st.result));

  // ---- the gap diagnoses on the contact-area files just written (their own outputs, in gap/)
  t0 = Clock::now();
  for (const std::string& file : setup.gap_setup_files) {
    if (!pathExists(file)) throw InputError({setup.setup_file, 0, "gap_setup_file"}, "gap setup file not found: " + file);
    gap::GapSetup gs = gap::readGapSetup(file);
    // The areas and the knee's net loads (knee_load effect) this run just wrote.
    gap::setWorkflowResults(gs, setup.results_directory);
    // A setup that tests muscle_load reads the musculoskeletal force beside the net loads
    // (knee_muscle_total, <trial>_knee_loads_muscles.sto) in place of the net loads alone.
    if (std::find(gs.plugins.begin(), gs.plugins.end(), "muscle_load") != gs.plugins.end())
      for (gap::TrialSource& t : gs.trials)
        for (const WorkflowTrialResult& r : report.trials) {
          const fs::path dir = trialDirectory(setup, r.name);
          if (r.name == t.name && !r.muscle_loads.total.empty() && t.knee_loads == (dir / (r.name + "_knee_loads.sto")).string())
            t.knee_loads = (dir / (r.name + "_knee_loads_muscles.sto")).string();
        }
    gs.results_directory = (fs::path(setup.results_directory) / "gap" / gs.name).string();
    if (!setup.plots) gs.report.plots = false;
    progress("gap " + gs.name, 0, 1);
    report.gap.push_back(std::make_shared<const gap::GapRunResult>(gap::runGap(gs)));
    progress("gap " + gs.name, 1, 1);
  }
  report.seconds_gap = secondsSince(t0);
  report.seconds_total = secondsSince(t_start);
  return report;
}

void printWorkflowSummary(const WorkflowReport& r, std::ostream& os) {
  const auto flags = os.flags();
  const auto prec = os.precision();
  os << "Knee contact workflow '" << r.name << "': law " << r.fit.law << ", " << r.trials.size() << " trials\n";
  os << std::fixed;
  for (const WorkflowTrialResult& t : r.trials) {
    const auto& m = t.window_prediction.metrics;
    const auto& a = t.trial_prediction.metrics;
    double speak = 0;
    for (const auto& f : t.contact.frames) speak = std::max(speak, f.S);
    os << "  " << std::left << std::setw(12) << t.name << std::right << (t.fit ? " fit     " : " predict ")
       << std::setw(4) << t.time.size() << " frames, S peak " << std::setprecision(0) << speak * 1e6
       << " mm^2; window RMSE " << std::setprecision(1) << m.rmse << " N";
    if (std::isfinite(m.rmse_bw)) os << " (" << std::setprecision(3) << m.rmse_bw << " BW)";
    os << ", R^2 " << std::setprecision(3) << m.r2 << "; whole trial RMSE " << std::setprecision(1) << a.rmse << " N\n";
    for (const std::string& n : t.notes) os << "      " << n << "\n";
    for (const KneeLoadAgreement& a : t.knee_loads.agreement)
      if (a.measured == "total" && (a.load == "knee_axial_force" || a.load == "knee_flexion_moment"))
        os << "      net " << a.load.substr(5) << " vs measured total: r " << std::setprecision(3) << a.r_trial
           << " (window " << a.r_window << "), best lag " << std::setprecision(0) << 1e3 * a.lag << " ms (r "
           << std::setprecision(3) << a.r_at_lag << ")\n";
    printMuscleLoads(t.muscle_loads, os);
    for (const PhaseError& e : t.phases)
      os << "      " << std::left << std::setw(20) << e.name << std::right << " RMSE " << std::setw(7)
         << std::setprecision(1) << e.metrics.rmse << " N, bias " << std::setw(7) << e.metrics.bias
         << " N, agreeing frames " << std::setprecision(0) << 100 * e.agreement << "%\n";
  }
  os.unsetf(std::ios::fixed);
  os << std::setprecision(5);
  const auto unit = [](const std::string& u) { return u.empty() || u == "1" ? std::string() : " " + u; };
  for (const auto& p : r.fit.parameters)
    os << "  " << p.name << " = " << p.value << unit(p.unit) << " (" << identify::toString(p.status)
       << (p.value_source.empty() ? "" : ", " + p.value_source) << ")\n";
  for (const auto& d : r.fit.derived) {
    os << "  " << d.name << " = " << d.value << unit(d.unit);
    // The bootstrap when there is one (it copes with serially correlated residuals), else the
    // profile, else the asymptotic interval; all three are in summary.json.
    const identify::Interval& ci = d.ci_bootstrap.isValid() ? d.ci_bootstrap
                                   : d.ci_profile.isValid() ? d.ci_profile
                                                            : d.ci_asymptotic;
    const char* kind = d.ci_bootstrap.isValid() ? "bootstrap" : d.ci_profile.isValid() ? "profile" : "asymptotic";
    if (ci.isValid())
      os << ", " << 100 * r.fit.confidence_level << "% " << kind << " interval [" << ci.lower << ", " << ci.upper << "]";
    os << (d.identified ? "" : " (not identified)") << "\n";
  }
  for (const std::string& n : r.fit.notes) os << "  note: " << n << "\n";
  for (const ThresholdRefit& t : r.threshold_refits) {
    os << "  refit with " << t.channel << ":";
    for (const auto& [name, v] : t.derived) os << " " << name << " = " << v;
    for (const auto& [trial, m] : t.per_trial) os << "; " << trial << " RMSE " << std::setprecision(4) << m.rmse << " N";
    os << "\n";
  }
  os << std::setprecision(3) << "  time: " << r.seconds_total << " s (fit " << r.seconds_fit << " s, plots "
     << r.seconds_plots << " s)\n";
  for (const std::string& w : r.warnings) os << "  warning: " << w << "\n";
  os << "  results in " << (r.summary_file.empty() ? std::string("?") : fs::path(r.summary_file).parent_path().string())
     << " (" << r.outputs.size() << " files; summary.json, plots/)\n";
  for (const auto& g : r.gap) gap::printGapSummary(*g, os);
  if (!r.gap.empty()) os << std::setprecision(3) << "  (gap diagnoses: " << r.seconds_gap << " s)\n";
  os.flags(flags);
  os.precision(prec);
}

}  // namespace kneesim::tool
