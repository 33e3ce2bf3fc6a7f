#include "gap/tool.hpp"

#include <filesystem>
#include <set>

#include "core/paths.hpp"
#include "core/strings.hpp"
#include "io/storage.hpp"
#include "core/xml.hpp"
#include "plugin/registry.hpp"

namespace kneesim::gap {

namespace {

namespace fs = std::filesystem;

// "name value name value ..." into a map; fails on an odd count or a non-number.
std::map<std::string, double> pairs(const xml::Node& n) {
  std::map<std::string, double> m;
  const auto w = n.toWords();
  if (w.size() % 2) n.fail("expected pairs of a parameter name and a value, got " + std::to_string(w.size()) + " words");
  for (size_t k = 0; k < w.size(); k += 2) {
    double v;
    if (!tryParseDouble(w[k + 1], v)) n.fail("expected a number after '" + w[k] + "', got '" + w[k + 1] + "'");
    m[w[k]] = v;
  }
  return m;
}

// The contact-area file a KneeContactWorkflow writes for trial @p name under @p dir.
std::string workflowAreaFile(const std::string& dir, const std::string& name) {
  return (fs::path(dir) / name / (name + "_contact_area.sto")).string();
}

// The trial's knee net loads from the workflow's inverse dynamics (<dir>/<name>/<name>_knee_loads.sto),
// where the workflow wrote them (trials with an id_setup_file) and the setup names none: the knee_load
// effect's channels, in a standalone diagnosis as in the workflow's own.
void useWorkflowKneeLoads(TrialSource& t, const std::string& dir) {
  const fs::path f = fs::path(dir) / t.name / (t.name + "_knee_loads.sto");
  std::error_code ec;  // a name too long for the system is not there either (not a filesystem_error)
  if (t.knee_loads.empty() && fs::is_regular_file(f, ec)) t.knee_loads = f.string();
}

TrialSource readTrial(const xml::Node& t, const std::string& dir) {
  static const std::set<std::string> known = {"knee_forces", "contact_area",   "c3d",        "kinematics",
                                              "flexion_column", "flexion_source", "events", "event_times",
                                              "time_range",  "gon_calibration", "grf_from_knee_forces", "knee_loads"};
  for (const xml::Node& c : t.children())
    if (!known.count(c.name()))
      c.fail("unknown element <" + c.name() + "> in Trial (expected one of " + join(known, ", ") + ")");
  TrialSource s;
  s.where = t.where();
  s.name = t.nameAttr();
  if (s.name.empty()) t.fail("expected a name attribute on <Trial>");
  s.activity = t.attr("activity").value_or("gait");
  s.knee_forces = xml::resolvePath(dir, t.childText("knee_forces"));
  s.contact_area = xml::resolvePath(dir, t.childText("contact_area"));
  s.c3d = xml::resolvePath(dir, t.childText("c3d"));
  s.kinematics = xml::resolvePath(dir, t.childText("kinematics"));
  s.knee_loads = xml::resolvePath(dir, t.childText("knee_loads"));
  s.flexion_column = t.childText("flexion_column", s.flexion_column);
  s.flexion_source = t.childText("flexion_source", s.flexion_source);
  s.events = t.childText("events", s.events);
  if (xml::Node e = t.child("event_times"); e && !e.text().empty()) s.event_times = e.toDoubles();
  if (xml::Node r = t.child("time_range"); r && !r.text().empty()) {
    const auto v = r.toDoubles();
    if (v.size() != 2 || !(v[0] < v[1])) r.fail("expected two increasing times (start end), got '" + r.text() + "'");
    s.time_range = {v[0], v[1]};
  }
  if (xml::Node g = t.child("grf_from_knee_forces"); g && !g.text().empty()) {
    s.knee_forces_grf_scale = g.toDouble();
    if (!(s.knee_forces_grf_scale > 0) || !std::isfinite(s.knee_forces_grf_scale))
      g.fail("expected newtons per unit of the GRFz column (> 0; JW: 2000), got " + g.text());
  }
  if (xml::Node g = t.child("gon_calibration"); g && !g.text().empty()) {
    const auto v = g.toDoubles();
    if (v.size() != 2)
      g.fail("expected 2 numbers (gain of the knee flexion per goniometer degree, offset in degrees), got " +
             std::to_string(v.size()));
    s.goniometer.gain = v[0];
    s.goniometer.offset_deg = v[1];
    s.goniometer.source = "given in the setup";
  }
  return s;
}

}  // namespace

GapSetup readGapSetup(const std::string& path) {
  auto doc = xml::Document::load(path);
  xml::Node root = doc->root();
  xml::Node tool = root;
  if (root.name() == "OpenSimDocument") tool = root.child("GapTool");
  if (!tool || tool.name() != "GapTool") root.fail("expected a <GapTool> element, got <" + root.name() + ">");
  const std::string dir = fs::path(path).parent_path().string();
  static const std::set<std::string> known = {
      "results_directory", "plugins",     "law",          "free_parameters", "assumed_values", "parameter_values",
      "effects",           "targets",     "body_mass",    "cv_folds",        "screen_top",     "max_effects",
      "alpha",             "structure_alpha", "min_relative_improvement", "confidence_level", "bootstrap_samples",
      "prewhiten_order",   "alternative_baselines", "compared_effects",
      "plots",             "emg_flexors", "emg_extensors", "trials", "workflow_results"};
  for (const xml::Node& c : tool.children())
    if (!known.count(c.name()))
      c.fail("unknown element <" + c.name() + "> in GapTool (expected one of " + join(known, ", ") + ")");
  GapSetup s;
  s.setup_file = path;
  s.name = tool.nameAttr().empty() ? "gap" : tool.nameAttr();
  s.results_directory = xml::resolvePath(dir, tool.childText("results_directory", s.name + "_results"));
  if (xml::Node p = tool.child("plugins")) s.plugins = p.toWords();
  s.law = tool.childText("law", s.law);
  s.workflow_results = xml::resolvePath(dir, tool.childText("workflow_results"));
  if (xml::Node e = tool.child("effects")) {
    s.effects = e.toWords();
    if (s.effects.size() == 1 && s.effects[0] == "all") s.effects.clear();
  }
  DiagnosisOptions& o = s.options;
  o.fit.where = tool.where();
  if (xml::Node f = tool.child("free_parameters")) o.fit.free_parameters = f.toWords();
  if (xml::Node a = tool.child("assumed_values")) o.fit.assumed_values = pairs(a);
  if (xml::Node v = tool.child("parameter_values")) o.fit.parameter_values = pairs(v);
  if (xml::Node t = tool.child("targets")) {
    o.targets = t.toWords();
    for (const auto& target : o.targets)
      if (const std::string why = findTargetProblem(target); !why.empty()) t.fail(why);
  }
  if (xml::Node a = tool.child("alternative_baselines")) o.alternative_baselines = a.toWords();
  if (xml::Node c = tool.child("compared_effects")) o.compared_effects = c.toWords();
  o.fit.body_mass = tool.childDouble("body_mass", 0.0);
  if (!(o.fit.body_mass >= 0)) tool.child("body_mass").fail("expected a mass >= 0 kg");
  auto integer = [&](const char* tag, int fallback, int lo) {
    xml::Node n = tool.child(tag);
    if (!n || n.text().empty()) return fallback;
    return n.toIntIn(lo);
  };
  auto fraction = [&](const char* tag, double fallback) {
    xml::Node n = tool.child(tag);
    if (!n || n.text().empty()) return fallback;
    const double v = n.toDouble();
    if (!(v > 0 && v < 1)) n.fail("expected a value in (0, 1), got " + n.text());
    return v;
  };
  o.cv_folds = integer("cv_folds", 0, 0);
  if (o.cv_folds == 1) tool.child("cv_folds").fail("expected 0 (leave one cycle out) or at least 2 folds, got 1");
  o.screen_top = integer("screen_top", o.screen_top, 1);
  o.max_effects = integer("max_effects", o.max_effects, 0);
  o.prewhiten_order = integer("prewhiten_order", o.prewhiten_order, -1);
  if (o.prewhiten_order > 10)
    tool.child("prewhiten_order")
        .fail("expected -1 (by BIC), 0 (none) or an order up to 10, got " + tool.child("prewhiten_order").text());
  o.alpha = fraction("alpha", o.alpha);
  o.structure_alpha = fraction("structure_alpha", o.structure_alpha);
  o.min_relative_improvement = fraction("min_relative_improvement", o.min_relative_improvement);
  o.level = fraction("confidence_level", o.level);
  o.fit.confidence.level = o.level;
  o.fit.confidence.bootstrap_samples = integer("bootstrap_samples", o.fit.confidence.bootstrap_samples, 0);
  s.report.plots = tool.childBool("plots", true);
  TrialSource defaults;
  const auto flexors = tool.child("emg_flexors") ? tool.child("emg_flexors").toWords() : defaults.emg_flexors;
  const auto extensors = tool.child("emg_extensors") ? tool.child("emg_extensors").toWords() : defaults.emg_extensors;
  xml::Node trials = tool.child("trials");
  if (!trials) tool.fail("missing <trials>");
  for (const xml::Node& t : trials.children()) {
    if (t.name() != "Trial") t.fail("unknown element <" + t.name() + "> in trials (expected Trial)");
    TrialSource ts = readTrial(t, dir);
    if (ts.contact_area.empty() && s.workflow_results.empty())
      t.fail("missing <contact_area> (the contact-area tool's .sto for this trial) and no <workflow_results>");
    ts.emg_flexors = flexors;
    ts.emg_extensors = extensors;
    s.trials.push_back(ts);
  }
  if (s.trials.empty()) trials.fail("expected at least one <Trial>, got none");
  if (!s.workflow_results.empty())
    for (auto& t : s.trials) {
      if (t.contact_area.empty()) t.contact_area = workflowAreaFile(s.workflow_results, t.name);
      useWorkflowKneeLoads(t, s.workflow_results);
    }
  return s;
}

void setWorkflowResults(GapSetup& setup, const std::string& directory) {
  // Knee loads read from the setup's own <workflow_results> follow the folder given now.
  const std::string before = setup.workflow_results;
  setup.workflow_results = directory;
  for (auto& t : setup.trials) {
    t.contact_area = workflowAreaFile(directory, t.name);
    if (!before.empty() && t.knee_loads == (fs::path(before) / t.name / (t.name + "_knee_loads.sto")).string())
      t.knee_loads.clear();
    useWorkflowKneeLoads(t, directory);
  }
}

void setContactAreaDirectory(GapSetup& setup, const std::string& directory) {
  for (auto& t : setup.trials) t.contact_area = (fs::path(directory) / fs::path(t.contact_area).filename()).string();
}

GapRunResult runGap(const GapSetup& s, const std::function<void(const std::string&)>& log) {
  auto say = [&](const std::string& m) {
    if (log) log(m);
  };
  plugin::Registry registry;
  const SourceLocation where{s.setup_file, 0, "GapTool/plugins"};
  for (const auto& p : s.plugins) registry.loadPlugin(p, where);
  const identify::ContactLaw law = identify::ContactLaw::fromRegistry(registry, s.law, {s.setup_file, 0, "GapTool/law"});
  std::vector<Effect> catalogue;
  const std::vector<std::string> names = s.effects.empty() ? registry.getEffectNames() : s.effects;
  for (const auto& n : names) catalogue.push_back(Effect::fromRegistry(registry, n, {s.setup_file, 0, "GapTool/effects"}));
  std::vector<GapTrial> trials;
  for (const auto& t : s.trials) {
    if (t.knee_forces.empty())
      throw InputError(t.where, "trial '" + t.name + "': the diagnosis needs measured knee forces (<knee_forces>), got "
                                "none (a trial without them can be predicted: kneesim gap --predict gap_model.json)");
    say("assembling trial " + t.name);
    trials.push_back(assembleTrial(t));
  }
  GapRunResult res;
  std::map<std::string, double> emg_peaks;
  res.dead_emg = normalizeEmg(trials, s.trials.front().emg_flexors, s.trials.front().emg_extensors, nullptr, &emg_peaks);
  say("diagnosing " + std::to_string(trials.size()) + " trial(s) against " + std::to_string(catalogue.size()) +
      " effect(s)");
  res.report = diagnose(law, catalogue, trials, s.options);
  res.report.setup_file = s.setup_file;
  res.report.plugins = s.plugins;
  res.report.emg_peaks = emg_peaks;
  for (const auto& g : trials)
    for (const auto& n : g.notes) res.report.notes.push_back(g.trial.name + ": " + n);
  if (!res.dead_emg.empty()) {
    res.report.notes.push_back("EMG channels dropped as dead (peak-to-peak below 0.1 V in some trial): " +
                               join(res.dead_emg, ", "));
  }
  res.directory = s.results_directory;
  say("writing the report into " + res.directory);
  res.files = writeGapReport(res.directory, res.report, s.report);
  return res;
}

PredictRunResult runPredict(const GapSetup& s, const std::string& model_path,
                            const std::function<void(const std::string&)>& log) {
  auto say = [&](const std::string& m) {
    if (log) log(m);
  };
  PredictRunResult res;
  res.model = readGapModel(model_path);
  plugin::Registry registry;
  for (const auto& p : res.model.plugins) registry.loadPlugin(p, {model_path, 0, "plugins"});
  std::vector<GapTrial> trials;
  for (const auto& t : s.trials) {
    say("assembling trial " + t.name);
    trials.push_back(assembleTrial(t));
  }
  normalizeEmg(trials, s.trials.front().emg_flexors, s.trials.front().emg_extensors, &res.model.emg_peaks);
  res.predictions = predictTrials(res.model, registry, trials, model_path);
  res.directory = s.results_directory;
  say("writing the predictions into " + res.directory);
  createFolder(res.directory);
  for (const auto& p : res.predictions) {
    io::writeStorage(res.directory + "/" + p.trial + "_predicted.sto", toStorage(p));
    res.files.push_back(p.trial + "_predicted.sto");
  }
  return res;
}

void printPredictSummary(const PredictRunResult& r, std::ostream& out) {
  out << "gap model " << r.model.law << " (fitted on " << join(r.model.trials, ", ") << ") predicting "
      << r.predictions.size() << " trial(s)\n";
  for (const auto& t : r.model.targets)
    out << "  " << t.target << ": " << t.law << " (" << (t.verdict_class.empty() ? "?" : t.verdict_class) << ")\n";
  for (const auto& p : r.predictions) {
    out << "  " << p.trial << ": " << p.time.size() << " frames";
    for (const auto& [target, e] : p.rmse) out << "; " << target << " RMSE against its measured force " << e << " N";
    out << "\n";
  }
  out << "  predictions: " << r.directory << "/<trial>_predicted.sto\n";
}

void printGapSummary(const GapRunResult& r, std::ostream& out) {
  if (r.report.interim_inputs) out << "INTERIM INPUTS - not a real-data result\n";
  out << "gap diagnosis of " << r.report.law << " on " << r.report.trials.size() << " trial(s), " << r.report.cycles
      << " cycles (" << r.report.cv_scheme << ")\n";
  const double bwN = r.report.body_mass * identify::kStandardGravity;
  for (const auto& d : r.report.targets) {
    out << "  " << d.target << ": " << d.verdict << "; withheld RMSE " << d.baseline_rmse_heldout << " N";
    if (bwN > 0) out << " (" << d.baseline_rmse_heldout / bwN << " BW)";
    if (!d.shrinkage.empty()) out << " -> " << d.shrinkage[0].rmse_final << " N with " << d.final_law;
    out << "\n";
  }
  out << "  report: " << r.directory << "/gap_report.md (and gap_report.json)\n";
}

}  // namespace kneesim::gap
