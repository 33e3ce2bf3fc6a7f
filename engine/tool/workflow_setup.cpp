// Reading the knee contact workflow's setup file (<KneeContactWorkflow>): the implant and model,
// the contact-area options, the trials and their kinematics sources, the contact law to identify,
// and the outputs.

#include <algorithm>
#include <filesystem>
#include <thread>

#include "core/strings.hpp"
#include "core/xml.hpp"
#include "tool/workflow_detail.hpp"

namespace kneesim::tool {

namespace fs = std::filesystem;
using namespace detail;

namespace {

double readPositive(const xml::Node& n, const std::string& what) {
  const double v = n.toDouble();
  if (!(v > 0) || !std::isfinite(v)) n.fail("expected " + what + " > 0, got " + n.text());
  return v;
}

WorkflowTrialSpec readTrial(const xml::Node& t, const std::string& dir) {
  xml::checkChildren(t, {"ik_setup_file", "motion_file", "goniometer", "knee_forces_file", "c3d_file", "heel_marker",
                    "gait_events", "window", "time_range", "fit", "id_setup_file"});
  WorkflowTrialSpec s;
  s.where = t.where();
  s.name = t.nameAttr();
  if (s.name.empty()) t.fail("expected a name attribute (<Trial name=\"ngait_og3\">)");
  for (char c : s.name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.'))
      t.fail("expected a trial name of letters, digits, '_', '-' and '.', got '" + s.name + "'");
  s.fit = t.childBool("fit", false);
  int sources = 0;
  if (xml::Node n = t.child("ik_setup_file")) {
    ++sources;
    s.source = WorkflowTrialSpec::Source::ik;
    s.ik_setup_file = xml::resolvePath(dir, n.text());
  }
  if (xml::Node n = t.child("motion_file")) {
    ++sources;
    s.source = WorkflowTrialSpec::Source::motion;
    s.motion_file = xml::resolvePath(dir, n.text());
  }
  if (xml::Node g = t.child("goniometer")) {
    ++sources;
    s.source = WorkflowTrialSpec::Source::goniometer;
    xml::checkChildren(g, {"scale", "offset_deg", "calibrate_on", "units", "volts_to_degrees"});
    s.calibrate_on = g.child("calibrate_on") ? g.child("calibrate_on").toWords() : std::vector<std::string>{};
    if (!s.calibrate_on.empty() && (g.child("scale") || g.child("offset_deg")))
      g.fail("expected either <calibrate_on> or <scale>/<offset_deg>, got both");
    io::GoniometerCalibration& c = s.goniometer;
    if (g.child("scale") || g.child("offset_deg")) {
      c.gain = g.childDouble("scale", 1.0);
      c.offset_deg = g.childDouble("offset_deg", 0.0);
      c.source = "given in the setup";
    }
    if (!std::isfinite(c.gain) || !std::isfinite(c.offset_deg)) g.fail("expected a finite scale and offset");
    c.units = g.childText("units", "auto");
    if (c.units != "auto" && c.units != "volts" && c.units != "degrees")
      g.child("units").fail("expected auto, volts or degrees, got '" + c.units + "'");
    if (xml::Node v = g.child("volts_to_degrees")) {
      const auto w = v.toDoubles();
      if (w.size() != 2 || !std::isfinite(w[0]) || !std::isfinite(w[1]))
        v.fail("expected 'degrees_per_volt offset_deg', got '" + v.text() + "'");
      c.volts_gain = w[0];
      c.volts_offset_deg = w[1];
    }
  }
  if (sources != 1)
    t.fail("expected exactly one kinematics source (ik_setup_file, motion_file or goniometer), got " +
           std::to_string(sources));
  if (xml::Node n = t.child("id_setup_file")) {
    if (s.source == WorkflowTrialSpec::Source::goniometer)
      n.fail("expected a trial with ik_setup_file or motion_file (inverse dynamics needs every coordinate), got a goniometer");
    s.id_setup_file = xml::resolvePath(dir, n.text());
  }
  s.knee_forces_file = xml::resolvePath(dir, t.requireChild("knee_forces_file").text());
  if (s.knee_forces_file.empty()) t.fail("expected a knee_forces_file");
  s.c3d_file = xml::resolvePath(dir, t.childText("c3d_file"));
  s.heel_marker = t.childText("heel_marker", "RHeel");
  if (xml::Node n = t.child("gait_events")) {
    s.gait_events = n.toDoubles();
    if (s.gait_events.size() != 3)
      n.fail("expected three times 'strike toe_off next_strike' in seconds (NaN for an unknown one), got '" +
             n.text() + "'");
  }
  if (xml::Node n = t.child("window")) {
    const std::string w = n.text();
    if (w == "stance" || w == "cycle" || w == "trial") {
      s.window = w;
    } else {
      const std::vector<double> v = n.toDoubles();
      if (v.size() != 2 || !(v[0] <= v[1]))
        n.fail("expected 'stance', 'cycle', 'trial' or 'begin end' in seconds, got '" + w + "'");
      s.window = "times";
      s.window_begin = v[0];
      s.window_end = v[1];
    }
  }
  if (xml::Node n = t.child("time_range")) {
    const auto r = n.toDoubles();
    if (r.size() != 2 || !(r[0] <= r[1])) n.fail("expected 'start end' in seconds with start <= end, got '" + n.text() + "'");
    s.time_start = r[0];
    s.time_end = r[1];
  }
  return s;
}

void readLaw(const xml::Node& l, WorkflowSetup& s) {
  xml::checkChildren(l, {"plugins", "name", "free_parameters", "parameter", "bounds", "assumed", "confidence_level",
                    "bootstrap_samples", "bootstrap_mode", "profile"});
  if (xml::Node n = l.child("plugins")) s.law_plugins = n.toWords();
  s.law = l.childText("name", "hertz");
  if (xml::Node n = l.child("free_parameters")) s.fit.free_parameters = n.toWords();
  for (const xml::Node& p : l.children("parameter")) {
    if (p.nameAttr().empty()) p.fail("expected a name attribute (<parameter name=\"R\">0.037</parameter>)");
    s.fit.parameter_values[p.nameAttr()] = p.toDouble();
  }
  for (const xml::Node& b : l.children("bounds")) {
    const auto v = b.toDoubles();
    if (b.nameAttr().empty() || v.size() != 2) b.fail("expected <bounds name=\"E\">lower upper</bounds>");
    s.fit.bounds[b.nameAttr()] = {v[0], v[1]};
  }
  for (const xml::Node& a : l.children("assumed")) {
    if (a.nameAttr().empty()) a.fail("expected a name attribute (<assumed name=\"nu\">0.45</assumed>)");
    s.fit.assumed_values[a.nameAttr()] = a.toDouble();
  }
  s.fit.confidence.level = l.childDouble("confidence_level", 0.95);
  if (xml::Node n = l.child("bootstrap_samples")) {
    const long b = n.toInt();
    if (b < 0 || b > 100000) n.fail("expected 0..100000 bootstrap samples, got " + n.text());
    s.fit.confidence.bootstrap_samples = int(b);
  }
  s.fit.confidence.bootstrap_mode = l.childText("bootstrap_mode", "frames");
  if (s.fit.confidence.bootstrap_mode != "frames" && s.fit.confidence.bootstrap_mode != "trials")
    l.child("bootstrap_mode").fail("expected 'frames' or 'trials', got " + s.fit.confidence.bootstrap_mode);
  s.fit.confidence.profile = l.childBool("profile", true);
}

// The <Trial> elements (unique names, at least one to fit, calibrations naming trials with IK or a
// motion).
void readTrials(const xml::Node& tool, const std::string& dir, WorkflowSetup& s) {
  for (const xml::Node& t : tool.children("Trial")) {
    s.trials.push_back(readTrial(t, dir));
    for (size_t k = 0; k + 1 < s.trials.size(); ++k)
      if (s.trials[k].name == s.trials.back().name) t.fail("expected unique trial names, got '" + s.trials[k].name + "' twice");
  }
  if (s.trials.empty()) tool.fail("expected at least one <Trial>, got none");
  if (std::none_of(s.trials.begin(), s.trials.end(), [](const WorkflowTrialSpec& t) { return t.fit; }))
    tool.fail("expected at least one trial with <fit>true</fit> to identify the law on, got none");
  for (const WorkflowTrialSpec& t : s.trials)
    for (const std::string& ref : t.calibrate_on) {
      const auto it = std::find_if(s.trials.begin(), s.trials.end(),
                                   [&](const WorkflowTrialSpec& o) { return o.name == ref; });
      if (it == s.trials.end() || it->source == WorkflowTrialSpec::Source::goniometer)
        throw InputError(t.where, "trial '" + t.name + "': <calibrate_on> names '" + ref +
                                      "', expected a trial of this setup whose kinematics come from IK or a motion");
    }
}

}  // namespace

WorkflowSetup readWorkflowSetup(const std::string& path) {
  const auto [doc, dir, tool] = xml::openSetupFile(
      path, "KneeContactWorkflow",
      {"model_file", "femoral_component_file", "insert_file", "mesh_scale", "femoral_body", "insert_body",
       "femoral_mesh", "insert_mesh", "threshold", "extra_thresholds", "area_rule", "distance_provider", "plugins",
       "kinematics", "flexion_coordinate", "seating_grid_deg", "body_mass", "Trial", "ContactLaw",
       "threshold_sensitivity", "agreement_fraction", "results_directory", "plots", "gnuplot", "plot_scripts",
       "threads", "area_derivatives", "flexion_step_deg", "flexion_step", "ap_step", "gap_setup_file", "timings",
       "MuscleChain"});
  WorkflowSetup s;
  s.setup_file = path;
  if (!tool.nameAttr().empty()) s.name = tool.nameAttr();
  s.fit.where = tool.where();
  s.model_file = xml::resolvePath(dir, tool.requireChild("model_file").text());
  ContactAreaSetup& c = s.contact;
  c.setup_file = path;
  c.name = s.name;
  c.use_model = true;
  c.femur_file = xml::resolvePath(dir, tool.requireChild("femoral_component_file").text());
  c.insert_file = xml::resolvePath(dir, tool.requireChild("insert_file").text());
  if (xml::Node n = tool.child("mesh_scale")) c.mesh_scale = readPositive(n, "a mesh scale");
  c.model.model_file = s.model_file;
  c.model.femoral_body = tool.childText("femoral_body", "femoral_component");
  c.model.insert_body = tool.childText("insert_body", "tibial_component");
  c.model.femoral_mesh = tool.childText("femoral_mesh");
  c.model.insert_mesh = tool.childText("insert_mesh");
  c.model.where = tool.where();
  if (xml::Node n = tool.child("threshold")) c.options.threshold = readPositive(n, "a threshold (m)");
  if (xml::Node n = tool.child("extra_thresholds"))
    for (double t : n.toDoubles()) {
      if (!(t > 0) || !std::isfinite(t)) n.fail("expected thresholds > 0 (m), got " + n.text());
      c.options.extra_thresholds.push_back(t);
    }
  if (xml::Node n = tool.child("area_rule")) c.options.rule = contact::parseAreaRule(n.text(), n.where());
  readDistanceProvider(tool, c);
  s.kinematics = tool.childText("kinematics", "model");
  if (s.kinematics != "model" && s.kinematics != "hinge")
    tool.child("kinematics").fail("expected 'model' or 'hinge', got '" + s.kinematics + "'");
  s.flexion_coordinate = tool.childText("flexion_coordinate", "knee_flexion");
  c.hinge.seating_grid = 2.0 * kDeg;
  if (xml::Node n = tool.child("seating_grid_deg")) {
    const double g = n.toDouble();
    if (!(g >= 0 && g <= 30)) n.fail("expected a grid spacing of 0 (seat every frame) to 30 degrees, got " + n.text());
    c.hinge.seating_grid = g * kDeg;
  }
  c.hinge.where = tool.where();
  if (xml::Node n = tool.child("body_mass")) s.body_mass = readPositive(n, "a body mass (kg)");
  s.area_derivatives = tool.childBool("area_derivatives", false);
  if (xml::Node n = tool.child("flexion_step_deg")) {
    const double d = n.toDouble();
    if (!(d > 0 && d <= 5)) n.fail("expected a flexion step in (0, 5] degrees, got " + n.text());
    s.flexion_step = d * kDeg;
  }
  if (xml::Node n = tool.child("flexion_step")) {
    if (tool.child("flexion_step_deg")) n.fail("expected <flexion_step> or <flexion_step_deg>, got both");
    s.flexion_step = n.toDouble();
    if (!(s.flexion_step > 0) || !std::isfinite(s.flexion_step))
      n.fail("expected a step > 0 in the flexion coordinate's SI unit, got " + n.text());
  }
  if (xml::Node n = tool.child("ap_step")) {
    const double d = n.toDouble();
    if (!(d > 0 && d <= 2e-3)) n.fail("expected an AP step in (0, 0.002] m, got " + n.text());
    s.ap_step = d;
  }
  if (xml::Node n = tool.child("MuscleChain")) s.muscles = readMuscleChainSetup(n, dir);
  if (xml::Node n = tool.child("gap_setup_file"))
    for (const std::string& f : n.toWords()) s.gap_setup_files.push_back(xml::resolvePath(dir, f));
  s.fit.body_mass = s.body_mass;
  readTrials(tool, dir, s);
  if (xml::Node l = tool.child("ContactLaw")) readLaw(l, s);
  s.threshold_sensitivity = tool.childBool("threshold_sensitivity", true);
  if (xml::Node n = tool.child("agreement_fraction")) {
    s.agreement_fraction = n.toDouble();
    if (!(s.agreement_fraction > 0 && s.agreement_fraction < 1)) n.fail("expected a fraction in (0, 1), got " + n.text());
  }
  std::string results = tool.childText("results_directory");
  if (results.empty()) results = ".";
  s.results_directory = xml::resolvePath(dir, results);
  c.results_directory = s.results_directory;
  s.plots = tool.childBool("plots", true);
  s.gnuplot = tool.childText("gnuplot", "gnuplot");
  s.plot_scripts = tool.childBool("plot_scripts", true);
  s.timings = tool.childBool("timings", true);
  if (xml::Node n = tool.child("threads")) {
    const long t = n.toInt();
    if (t < 0 || t > 64) n.fail("expected 0 (one per core, at most 4) to 64 threads, got " + n.text());
    s.threads = int(t);
  }
  if (s.threads == 0) s.threads = int(std::clamp(std::thread::hardware_concurrency(), 1u, 4u));
  return s;
}

}  // namespace kneesim::tool
