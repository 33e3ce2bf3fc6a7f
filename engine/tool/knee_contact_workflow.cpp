#include "tool/knee_contact_workflow.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "contact/contact_output.hpp"
#include "core/atomic_file.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "identify/report_json.hpp"
#include "ik/tool.hpp"
#include "io/c3d.hpp"
#include "io/storage.hpp"
#include "model/osim_reader.hpp"
#include "model/urdf.hpp"
#include "tool/plot.hpp"

namespace kneesim::tool {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kDeg = M_PI / 180.0;
// Dao & Pouletaut 2015, section 3.3: peak contact areas of the five gaits.
constexpr double kPaperPeakLow = 1016e-6, kPaperPeakHigh = 1117e-6;

std::string fmt(double v, int digits = 6) { return formatSignificant(v, digits); }

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

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

}  // namespace

WorkflowSetup readWorkflowSetup(const std::string& path) {
  auto doc = xml::Document::load(path);
  WorkflowSetup s;
  s.setup_file = path;
  const std::string dir = fs::path(path).parent_path().string();
  const xml::Node tool = xml::requireSetupElement(*doc, "KneeContactWorkflow");
  if (!tool.nameAttr().empty()) s.name = tool.nameAttr();
  xml::checkChildren(tool, {"model_file", "femoral_component_file", "insert_file", "mesh_scale", "femoral_body",
                       "insert_body", "femoral_mesh", "insert_mesh", "threshold", "extra_thresholds", "area_rule",
                       "distance_provider", "plugins", "kinematics", "flexion_coordinate", "seating_grid_deg",
                       "body_mass", "Trial", "ContactLaw", "threshold_sensitivity", "agreement_fraction",
                       "results_directory", "plots", "gnuplot", "plot_scripts", "threads", "area_derivatives",
                       "flexion_step_deg", "flexion_step", "ap_step", "gap_setup_file", "timings"});
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
  c.distance_provider = tool.childText("distance_provider", "fcl");
  if (xml::Node n = tool.child("plugins"))
    c.plugins = n.toWords();
  else if (startsWith(c.distance_provider, "fcl"))
    c.plugins.push_back("distance_fcl");
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
  if (xml::Node n = tool.child("gap_setup_file"))
    for (const std::string& f : n.toWords()) s.gap_setup_files.push_back(xml::resolvePath(dir, f));
  s.fit.body_mass = s.body_mass;
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

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Linear interpolation of column @p col of @p st at time @p t (held at the ends).
double interpolateColumn(const io::Storage& st, int col, double t) {
  const int n = st.getNumRows();
  if (n == 0) return kNaN;
  if (t <= st.data(0, 0)) return st.data(0, col);
  if (t >= st.data(n - 1, 0)) return st.data(n - 1, col);
  int hi = 1;
  while (st.data(hi, 0) < t) ++hi;
  const double a = (t - st.data(hi - 1, 0)) / (st.data(hi, 0) - st.data(hi - 1, 0));
  return (1 - a) * st.data(hi - 1, col) + a * st.data(hi, col);
}

template <class T>
std::vector<T> subset(const std::vector<T>& v, const std::vector<int>& keep) {
  std::vector<T> out;
  out.reserve(keep.size());
  for (int i : keep) out.push_back(v[size_t(i)]);
  return out;
}

io::KneeForces subsetForces(const io::KneeForces& f, const std::vector<int>& keep) {
  io::KneeForces o = f;
  for (auto* v : {&o.time, &o.am, &o.pm, &o.al, &o.pl, &o.medial, &o.lateral, &o.total, &o.goniometer, &o.grfz})
    if (v->size() == f.time.size()) *v = subset(*v, keep);
  return o;
}

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

json metricsJson(const identify::FitMetrics& m) { return identify::toJson(m); }

json phaseJson(const PhaseError& e) {
  json j = metricsJson(e.metrics);
  j["phase"] = e.name;
  j["begin_s"] = num(e.begin);
  j["end_s"] = num(e.end);
  j["begin_percent_of_cycle"] = num(e.begin_percent);
  j["end_percent_of_cycle"] = num(e.end_percent);
  j["agreement_fraction"] = num(e.agreement);
  return j;
}

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

std::vector<double> areaSeries(const contact::ContactSeries& s, int extra) {
  std::vector<double> v;
  for (const auto& f : s.frames) v.push_back(extra < 0 ? f.S : f.S_extra[size_t(extra)]);
  return v;
}

// x axis of a trial's plots: percent of its gait cycle when complete, else time.
std::vector<double> plotAxis(const WorkflowTrialResult& r, bool cycle) {
  std::vector<double> x;
  for (double t : r.time) x.push_back(cycle ? r.cycle.getPercent(t) : t);
  return x;
}

const char* kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#17becf"};

// The contact series of @p X_IF with one thread per workspace, each on a contiguous block of
// frames (so a coherent distance provider keeps its warm starts within a block).
contact::ContactSeries calcSeriesInParallel(const contact::ContactAreaCalculator& calculator,
                                            std::vector<std::unique_ptr<contact::ContactAreaWorkspace>>& wss,
                                            const std::vector<double>& time,
                                            const std::vector<Eigen::Isometry3d>& X_IF,
                                            const std::function<void(int, int)>& progress) {
  contact::ContactSeries series;
  series.time = time;
  series.extra_thresholds = calculator.getOptions().extra_thresholds;
  const size_t n = X_IF.size();
  series.frames.resize(n);
  for (auto& f : series.frames) f.S_extra.resize(series.extra_thresholds.size());
  const size_t threads = std::max<size_t>(1, std::min(wss.size(), n / 16));
  const size_t block = (n + threads - 1) / threads;
  std::vector<std::exception_ptr> errors(threads);
  const auto work = [&](size_t j) {
    try {
      const size_t begin = j * block, end = std::min(n, begin + block);
      for (size_t k = begin; k < end; ++k) {
        calculator.calcFrame(*wss[j], X_IF[k], series.frames[k]);
        // Only the first thread reports, scaled to the whole.
        if (j == 0 && progress && ((k - begin) % 10 == 9 || k + 1 == end))
          progress(int(std::min(n, (k - begin + 1) * threads)), int(n));
      }
    } catch (...) {
      errors[j] = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  for (size_t j = 1; j < threads; ++j) pool.emplace_back(work, j);
  work(0);
  for (auto& t : pool) t.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  if (progress) progress(int(n), int(n));
  contact::calcAreaDerivatives(series);
  return series;
}

bool isRotational(const model::ModelPtr& model, const WorkflowSetup& setup) {
  const int c = model->findCoordinate(setup.flexion_coordinate);
  return c >= 0 && model->coordinates[size_t(c)].motion_type == model::MotionType::Rotational;
}

// The step of the area's flexion derivative in the coordinate's SI unit.
double getFlexionStep(const WorkflowSetup& setup, bool rotational) {
  return std::isfinite(setup.flexion_step) ? setup.flexion_step : rotational ? 0.5 * kDeg : 1e-4;
}

// The area derivatives of one trial (WorkflowSetup::area_derivatives): dS/d(flexion) and
// dS/d(anterior shift of the femur), total and per compartment, at the main threshold, by central
// differences of areas at shifted poses. When every pose of the trial is a function of the flexion
// alone (always for the hinge; for the model when its other coordinates between the components
// follow couplers, checked pose by pose), the derivatives are computed on a flexion grid of the
// step's spacing covering the trial and interpolated linearly to the frames (3 area evaluations
// per grid knot instead of 4 per frame); otherwise at every frame.
std::vector<std::pair<std::string, std::vector<double>>> calcAreaDerivatives(
    const WorkflowSetup& setup, const WorkflowTrialSpec& spec, const model::ModelPtr& model, const ImplantMeshes& meshes,
    const io::Storage& motion, int motion_flex, double flex_unit, const ContactAreaSetup& cs, const ContactKinematics& k,
    const std::vector<int>& keep, const contact::ContactAreaCalculator& calculator,
    std::vector<std::unique_ptr<contact::ContactAreaWorkspace>>& wss, std::vector<std::string>& notes,
    const std::function<void(int, int)>& progress) {
  const double h = getFlexionStep(setup, isRotational(model, setup)), a = setup.ap_step;
  const std::string step_text = isRotational(model, setup) ? fmt(h / kDeg, 3) + " deg" : fmt(h, 3) + " m";
  const Eigen::Vector3d anterior = -setup.contact.options.insert_directions.posterior.normalized();
  const auto shift = [&](const std::vector<Eigen::Isometry3d>& X, double s) {
    std::vector<Eigen::Isometry3d> out(X.size());
    for (size_t i = 0; i < X.size(); ++i) out[i] = Eigen::Translation3d(s * anterior) * X[i];
    return out;
  };
  // Poses at arbitrary flexion angles (rad), every other coordinate at its default or coupler.
  ContactAreaSetup any_time = cs;
  any_time.time_start = -HUGE_VAL;
  any_time.time_end = HUGE_VAL;
  const auto posesAt = [&](const std::vector<double>& flexion) {
    std::vector<double> t(flexion.size());
    for (size_t i = 0; i < t.size(); ++i) t[i] = double(i);
    if (setup.kinematics != "model") return calcHingeKinematics(any_time, meshes, t, flexion).X_IF;
    io::Storage m;
    m.name = spec.name + " flexion only";
    m.in_degrees = false;
    m.labels = {"time", setup.flexion_coordinate};
    m.data.resize(Eigen::Index(t.size()), 2);
    for (size_t i = 0; i < t.size(); ++i) {
      m.data(Eigen::Index(i), 0) = t[i];
      m.data(Eigen::Index(i), 1) = flexion[i];
    }
    return calcModelKinematics(any_time, model, m, m.name).X_IF;
  };
  // The frames' flexion (rad) in the order of k.
  std::vector<double> theta;
  for (int row = 0; row < motion.getNumRows(); ++row) {
    const double t = motion.data(row, 0);
    if (t < cs.time_start - 1e-9 || t > cs.time_end + 1e-9) continue;
    theta.push_back(motion.data(row, motion_flex) * flex_unit);
  }
  bool on_path = setup.kinematics != "model";
  if (!on_path && theta.size() == k.X_IF.size()) {
    try {
      const std::vector<Eigen::Isometry3d> X = posesAt(theta);
      double worst = 0;
      for (size_t i = 0; i < X.size(); ++i)
        worst = std::max({worst, (X[i].translation() - k.X_IF[i].translation()).norm(),
                          (X[i].linear() - k.X_IF[i].linear()).norm() * 0.05});
      on_path = worst < 1e-9;
    } catch (const InputError&) {
      on_path = false;  // an uncoupled coordinate between the components: not a function of flexion
    }
  }
  const auto S = [](const contact::ContactFrame& f, int c) { return c == 0 ? f.S : c == 1 ? f.S_medial : f.S_lateral; };
  std::vector<std::vector<double>> dflex(3, std::vector<double>(keep.size())), dap = dflex;
  if (on_path) {
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (int i : keep) lo = std::min(lo, theta[size_t(i)]), hi = std::max(hi, theta[size_t(i)]);
    const int k0 = int(std::floor(lo / h)) - 1, k1 = int(std::ceil(hi / h)) + 1;
    std::vector<double> grid;
    for (int j = k0; j <= k1; ++j) grid.push_back(j * h);
    const std::vector<Eigen::Isometry3d> X = posesAt(grid);
    std::vector<double> gt(grid.size());
    for (size_t i = 0; i < gt.size(); ++i) gt[i] = double(i);
    const contact::ContactSeries s0 = calcSeriesInParallel(calculator, wss, gt, X, progress);
    const contact::ContactSeries sp = calcSeriesInParallel(calculator, wss, gt, shift(X, +a), progress);
    const contact::ContactSeries sm = calcSeriesInParallel(calculator, wss, gt, shift(X, -a), progress);
    const size_t n = grid.size();
    for (size_t f = 0; f < keep.size(); ++f) {
      const double x = (theta[size_t(keep[f])] - grid[0]) / h;
      const size_t j = std::clamp<size_t>(size_t(std::floor(x)), 1, n - 3);
      const double w = std::clamp(x - double(j), 0.0, 1.0);
      for (int c = 0; c < 3; ++c) {
        const auto df = [&](size_t q) { return (S(s0.frames[q + 1], c) - S(s0.frames[q - 1], c)) / (2 * h); };
        const auto da = [&](size_t q) { return (S(sp.frames[q], c) - S(sm.frames[q], c)) / (2 * a); };
        dflex[size_t(c)][f] = (1 - w) * df(j) + w * df(j + 1);
        dap[size_t(c)][f] = (1 - w) * da(j) + w * da(j + 1);
      }
    }
    notes.push_back("area derivatives on a " + step_text + " grid of " + setup.flexion_coordinate + " (" + std::to_string(n) +
                    " knots): every pose of the trial is a function of it alone");
  } else {
    std::vector<double> tp, tm;
    for (double v : theta) tp.push_back(v + h), tm.push_back(v - h);
    const std::vector<Eigen::Isometry3d> X = subset(k.X_IF, keep);
    std::vector<Eigen::Isometry3d> Xp, Xm;
    if (setup.kinematics == "model") {
      io::Storage plus = motion, minus = motion;
      plus.data.col(motion_flex).array() += h / flex_unit;
      minus.data.col(motion_flex).array() -= h / flex_unit;
      Xp = subset(calcModelKinematics(cs, model, plus, spec.name + " flexion + step").X_IF, keep);
      Xm = subset(calcModelKinematics(cs, model, minus, spec.name + " flexion - step").X_IF, keep);
    }
    std::vector<double> time(keep.size());
    for (size_t i = 0; i < time.size(); ++i) time[i] = k.time[size_t(keep[i])];
    const contact::ContactSeries fp = calcSeriesInParallel(calculator, wss, time, Xp, progress);
    const contact::ContactSeries fm = calcSeriesInParallel(calculator, wss, time, Xm, progress);
    const contact::ContactSeries ap = calcSeriesInParallel(calculator, wss, time, shift(X, +a), progress);
    const contact::ContactSeries am = calcSeriesInParallel(calculator, wss, time, shift(X, -a), progress);
    for (size_t f = 0; f < keep.size(); ++f)
      for (int c = 0; c < 3; ++c) {
        dflex[size_t(c)][f] = (S(fp.frames[f], c) - S(fm.frames[f], c)) / (2 * h);
        dap[size_t(c)][f] = (S(ap.frames[f], c) - S(am.frames[f], c)) / (2 * a);
      }
    notes.push_back("area derivatives at every frame (the poses depend on more than " + setup.flexion_coordinate + ")");
  }
  return {{"dS_dflexion", dflex[0]}, {"dS_medial_dflexion", dflex[1]}, {"dS_lateral_dflexion", dflex[2]},
          {"dS_dap", dap[0]},        {"dS_medial_dap", dap[1]},        {"dS_lateral_dap", dap[2]}};
}

struct TrialState {
  WorkflowTrialSpec spec;
  WorkflowTrialResult result;
  io::Storage motion;        // degrees for rotations when in_degrees
  std::string motion_label;  // for messages
};

}  // namespace

WorkflowReport runWorkflow(const WorkflowSetup& setup, const RunOptions& options) {
  const auto t_start = Clock::now();
  WorkflowReport report;
  report.name = setup.name;
  const auto progress = [&](const std::string& what, int d, int t) {
    if (options.progress) options.progress(what, d, t);
  };
  const SourceLocation at_setup{setup.setup_file, 0, "KneeContactWorkflow"};

  // ---- shared inputs: meshes, contact-area calculator, law, model
  const ImplantMeshes meshes = readImplantMeshes(setup.contact);
  plugin::Registry registry;
  const auto calculator = makeContactAreaCalculator(setup.contact, meshes, registry);
  // One workspace per thread (each builds the provider's structures once for the whole run).
  std::vector<std::unique_ptr<contact::ContactAreaWorkspace>> wss;
  for (int j = 0; j < std::max(1, setup.threads); ++j) wss.push_back(calculator->createWorkspace());
  // The area derivatives need only the main threshold: a calculator without the extra ones
  // searches a narrower band.
  std::unique_ptr<contact::ContactAreaCalculator> derivative_calculator;
  std::vector<std::unique_ptr<contact::ContactAreaWorkspace>> derivative_wss;
  if (setup.area_derivatives) {
    ContactAreaSetup ds = setup.contact;
    ds.options.extra_thresholds.clear();
    derivative_calculator = makeContactAreaCalculator(ds, meshes, registry);
    for (int j = 0; j < std::max(1, setup.threads); ++j) derivative_wss.push_back(derivative_calculator->createWorkspace());
  }
  for (const std::string& p : setup.law_plugins) registry.loadPlugin(p, {setup.setup_file, 0, "ContactLaw/plugins"});
  const identify::ContactLaw law =
      identify::ContactLaw::fromRegistry(registry, setup.law, {setup.setup_file, 0, "ContactLaw/name"});
  report.law_description = law.getDescription();
  if (!fs::exists(setup.model_file)) throw InputError({setup.setup_file, 0, "model_file"}, "model file not found: " + setup.model_file);
  const model::ModelPtr model = endsWith(toLower(setup.model_file), ".urdf") ? model::readUrdf(setup.model_file)
                                                                             : model::readOsim(setup.model_file);
  const int flex_coord = model->findCoordinate(setup.flexion_coordinate);
  if (flex_coord < 0)
    throw InputError({setup.setup_file, 0, "flexion_coordinate"},
                     "no coordinate '" + setup.flexion_coordinate + "' in " + setup.model_file);
  const bool flex_rot = model->coordinates[size_t(flex_coord)].motion_type == model::MotionType::Rotational;

  AtomicFileSet outputs;
  std::vector<TrialState> states;
  for (const WorkflowTrialSpec& s : setup.trials) states.push_back({s, {}, {}, {}});
  // Goniometer trials last: a calibration needs its reference trial's flexion.
  std::vector<size_t> order;
  for (size_t i = 0; i < states.size(); ++i)
    if (states[i].spec.source != WorkflowTrialSpec::Source::goniometer) order.push_back(i);
  for (size_t i = 0; i < states.size(); ++i)
    if (states[i].spec.source == WorkflowTrialSpec::Source::goniometer) order.push_back(i);

  const auto trialDir = [&](const std::string& trial) { return (fs::path(setup.results_directory) / trial).string(); };

  for (size_t oi : order) {
    TrialState& st = states[oi];
    const WorkflowTrialSpec& spec = st.spec;
    WorkflowTrialResult& r = st.result;
    r.name = spec.name;
    r.fit = spec.fit;
    const std::string who = "trial '" + spec.name + "': ";

    // ---- forces (needed first by the goniometer source)
    if (!fs::exists(spec.knee_forces_file)) throw InputError(spec.where, who + "knee-force file not found: " + spec.knee_forces_file);
    io::KneeForces forces = io::readKneeForces(spec.knee_forces_file);
    std::string c3d_file = spec.c3d_file;

    // ---- kinematics source
    auto t0 = Clock::now();
    if (spec.source == WorkflowTrialSpec::Source::ik) {
      if (!fs::exists(spec.ik_setup_file)) throw InputError(spec.where, who + "IK setup file not found: " + spec.ik_setup_file);
      ik::IkSetup ik = ik::readIkSetup(spec.ik_setup_file);
      ik.output_motion_file = (fs::path(trialDir(spec.name)) / (spec.name + "_ik.mot")).string();
      ik.results_directory = trialDir(spec.name);
      ik.time_start = std::max(ik.time_start, spec.time_start);
      ik.time_end = std::min(ik.time_end, spec.time_end);
      if (fs::weakly_canonical(ik.model_file) != fs::weakly_canonical(setup.model_file))
        r.notes.push_back("IK used " + ik.model_file + ", the contact kinematics " + setup.model_file);
      ik::IkRunOptions ro;
      ro.progress = [&](int d, int t) { progress("IK " + spec.name, d, t); };
      ro.stage = &outputs;
      const ik::IkReport rep = ik::runIk(ik, ro);
      st.motion = rep.motion;
      st.motion_label = ik.output_motion_file + " (IK of " + ik.marker_file + ")";
      r.ik_mean_rms = rep.mean_rms;
      if (c3d_file.empty() && endsWith(toLower(ik.marker_file), ".c3d")) c3d_file = ik.marker_file;
      r.notes.push_back("IK of " + ik.marker_file + ": " + std::to_string(rep.frames_solved) + " frames, mean marker RMS " +
                        fmt(rep.mean_rms * 1e3, 3) + " mm");
    } else if (spec.source == WorkflowTrialSpec::Source::motion) {
      if (!fs::exists(spec.motion_file)) throw InputError(spec.where, who + "motion file not found: " + spec.motion_file);
      st.motion = io::readStorage(spec.motion_file);
      st.motion_label = spec.motion_file;
    } else {
      // Flexion from the goniometer (io/goniometer.hpp): volts to goniometer degrees when the file
      // is in volts, then the line to the model's flexion, as given or fitted on other trials.
      io::GoniometerCalibration cal = spec.goniometer;
      if (!spec.calibrate_on.empty()) {
        std::vector<io::GoniometerPairs> pairs;
        for (const std::string& ref_name : spec.calibrate_on) {
          const auto it = std::find_if(states.begin(), states.end(),
                                       [&](const TrialState& o) { return o.spec.name == ref_name; });
          const WorkflowTrialResult& ref = it->result;
          io::GoniometerPairs p;
          p.trial = ref_name;
          p.goniometer = ref.forces.goniometer;
          for (double f : ref.flexion) p.flexion_deg.push_back(flex_rot ? f / kDeg : f);
          pairs.push_back(std::move(p));
        }
        cal = io::fitGoniometerCalibration(pairs, cal, spec.where);
        if (!(std::abs(cal.r) > 0.9))
          throw InputError(spec.where, who + "the goniometer " + cal.source + " does not follow the " +
                                           setup.flexion_coordinate + " (r = " + fmt(cal.r, 3) + " over " +
                                           std::to_string(cal.frames) + " frames, expected |r| > 0.9): no calibration");
      }
      std::string note;
      const std::vector<double> flex_deg = io::calcKneeFlexionDeg(forces.goniometer, cal, &note);
      r.goniometer = cal;
      r.goniometer_in_volts = io::usesVolts(forces.goniometer, cal);
      r.notes.push_back(note + (spec.calibrate_on.empty() ? "" : "; assumes the same sensor, gain and offset in this trial"));
      st.motion.name = spec.name + " flexion from the goniometer";
      st.motion.in_degrees = true;
      st.motion.labels = {"time", setup.flexion_coordinate};
      std::vector<int> rows;
      for (size_t i = 0; i < forces.time.size(); ++i)
        if (std::isfinite(forces.goniometer[i])) rows.push_back(int(i));
      if (rows.empty()) throw InputError(spec.where, who + "no goniometer values (GON) in " + spec.knee_forces_file);
      st.motion.data.resize(Eigen::Index(rows.size()), 2);
      for (size_t k = 0; k < rows.size(); ++k) {
        st.motion.data(Eigen::Index(k), 0) = forces.time[size_t(rows[k])];
        st.motion.data(Eigen::Index(k), 1) = flex_deg[size_t(rows[k])];
      }
      st.motion_label = spec.name + " goniometer of " + spec.knee_forces_file;
      outputs.addContents((fs::path(trialDir(spec.name)) / (spec.name + "_motion.mot")).string(),
                          io::formatStorage(st.motion));
    }
    r.seconds_ik = secondsSince(t0);
    if (!spec.id_setup_file.empty())
      r.knee_loads = runTrialKneeLoads(spec.id_setup_file, st.motion,
                                       spec.source == WorkflowTrialSpec::Source::ik ? st.motion_label : spec.motion_file,
                                       spec.name, trialDir(spec.name), spec.where, outputs, r.notes);

    // ---- forces on the C3D's clock, gait events
    io::C3dFile c3d;
    if (!c3d_file.empty()) {
      if (!fs::exists(c3d_file)) throw InputError(spec.where, who + "C3D file not found: " + c3d_file);
      c3d = io::readC3d(c3d_file);
      forces = io::retimeToFrames(forces, c3d.first_frame, c3d.markers.rate);
      io::FootContactOptions fo;
      fo.heel_marker = spec.heel_marker;
      if (spec.gait_events.empty()) r.contacts = io::findFootContacts(c3d, fo);
    }
    if (spec.gait_events.size() == 3) {
      r.cycle.strike = spec.gait_events[0];
      r.cycle.toe_off = spec.gait_events[1];
      r.cycle.next_strike = spec.gait_events[2];
    } else {
      r.cycle = io::findGaitCycle(r.contacts);
    }

    // ---- component poses
    t0 = Clock::now();
    ContactAreaSetup cs = setup.contact;
    cs.time_start = spec.time_start;
    cs.time_end = spec.time_end;
    const int motion_flex = st.motion.findColumn(setup.flexion_coordinate);
    if (motion_flex < 0)
      throw InputError(spec.where, who + "the motion " + st.motion_label + " has no column '" + setup.flexion_coordinate + "'");
    const double flex_unit = st.motion.in_degrees && flex_rot ? kDeg : 1.0;
    // The poses of the trial's frames with the flexion shifted by dflex (rad): 0 for the areas,
    // +-a step for their derivative along flexion (through the model's couplers or the hinge).
    const auto calcPoses = [&](double dflex) {
      const auto prog = [&](const std::string& w, int d, int t) {
        progress(w + " " + spec.name + (dflex != 0 ? " (flexion step)" : ""), d, t);
      };
      if (setup.kinematics == "model") {
        if (dflex == 0) return calcModelKinematics(cs, model, st.motion, st.motion_label, prog);
        io::Storage shifted = st.motion;
        shifted.data.col(motion_flex).array() += dflex / flex_unit;
        return calcModelKinematics(cs, model, shifted, st.motion_label, prog);
      }
      std::vector<double> t_all, f_all;
      for (int row = 0; row < st.motion.getNumRows(); ++row) {
        const double t = st.motion.data(row, 0);
        if (t < spec.time_start - 1e-9 || t > spec.time_end + 1e-9) continue;
        t_all.push_back(t);
        f_all.push_back(st.motion.data(row, motion_flex) * flex_unit + dflex);
      }
      if (t_all.empty())
        throw InputError(spec.where, who + "time range " + fmt(spec.time_start) + " to " + fmt(spec.time_end) +
                                         " s does not overlap the motion " + st.motion_label);
      return calcHingeKinematics(cs, meshes, t_all, f_all, prog);
    };
    const ContactKinematics k = calcPoses(0.0);
    r.seconds_kinematics = secondsSince(t0);
    r.kinematics_description = k.description;
    for (const std::string& w : k.warnings)  // model warnings repeat for every trial: once is enough
      if (std::find(report.warnings.begin(), report.warnings.end(), w) == report.warnings.end())
        report.warnings.push_back(w);

    // ---- measured force at the motion's frames; frames outside the recording are left out
    const io::KneeForces at_frames = io::resampleKneeForces(forces, k.time);
    std::vector<int> keep;
    for (size_t i = 0; i < k.time.size(); ++i)
      if (std::isfinite(at_frames.total[i])) keep.push_back(int(i));
    if (keep.size() < 2)
      throw InputError(spec.where, who + "the knee forces of " + spec.knee_forces_file + " (" +
                                       fmt(forces.time.front()) + " to " + fmt(forces.time.back()) +
                                       " s) overlap the kinematics (" + fmt(k.time.front()) + " to " +
                                       fmt(k.time.back()) + " s) in " + std::to_string(keep.size()) +
                                       " frames, expected at least 2");
    if (keep.size() < k.time.size())
      r.notes.push_back(std::to_string(k.time.size() - keep.size()) + " of " + std::to_string(k.time.size()) +
                        " motion frames lie outside the knee-force recording and are left out");
    r.time = subset(k.time, keep);
    r.forces = subsetForces(at_frames, keep);
    const std::vector<Eigen::Isometry3d> X_IF = subset(k.X_IF, keep);
    for (const auto& [name, v] : k.columns) r.kinematics_columns.emplace_back(name, subset(v, keep));
    for (double t : r.time) r.flexion.push_back(interpolateColumn(st.motion, motion_flex, t) * flex_unit);

    // ---- contact area
    t0 = Clock::now();
    r.contact = calcSeriesInParallel(*calculator, wss, r.time, X_IF,
                                     [&](int d, int t) { progress("area " + spec.name, d, t); });
    r.seconds_area = secondsSince(t0);

    // ---- derivatives of the area along flexion and along an anterior shift of the femur
    if (setup.area_derivatives) {
      t0 = Clock::now();
      r.area_derivatives = calcAreaDerivatives(setup, spec, model, meshes, st.motion, motion_flex, flex_unit, cs, k,
                                               keep, *derivative_calculator, derivative_wss, r.notes,
                                               [&](int d, int t) { progress("area derivatives " + spec.name, d, t); });
      r.seconds_area_derivatives = secondsSince(t0);
    }

    // ---- the identification's view
    identify::Trial& tr = r.trial;
    tr.name = spec.name;
    tr.source = spec.where;
    tr.time = r.time;
    for (auto& [name, v] : contact::getContactChannels(r.contact))
      if (name != "time") tr.channels[name] = std::move(v);
    tr.channels[setup.flexion_coordinate] = r.flexion;
    tr.measured_force = r.forces.total;
    const identify::TimeWindow w = resolveWindow(spec, r.cycle);
    if (spec.window != "trial") tr.windows.push_back(w);
    if (!spec.id_setup_file.empty()) compareKneeLoads(r.knee_loads, r.time, r.forces, w.begin, w.end);
  }

  // ---- identification on the training trials
  auto t0 = Clock::now();
  std::vector<identify::Trial> training;
  for (const TrialState& st : states)
    if (st.spec.fit) training.push_back(st.result.trial);
  progress("fit", 0, 1);
  report.fit = identify::fit(law, training, setup.fit);
  progress("fit", 1, 1);
  const Eigen::VectorXd params = report.fit.getValues();

  // Laws on the two compartments (hertz_ml) give each compartment's share with the other's area zeroed.
  const std::vector<std::string>& inputs = law.getInputNames();
  const bool per_compartment = inputs.size() == 2 && std::count(inputs.begin(), inputs.end(), "S_medial") == 1 &&
                               std::count(inputs.begin(), inputs.end(), "S_lateral") == 1;

  for (TrialState& st : states) {
    WorkflowTrialResult& r = st.result;
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

  // ---- the fit at the other thresholds (the law reads S; each extra threshold's area takes its place)
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
  report.seconds_fit = secondsSince(t0);

  // ---- per-trial outputs
  const std::string thr_label = fmt(setup.contact.options.threshold * 1e3, 4) + " mm";
  for (TrialState& st : states) {
    const WorkflowTrialResult& r = st.result;
    const std::string dir = trialDir(r.name);
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
    const io::Storage area = contact::makeContactStorage(r.contact, *calculator, r.name + "_contact_area", extra, header);
    outputs.addContents((fs::path(dir) / (r.name + "_contact_area.sto")).string(), io::formatStorage(area));

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
      for (size_t c = 0; c < row.size(); ++c) f.data(Eigen::Index(i), Eigen::Index(c)) = row[c];
    }
    outputs.addContents((fs::path(dir) / (r.name + "_forces.sto")).string(), io::formatStorage(f));
  }

  // ---- plots (the paper's Figures 6-9)
  t0 = Clock::now();
  std::vector<std::string> plot_files;
  if (setup.plots) {
    const Gnuplot gp = findGnuplot(setup.gnuplot);
    if (!gp.isUsable()) {
      report.plots_problem = gp.problem;
      report.warnings.push_back("no plots: " + gp.problem);
    } else {
      const std::string pdir = (fs::path(setup.results_directory) / "plots").string();
      std::vector<Plot> plots;
      std::vector<const WorkflowTrialResult*> cyc, other;
      for (const TrialState& st : states) (st.result.cycle.isComplete() ? cyc : other).push_back(&st.result);
      const bool by_cycle = !cyc.empty();
      const std::vector<const WorkflowTrialResult*>& main = by_cycle ? cyc : other;
      const std::string xl = by_cycle ? "gait cycle (%, heel strike to heel strike, from the force plates)" : "time (s)";
      // Figures 6-8: the main trials against the shared x axis, limited to the cycle with its toe-offs.
      const auto startMainPlot = [&](const std::string& name, const std::string& title, const std::string& ylabel) {
        Plot p;
        p.file = pdir + "/" + name + ".png";
        p.title = title;
        p.xlabel = xl;
        p.ylabel = ylabel;
        return p;
      };
      const auto addMainPlot = [&](Plot& p) {
        if (by_cycle) {
          p.xmin = 0;
          p.xmax = 100;
          for (const auto* r : main)
            if (std::isfinite(r->cycle.toe_off))
              p.vlines.push_back({r->cycle.getToeOffPercent(), main.size() == 1 ? "toe-off" : "toe-off " + r->name});
        }
        plots.push_back(std::move(p));
      };
      {
        Plot p = startMainPlot("fig6_knee_flexion", "Knee flexion (after Dao & Pouletaut 2015, Fig. 6)",
                               setup.flexion_coordinate + (flex_rot ? " (deg)" : ""));
        int c = 0;
        for (const auto* r : main) {
          std::vector<double> y;
          for (double v : r->flexion) y.push_back(flex_rot ? v / kDeg : v);
          const auto src = std::find_if(states.begin(), states.end(), [&](const TrialState& o) { return o.spec.name == r->name; })->spec.source;
          p.series.push_back({r->name + (src == WorkflowTrialSpec::Source::ik ? " (IK)"
                                         : src == WorkflowTrialSpec::Source::motion ? " (motion)"
                                                                                     : " (goniometer, calibrated)"),
                              plotAxis(*r, by_cycle), y, "lines", kColors[c % 7]});
          // A goniometer in degrees (spanning more than 10 units) is drawn for comparison.
          double lo = HUGE_VAL, hi = -HUGE_VAL;
          for (double g : r->forces.goniometer)
            if (std::isfinite(g)) {
              lo = std::min(lo, g);
              hi = std::max(hi, g);
            }
          if (hi - lo > 10)
            p.series.push_back({r->name + " goniometer (GON)", plotAxis(*r, by_cycle), r->forces.goniometer, "lines",
                                kColors[c % 7], 2, 1.5});
          ++c;
        }
        addMainPlot(p);
      }
      {
        Plot p = startMainPlot("fig7_contact_area", "Implant contact area (after Dao & Pouletaut 2015, Fig. 7)",
                               "contact area (mm²)");
        int c = 0;
        for (const auto* r : main) {
          const auto x = plotAxis(*r, by_cycle);
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
        addMainPlot(p);
      }
      {
        Plot p = startMainPlot("fig8_compartment_forces",
                               "Measured compartment forces, eKnee and equation 4 (after Dao & Pouletaut 2015, Fig. 8)",
                               "force (N)");
        int c = 0;
        for (const auto* r : main) {
          const auto x = plotAxis(*r, by_cycle);
          p.series.push_back({r->name + " medial", x, r->forces.medial, "lines", kColors[c % 7]});
          p.series.push_back({r->name + " lateral", x, r->forces.lateral, "lines", kColors[c % 7], 2});
          ++c;
        }
        addMainPlot(p);
      }
      for (const TrialState& st : states) {
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
        plots.push_back(p);
      }
      // The knee's net loads (inverse dynamics) beside the measured forces.
      for (const TrialState& st : states) {
        const WorkflowTrialResult& r = st.result;
        if (r.knee_loads.at_frames.empty()) continue;
        const bool rc = r.cycle.isComplete();
        Plot p = makeKneeLoadPlot(r.knee_loads, r.forces, plotAxis(r, rc), rc ? "gait cycle (%)" : "time (s)", r.name);
        p.file = pdir + "/fig10_knee_loads_" + r.name + ".png";
        if (rc) {
          p.vlines.push_back({0.0, "heel strike"});
          if (std::isfinite(r.cycle.toe_off)) p.vlines.push_back({r.cycle.getToeOffPercent(), "toe-off"});
          p.vlines.push_back({100.0, "heel strike"});
        }
        plots.push_back(p);
      }
      // Trials without a gait cycle: flexion and area over time.
      for (const auto* r : other) {
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
        plots.push_back(p);
      }
      // Goniometer calibrations: the reference trials' flexion against the goniometer's degrees,
      // the fitted line, the goniometer's own degrees (y = x) and the calibrated trial's range.
      for (const TrialState& st : states) {
        if (st.spec.source != WorkflowTrialSpec::Source::goniometer || st.spec.calibrate_on.empty() || !flex_rot) continue;
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
        plots.push_back(p);
      }
      renderPlots(plots, gp, outputs, setup.plot_scripts);
      for (const Plot& p : plots) plot_files.push_back(p.file);
    }
  }
  report.seconds_plots = secondsSince(t0);

  // ---- summary.json
  json sj;
  sj["workflow"] = setup.name;
  sj["setup_file"] = setup.setup_file;
  sj["model_file"] = setup.model_file;
  sj["body_mass_kg"] = num(setup.body_mass);
  sj["kinematics"] = setup.kinematics == "model"
                         ? "model: the components placed by the model at every frame"
                         : "hinge: flexion only about the fitted cylinder, seated (Dao & Pouletaut 2015)";
  json ca;
  ca["threshold_m"] = setup.contact.options.threshold;
  ca["extra_thresholds_m"] = setup.contact.options.extra_thresholds;
  ca["area_rule"] = contact::toString(setup.contact.options.rule);
  ca["distance_method"] = calculator->getDistanceMethod();
  ca["articular_area_m2"] = calculator->getArticularArea();
  ca["paper_peak_range_m2"] = {kPaperPeakLow, kPaperPeakHigh};
  sj["contact_area"] = ca;
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
  sj["identification"] = law_j;
  json refits = json::array();
  for (const ThresholdRefit& t : report.threshold_refits) {
    json j{{"channel", t.channel}, {"threshold_m", t.threshold}, {"solver_status", t.solver_status}};
    for (const auto& [name, v] : t.derived) j[name] = v;
    json pt = json::object();
    for (const auto& [trial, m] : t.per_trial) pt[trial] = metricsJson(m);
    j["per_trial_window"] = pt;
    refits.push_back(j);
  }
  sj["threshold_refits"] = refits;
  json trials = json::array();
  for (const TrialState& st : states) {
    const WorkflowTrialResult& r = st.result;
    json j;
    j["name"] = r.name;
    j["role"] = r.fit ? "fit" : "predict";
    j["kinematics"] = r.kinematics_description;
    j["frames"] = r.time.size();
    j["time_s"] = {r.time.front(), r.time.back()};
    j["ik_mean_marker_rms_m"] = num(r.ik_mean_rms);
    j["notes"] = r.notes;
    json ev;
    ev["heel_strike_s"] = num(r.cycle.strike);
    ev["toe_off_s"] = num(r.cycle.toe_off);
    ev["next_heel_strike_s"] = num(r.cycle.next_strike);
    ev["toe_off_percent_of_cycle"] = r.cycle.isComplete() ? num(r.cycle.getToeOffPercent()) : json(nullptr);
    ev["source"] = st.spec.gait_events.empty() ? "force plates (" + st.spec.heel_marker + " over the plate)" : "setup";
    json plates = json::array();
    for (const auto& c : r.contacts) plates.push_back({{"plate", c.plate}, {"strike_s", c.strike}, {"off_s", num(c.off)}});
    ev["plate_contacts"] = plates;
    j["gait_events"] = ev;
    json win;
    if (!r.trial.windows.empty()) win = {r.trial.windows[0].begin, r.trial.windows[0].end};
    j["window"] = {{"kind", st.spec.window}, {"s", win}};
    // Contact-area peaks: over the trial and the window, at the threshold and the extra ones.
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
                       {"peak_m2", num(pk)},
                       {"peak_time_s", num(tpk)},
                       {"window_peak_m2", num(pw)},
                       {"window_peak_time_s", num(tpw)},
                       {"window_lowest_m2", std::isfinite(lo) ? num(lo) : json(nullptr)}});
    }
    j["contact_area"] = areas;
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
      j["window_metrics"]["constant_force_rmse_N"] = num(std::sqrt(ss / double(meas.size())));
    }
    j["trial_metrics"] = metricsJson(r.trial_prediction.metrics);
    j["agreement"] = {{"tolerance_N", setup.agreement_fraction * r.window_prediction.metrics.peak_measured},
                      {"tolerance_fraction_of_window_peak", setup.agreement_fraction},
                      {"window_fraction", num(r.window_agreement)},
                      {"cycle_fraction", num(r.cycle_agreement)}};
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
                                     {"source", g.source}, {"r", num(g.r)}, {"rms_deg", num(g.rms_deg)}, {"frames", g.frames}};
    }
    if (!r.knee_loads.at_frames.empty()) j["knee_loads"] = toJson(r.knee_loads, setup.timings);
    if (setup.timings) j["seconds"] = {{"ik", r.seconds_ik}, {"kinematics", r.seconds_kinematics}, {"contact_area", r.seconds_area}};
    trials.push_back(j);
  }
  sj["trials"] = trials;
  sj["plots"] = plot_files;
  sj["plots_problem"] = report.plots_problem;
  sj["warnings"] = report.warnings;
  report.seconds_total = secondsSince(t_start);
  if (setup.timings) sj["seconds"] = {{"total_before_writing", report.seconds_total}, {"fit", report.seconds_fit}, {"plots", report.seconds_plots}};
  report.summary_file = (fs::path(setup.results_directory) / "summary.json").string();
  outputs.addContents(report.summary_file, sj.dump(2) + "\n");

  outputs.commit();
  report.outputs = outputs.getPaths();
  for (TrialState& st : states) report.trials.push_back(std::move(st.result));

  // ---- the gap diagnoses on the contact-area files just written (their own outputs, in gap/)
  t0 = Clock::now();
  for (const std::string& file : setup.gap_setup_files) {
    if (!fs::exists(file)) throw InputError({setup.setup_file, 0, "gap_setup_file"}, "gap setup file not found: " + file);
    gap::GapSetup gs = gap::readGapSetup(file);
    gap::setWorkflowResults(gs, setup.results_directory);
    // The knee's net loads this run computed become the trials' knee_* channels (knee_load effect).
    for (gap::TrialSource& t : gs.trials)
      for (const WorkflowTrialResult& r : report.trials)
        if (t.knee_loads.empty() && r.name == t.name && !r.knee_loads.at_frames.empty())
          t.knee_loads = (fs::path(trialDir(r.name)) / (r.name + "_knee_loads.sto")).string();
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
