#include "ik/tool.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <ostream>
#include <set>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/paths.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "io/marker_table.hpp"
#include "io/storage.hpp"
#include "model/model_info.hpp"
#include "model/read_model.hpp"

namespace kneesim::ik {

namespace fs = std::filesystem;

SourceLocation IkSetup::locate(const std::string& element) const {
  auto it = locations.find(element);
  if (it != locations.end()) return it->second;
  return {setup_file, 0, element};
}

namespace {

bool isIkToolTag(const std::string& tag) {
  // OpenSim accepts its own historical misspellings (e.g. "InverseKinemtaticsTool").
  const std::string t = toLower(tag);
  return startsWith(t, "inversekinem") && endsWith(t, "tool");
}

}  // namespace

void readTaskSet(const xml::Node& set, std::vector<TaskSpec>& out) {
  xml::Node objects = set.child("objects");
  const xml::Node holder = objects ? objects : set;
  for (const xml::Node& t : holder.children()) {
    TaskSpec spec;
    const std::string tag = t.name();
    if (tag == "IKMarkerTask")
      spec.kind = TaskSpec::Kind::Marker;
    else if (tag == "IKCoordinateTask")
      spec.kind = TaskSpec::Kind::Coordinate;
    else if (tag == "groups")
      continue;
    else
      t.fail("unknown task type <" + tag + "> (expected IKMarkerTask or IKCoordinateTask)");
    spec.name = t.nameAttr();
    if (spec.name.empty()) t.fail("task has no name attribute");
    spec.apply = t.childBool("apply", true);
    spec.weight = t.childDouble("weight", 1.0);
    if (!(spec.weight >= 0) || !std::isfinite(spec.weight))
      t.child("weight").fail("expected a weight >= 0, got " + t.childText("weight"));
    spec.value_type = t.childText("value_type", "default_value");
    if (spec.value_type.empty()) spec.value_type = "default_value";
    if (spec.value_type != "default_value" && spec.value_type != "manual_value" && spec.value_type != "from_file")
      t.child("value_type").fail("expected default_value, manual_value or from_file, got '" + spec.value_type + "'");
    spec.value = t.childDouble("value", 0.0);
    spec.where = t.where();
    out.push_back(spec);
  }
}

std::vector<TaskSpec> readTaskSetElement(const xml::Node& set, const std::string& setup_dir) {
  if (auto file = set.attr("file"); file && !trim(*file).empty() && *file != "Unassigned") {
    const std::string task_path = xml::resolvePath(setup_dir, std::string(trim(*file)));
    if (!pathExists(task_path)) set.fail("IKTaskSet file not found: " + task_path);
    return readTaskFile(task_path);
  }
  std::vector<TaskSpec> tasks;
  readTaskSet(set, tasks);
  return tasks;
}

std::vector<TaskSpec> readTaskFile(const std::string& path) {
  if (!pathExists(path)) throw InputError({path, 0, ""}, "IKTaskSet file not found");
  auto doc = xml::Document::load(path);
  xml::Node root = doc->root();
  xml::Node set = root.name() == "IKTaskSet" ? root : root.child("IKTaskSet");
  if (!set) root.fail("no <IKTaskSet> in task file");
  std::vector<TaskSpec> tasks;
  readTaskSet(set, tasks);
  return tasks;
}

IkSetup readIkSetup(const std::string& path) {
  if (!pathExists(path)) throw InputError({path, 0, ""}, "setup file not found");
  auto doc = xml::Document::load(path);
  IkSetup s;
  s.setup_file = path;
  const std::string dir = fs::path(path).parent_path().string();
  xml::Node root = doc->root();
  xml::Node tool;
  if (isIkToolTag(root.name())) {
    tool = root;
  } else {
    for (const xml::Node& c : root.children())
      if (isIkToolTag(c.name())) tool = c;
  }
  if (!tool) root.fail("no InverseKinematicsTool element (expected <OpenSimDocument><InverseKinematicsTool>)");
  s.name = tool.nameAttr();
  s.locations["InverseKinematicsTool"] = tool.where();

  static const std::set<std::string> known = {
      "model_file",      "constraint_weight", "accuracy",           "IKTaskSet",
      "marker_file",     "coordinate_file",   "time_range",         "report_errors",
      "output_motion_file", "report_marker_locations", "results_directory", "input_directory",
      "max_iterations",  "marker_rotation"};
  for (const xml::Node& c : tool.children()) {
    if (!known.count(c.name()))
      c.fail("unknown element <" + c.name() +
             "> in InverseKinematicsTool (expected one of model_file, marker_file, IKTaskSet, coordinate_file, "
             "time_range, accuracy, constraint_weight, output_motion_file, results_directory, report_errors, "
             "report_marker_locations, marker_rotation)");
    s.locations[c.name()] = c.where();
  }

  s.model_file = xml::resolvePath(dir, tool.childText("model_file"));
  if (s.model_file.empty()) tool.fail("missing <model_file>");
  s.marker_file = xml::resolvePath(dir, tool.childText("marker_file"));
  if (s.marker_file.empty()) tool.fail("missing <marker_file>");
  const std::string coord = tool.childText("coordinate_file");
  if (!coord.empty() && coord != "Unassigned") s.coordinate_file = xml::resolvePath(dir, coord);
  std::string out = tool.childText("output_motion_file");
  if (out.empty() || out == "Unassigned") out = (s.name.empty() ? std::string("ik") : s.name) + "_ik.mot";
  s.output_motion_file = xml::resolvePath(dir, out);
  std::string results = tool.childText("results_directory");
  if (results.empty() || results == "Unassigned") results = ".";
  s.results_directory = xml::resolvePath(dir, results);

  if (xml::Node cw = tool.child("constraint_weight"); cw && !cw.text().empty()) {
    const std::string t = toLower(cw.text());
    s.constraint_weight = (t == "inf" || t == "infinity") ? std::numeric_limits<double>::infinity() : cw.toDouble();
    if (!(s.constraint_weight > 0)) cw.fail("expected constraint_weight > 0 or Infinity, got " + cw.text());
  }
  s.accuracy = tool.childDouble("accuracy", 1e-5);
  if (!(s.accuracy > 0)) tool.child("accuracy").fail("expected accuracy > 0, got " + tool.childText("accuracy"));
  // OpenSim hands accuracy to its optimizer as the convergence tolerance; here a frame is
  // converged when the remaining Gauss-Newton step is below it (rad or m, or m of marker motion).
  s.solver.step_tolerance = s.accuracy;
  if (xml::Node mi = tool.child("max_iterations")) {
    s.solver.max_iterations = mi.toIntIn(1);
  }
  if (xml::Node tr = tool.child("time_range"); tr && !tr.text().empty()) {
    const auto v = tr.toDoubles();
    if (v.size() != 2) tr.fail("expected 2 numbers (start end), got " + std::to_string(v.size()));
    if (v[0] > v[1]) tr.fail("expected start <= end, got " + tr.text());
    s.time_start = v[0];
    s.time_end = v[1];
  }
  if (xml::Node mr = tool.child("marker_rotation"); mr && !mr.text().empty()) s.marker_rotation_deg = mr.toVec3();
  s.report_errors = tool.childBool("report_errors", true);
  s.report_marker_locations = tool.childBool("report_marker_locations", false);

  if (xml::Node set = tool.child("IKTaskSet")) s.tasks = readTaskSetElement(set, dir);
  return s;
}

namespace {

model::ModelPtr loadModel(const IkSetup& setup) {
  if (!pathExists(setup.model_file))
    throw InputError(setup.locate("model_file"), "model file not found: " + setup.model_file);
  return model::readModel(setup.model_file);
}

/// A marker name without the separators people use differently ('.', '_', '-', ' ') and
/// without a Vicon subject prefix ("JW:").
std::string looseName(const std::string& name) {
  const size_t colon = name.rfind(':');
  std::string out;
  for (size_t i = colon == std::string::npos ? 0 : colon + 1; i < name.size(); ++i) {
    const char c = name[i];
    if (c != '.' && c != '_' && c != '-' && c != ' ') out += c;
  }
  return out;
}

/// Matches model marker names to marker-file columns: exact (or with a subject prefix) first for
/// all names, then ignoring separators among the columns nobody claimed exactly.
class MarkerMatcher {
 public:
  explicit MarkerMatcher(const io::MarkerTable& table) : table_(table), claimed_(table.labels.size(), 0) {}

  /// Exact pass; returns the column or -1.
  int matchExact(const std::string& name) {
    const int col = table_.findMarker(name);
    if (col >= 0) claimed_[col] = 1;
    return col;
  }
  /// Separator-insensitive pass; -1 if none. Throws InputError when two columns match.
  int matchLoose(const std::string& name, const SourceLocation& where) {
    const std::string key = looseName(name);
    int found = -1;
    for (size_t c = 0; c < table_.labels.size(); ++c) {
      if (claimed_[c] || looseName(table_.labels[c]) != key) continue;
      if (found >= 0)
        throw InputError(where, "marker '" + name + "' matches both '" + table_.labels[found] + "' and '" +
                                    table_.labels[c] + "' of " + table_.source_file +
                                    " when separators are ignored (expected one; rename one of them)");
      found = int(c);
    }
    if (found >= 0) claimed_[found] = 1;
    return found;
  }

 private:
  const io::MarkerTable& table_;
  std::vector<char> claimed_;
};

std::string formatSeconds(double t) {
  std::ostringstream os;
  os << t;
  return os.str();
}

/// Model warnings for the run: unresolved meshes (IK does not need them) are summarised in one
/// line instead of one per file.
void addModelWarnings(const model::Model& m, std::vector<std::string>& out) {
  std::vector<std::string> missing;
  for (const model::Body& b : m.bodies)
    for (const model::MeshRef& mesh : b.meshes)
      if (mesh.resolved_path.empty()) missing.push_back(mesh.file);
  for (const std::string& w : m.warnings)
    if (missing.empty() || w.find("mesh file '") == std::string::npos) out.push_back(w);
  if (!missing.empty()) {
    std::string list;
    for (size_t i = 0; i < missing.size() && i < 3; ++i) list += (i ? ", " : "") + missing[i];
    if (missing.size() > 3) list += ", ...";
    out.push_back(m.source_file + ": " + std::to_string(missing.size()) + " mesh file" +
                  (missing.size() > 1 ? "s" : "") + " not found (" + list +
                  "); inverse kinematics does not need them");
  }
}

/// Warnings about the run itself: the model's, Simbody's, an unused constraint_weight, the
/// kinematics the model describes and IK leaves out.
void addRunWarnings(const IkSetup& setup, const model::Model& m, const sim::System& system, IkReport& report) {
  addModelWarnings(m, report.warnings);
  for (const auto& w : system.getWarnings()) report.warnings.push_back(w);
  if (!m.couplers.empty() && std::isfinite(setup.constraint_weight)) {
    std::ostringstream os;
    os << "constraint_weight " << setup.constraint_weight << " is not used for the " << m.couplers.size()
       << " coordinate coupler" << (m.couplers.size() > 1 ? "s" : "")
       << ": kneesim enforces couplers exactly, as OpenSim does with constraint_weight = Infinity";
    report.warnings.push_back(os.str());
  }
  if (const std::string w = model::describeIgnoredKinematics(m); !w.empty()) report.warnings.push_back(w);
}

/// What is tracked: the model markers with their data columns, the coordinate tasks.
struct TrackingPlan {
  std::vector<MarkerTask> marker_tasks;
  std::vector<int> marker_columns;
  std::vector<std::string> marker_names;
  std::vector<CoordinateTask> coord_tasks;
  std::vector<const TaskSpec*> coord_specs;
};

/// A model marker to track, before its data column is known.
struct Tracked {
  int marker;
  double weight;
  const TaskSpec* spec;
  int column = -1;
};

/// The applied tasks with a non-zero weight, as OpenSim's InverseKinematicsTool reads them: an
/// applied coordinate task must name a model coordinate; applied marker tasks restrict tracking to
/// their markers (those the model lacks are skipped, and said so); with no applied marker task
/// every model marker is tracked at weight 1. Returns the markers; the coordinate tasks go to @p plan.
std::vector<Tracked> selectTasks(const IkSetup& setup, const model::Model& m, TrackingPlan& plan, IkReport& report,
                                 bool& all_markers) {
  std::vector<Tracked> tracked;
  std::vector<std::string> not_in_model;
  bool any_marker_task = false;
  for (const TaskSpec& t : setup.tasks) {
    if (!t.apply) continue;
    if (t.kind == TaskSpec::Kind::Marker) {
      any_marker_task = true;
      const int mi = m.findMarker(t.name);
      if (mi < 0) {
        not_in_model.push_back(t.name);
        continue;
      }
      if (t.weight == 0) continue;
      tracked.push_back({mi, t.weight, &t});
    } else {
      const int ci = m.findCoordinate(t.name);
      if (ci < 0)
        throw InputError(t.where, "task names coordinate '" + t.name + "' which the model (" + setup.model_file +
                                      ") does not have");
      if (t.weight == 0) continue;
      plan.coord_tasks.push_back({ci, t.weight});
      plan.coord_specs.push_back(&t);
    }
  }
  if (!not_in_model.empty())
    report.warnings.push_back(std::to_string(not_in_model.size()) + " applied marker task" +
                              (not_in_model.size() > 1 ? "s name markers" : " names a marker") + " the model (" +
                              setup.model_file + ") does not have, not tracked: " + join(not_in_model, ", "));
  all_markers = !any_marker_task;
  if (all_markers)  // OpenSim with no task set: every model marker found in the data, weight 1
    for (size_t i = 0; i < m.markers.size(); ++i) tracked.push_back({int(i), 1.0, nullptr});
  return tracked;
}

/// Tasks -> model markers and data columns (exact names first, then ignoring separators); markers
/// not in the data are left out (said so when a task named them).
TrackingPlan planTracking(const IkSetup& setup, const model::Model& m, const io::MarkerTable& markers,
                          IkReport& report) {
  TrackingPlan plan;
  bool all_markers = false;
  std::vector<Tracked> tracked = selectTasks(setup, m, plan, report, all_markers);
  MarkerMatcher matcher(markers);
  for (Tracked& t : tracked) t.column = matcher.matchExact(m.markers[t.marker].name);
  for (Tracked& t : tracked)
    if (t.column < 0) {
      t.column = matcher.matchLoose(m.markers[t.marker].name, t.spec ? t.spec->where : setup.locate("IKTaskSet"));
      if (t.column >= 0) ++report.loose_name_matches;
    }
  std::vector<std::string> not_in_data;
  for (const Tracked& t : tracked) {
    if (t.column < 0) {
      if (!all_markers) not_in_data.push_back(m.markers[t.marker].name);
      continue;
    }
    plan.marker_tasks.push_back({t.marker, t.weight});
    plan.marker_columns.push_back(t.column);
    plan.marker_names.push_back(m.markers[t.marker].name);
  }
  if (!not_in_data.empty())
    report.warnings.push_back(std::to_string(not_in_data.size()) + " task marker" +
                              (not_in_data.size() > 1 ? "s are" : " is") + " not in " + setup.marker_file +
                              " and not tracked: " + join(not_in_data, ", "));
  if (plan.marker_tasks.empty())
    throw InputError(setup.locate(all_markers ? "marker_file" : "IKTaskSet"),
                     "no tracked marker of the model is in " + setup.marker_file +
                         " (expected marker names shared by the model and the marker file)");
  return plan;
}

/// Coordinate references from a file (the column of each from_file task, -1 for the others).
struct CoordinateFile {
  io::Storage storage;
  std::vector<int> columns;
};

CoordinateFile readCoordinateFile(const IkSetup& setup, const model::Model& m, const TrackingPlan& plan) {
  CoordinateFile file;
  file.columns.assign(plan.coord_tasks.size(), -1);
  bool need_file = false;
  for (const TaskSpec* t : plan.coord_specs) need_file = need_file || t->value_type == "from_file";
  if (!need_file) return file;
  if (setup.coordinate_file.empty())
    throw InputError(setup.locate("coordinate_file"), "a coordinate task uses from_file but no coordinate_file is given");
  if (!pathExists(setup.coordinate_file))
    throw InputError(setup.locate("coordinate_file"), "coordinate file not found: " + setup.coordinate_file);
  file.storage = io::readStorage(setup.coordinate_file);
  if (file.storage.getNumRows() == 0)
    throw InputError({setup.coordinate_file, 0, ""}, "expected at least one row of coordinate values, got none");
  for (size_t j = 0; j < plan.coord_tasks.size(); ++j) {
    if (plan.coord_specs[j]->value_type != "from_file") continue;
    const std::string& name = m.coordinates[plan.coord_tasks[j].coordinate].name;
    file.columns[j] = file.storage.findColumn(name);
    if (file.columns[j] < 0)
      throw InputError(plan.coord_specs[j]->where, "coordinate '" + name + "' is not a column of " + setup.coordinate_file);
  }
  return file;
}

/// The reference of each coordinate task at time @p t: its default value, its manual value, or the
/// file's value interpolated linearly (held constant beyond the ends), in SI units.
void calcReferences(const model::Model& m, const TrackingPlan& plan, const CoordinateFile& file, double t,
                    std::vector<double>& reference) {
  for (size_t j = 0; j < plan.coord_tasks.size(); ++j) {
    const TaskSpec& spec = *plan.coord_specs[j];
    const model::Coordinate& c = m.coordinates[plan.coord_tasks[j].coordinate];
    if (spec.value_type == "default_value") {
      reference[j] = c.default_value;
    } else if (spec.value_type == "manual_value") {
      reference[j] = spec.value;
    } else {
      const auto times = file.storage.data.col(0);
      const auto vals = file.storage.data.col(file.columns[j]);
      const Eigen::Index n = times.size();
      double v = vals[0];
      if (t >= times[n - 1]) {
        v = vals[n - 1];
      } else if (t > times[0]) {
        Eigen::Index hi = 1;
        while (times[hi] < t) ++hi;
        const double a = (t - times[hi - 1]) / (times[hi] - times[hi - 1]);
        v = (1 - a) * vals[hi - 1] + a * vals[hi];
      }
      if (file.storage.in_degrees && c.motion_type == model::MotionType::Rotational) v *= M_PI / 180.0;
      reference[j] = v;
    }
  }
}

/// Frames in the time range, as OpenSim picks them: the range is clipped to the data and each end
/// moves to the nearest frame.
std::vector<int> selectFrames(const IkSetup& setup, const io::MarkerTable& markers) {
  const double eps = 1e-9;
  const int n_frames = markers.getNumFrames();
  if (n_frames == 0 || setup.time_start > markers.time.back() + eps || setup.time_end < markers.time.front() - eps) {
    std::ostringstream os;
    os << "expected a time range overlapping the marker data (" << (markers.time.empty() ? 0.0 : markers.time.front())
       << " to " << (markers.time.empty() ? 0.0 : markers.time.back()) << " s in " << setup.marker_file << "), got "
       << setup.time_start << " to " << setup.time_end << " s";
    throw InputError(setup.locate("time_range"), os.str());
  }
  auto nearest = [&](double t) {
    int best = 0;
    for (int f = 1; f < n_frames; ++f)
      if (std::abs(markers.time[f] - t) < std::abs(markers.time[best] - t)) best = f;
    return best;
  };
  const int first = nearest(std::max(setup.time_start, markers.time.front()));
  const int last = nearest(std::min(setup.time_end, markers.time.back()));
  std::vector<int> frames;
  for (int f = first; f <= last; ++f) frames.push_back(f);
  return frames;
}

/// Per solved frame: the coordinates, each tracked marker's error (m, NaN when missing) and, when
/// asked for, the model markers' locations.
struct Solutions {
  std::vector<Eigen::VectorXd> q;
  std::vector<std::vector<double>> marker_errors;
  std::vector<std::vector<Eigen::Vector3d>> marker_locations;
};

/// Tracks the frames in order (warm starts; a frame whose tracked markers are all missing is
/// skipped, said so, and tracking restarts after it), filling the report's per-frame figures.
Solutions solveFrames(const IkSetup& setup, const IkRunOptions& options, const model::Model& m,
                      const sim::System& system, const io::MarkerTable& markers, const TrackingPlan& plan,
                      const CoordinateFile& coord_file, const std::vector<int>& frames, IkReport& report) {
  SolverOptions solver_options = setup.solver;
  solver_options.constraint_weight = setup.constraint_weight;
  Solver solver(system, plan.marker_tasks, plan.coord_tasks, solver_options);
  auto ws = system.createWorkspace();
  system.setCouplersEnabled(*ws, false);  // the solver enforces couplers and constraints itself
  system.setConstraintsEnabled(*ws, false);
  Eigen::VectorXd q = system.getDefaultCoordinates();
  const int nm = int(plan.marker_tasks.size());
  std::vector<Eigen::Vector3d> observed(nm);
  std::vector<double> reference(plan.coord_tasks.size());
  Solutions out;
  out.q.reserve(frames.size());
  out.marker_errors.reserve(frames.size());

  const auto t0 = std::chrono::steady_clock::now();
  for (size_t k = 0; k < frames.size(); ++k) {
    const int f = frames[k];
    const double t = markers.time[f];
    int present = 0;
    for (int i = 0; i < nm; ++i) {
      observed[i] = markers.getPosition(f, plan.marker_columns[i]);
      present += observed[i].allFinite() ? 1 : 0;
    }
    if (present == 0) {
      report.warnings.push_back("frame " + std::to_string(markers.frame_numbers[f]) + " (t = " + formatSeconds(t) +
                                " s) of " + setup.marker_file + ": every tracked marker is missing; frame skipped");
      solver.resetTracking();  // do not extrapolate across the gap
      continue;
    }
    calcReferences(m, plan, coord_file, t, reference);
    const FrameResult r = solver.trackFrame(*ws, observed, reference, q);
    report.iterations += r.iterations;
    report.max_constraint_error = std::max(report.max_constraint_error, r.max_constraint_error);
    report.time.push_back(t);
    report.frames.push_back(r);
    report.worst_marker.push_back(r.worst_marker >= 0 ? plan.marker_names[r.worst_marker] : "");
    out.q.push_back(q);
    out.marker_errors.push_back(solver.getLastMarkerErrors());
    if (setup.report_marker_locations) out.marker_locations.push_back(solver.getLastModelMarkers());
    if (options.progress && (k % 16 == 0 || k + 1 == frames.size())) options.progress(int(k + 1), int(frames.size()));
  }
  report.seconds_solving = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

/// The per-marker summary (frames seen, mean, RMS and largest error) and the run's mean RMS and
/// largest error.
void summarizeErrors(const TrackingPlan& plan, const io::MarkerTable& markers, const Solutions& solved,
                     IkReport& report) {
  for (size_t i = 0; i < plan.marker_tasks.size(); ++i) {
    MarkerErrorSummary s;
    s.name = plan.marker_names[i];
    s.data_label = markers.labels[plan.marker_columns[i]];
    double sum = 0, sum2 = 0;
    for (const auto& e : solved.marker_errors)
      if (std::isfinite(e[i])) {
        ++s.frames;
        sum += e[i];
        sum2 += e[i] * e[i];
        s.max = std::max(s.max, e[i]);
      }
    if (s.frames > 0) {
      s.mean = sum / s.frames;
      s.rms = std::sqrt(sum2 / s.frames);
    }
    report.markers.push_back(s);
  }
  for (const auto& r : report.frames) {
    report.mean_rms += r.rms_error / report.frames.size();
    report.max_error = std::max(report.max_error, r.max_error);
  }
}

/// The error reports (marker_errors.sto, marker_error_table.sto, marker_error_summary.csv) and the
/// model marker locations, as the setup asks, staged in @p outputs under @p prefix.
void stageReports(const IkSetup& setup, const IkReport& report, const TrackingPlan& plan, const Solutions& solved,
                  const std::string& prefix, AtomicFileSet& outputs) {
  const int nm = int(plan.marker_tasks.size());
  if (setup.report_errors) {
    io::Storage err;
    err.name = "Model Marker Errors from IK";
    err.labels = {"time", "total_squared_error", "marker_error_RMS", "marker_error_max", "markers_used"};
    err.data.resize(int(report.frames.size()), 5);
    for (size_t k = 0; k < report.frames.size(); ++k) {
      const auto& r = report.frames[k];
      err.data.row(k) << report.time[k], r.total_squared_error, r.rms_error, r.max_error, double(r.markers_used);
    }
    outputs.addContents(prefix + "marker_errors.sto", io::formatStorage(err));

    // Per-marker error table (m), NaN where the marker was missing (opensim-core#2748).
    io::Storage table;
    table.name = "Model Marker Errors per Marker from IK";
    table.labels.push_back("time");
    for (const auto& n : plan.marker_names) table.labels.push_back(n);
    table.data.resize(int(solved.marker_errors.size()), nm + 1);
    for (size_t k = 0; k < solved.marker_errors.size(); ++k) {
      table.data(k, 0) = report.time[k];
      for (int i = 0; i < nm; ++i) table.data(k, i + 1) = solved.marker_errors[k][i];
    }
    outputs.addContents(prefix + "marker_error_table.sto", io::formatStorage(table));

    std::ostringstream csv;
    csv << "marker,data_label,frames,mean_mm,rms_mm,max_mm\n" << std::setprecision(6);
    for (const auto& s : report.markers)
      csv << s.name << ',' << s.data_label << ',' << s.frames << ',' << s.mean * 1e3 << ',' << s.rms * 1e3 << ','
          << s.max * 1e3 << '\n';
    outputs.addContents(prefix + "marker_error_summary.csv", csv.str());
  }
  if (setup.report_marker_locations) {
    io::Storage loc;
    loc.name = "Model Marker Locations from IK";
    loc.labels.push_back("time");
    for (const auto& n : plan.marker_names)
      for (const char* ax : {"_tx", "_ty", "_tz"}) loc.labels.push_back(n + ax);
    loc.data.resize(int(solved.marker_locations.size()), 3 * nm + 1);
    for (size_t k = 0; k < solved.marker_locations.size(); ++k) {
      loc.data(k, 0) = report.time[k];
      for (int i = 0; i < nm; ++i) loc.data.block<1, 3>(k, 1 + 3 * i) = solved.marker_locations[k][i].transpose();
    }
    outputs.addContents(prefix + "model_marker_locations.sto", io::formatStorage(loc));
  }
}

}  // namespace

IkReport runIk(const IkSetup& setup, const IkRunOptions& options) {
  model::ModelPtr model = loadModel(setup);
  if (!pathExists(setup.marker_file))
    throw InputError(setup.locate("marker_file"), "marker file not found: " + setup.marker_file);
  return runIk(setup, std::move(model), io::readMarkerFile(setup.marker_file), options);
}

IkReport runIk(const IkSetup& setup, model::ModelPtr model, io::MarkerTable markers, const IkRunOptions& options) {
  KNEESIM_CHECK(model != nullptr, "runIk needs a model");
  IkReport report;
  report.model = model;
  const model::Model& m = *model;
  sim::System system(model);
  addRunWarnings(setup, m, system, report);
  if (!setup.marker_rotation_deg.isZero()) {
    const Eigen::Matrix3d R = model::poseFromXYZ(setup.marker_rotation_deg * (M_PI / 180.0), Eigen::Vector3d::Zero()).linear();
    for (Eigen::Vector3d& p : markers.positions)
      if (p.allFinite()) p = R * p;
  }
  const TrackingPlan plan = planTracking(setup, m, markers, report);
  const CoordinateFile coord_file = readCoordinateFile(setup, m, plan);
  const std::vector<int> frames = selectFrames(setup, markers);
  report.frames_total = int(frames.size());
  const Solutions solved = solveFrames(setup, options, m, system, markers, plan, coord_file, frames, report);
  report.frames_solved = int(solved.q.size());
  report.constraints = int(m.constraints.size());
  report.constraint_weight = setup.constraint_weight;
  if (solved.q.empty())
    throw InputError({setup.marker_file, 0, ""}, "expected at least one frame with a tracked marker in the time range, "
                                                 "got every tracked marker missing in every frame");
  summarizeErrors(plan, markers, solved, report);

  // Outputs: all prepared, then committed together.
  io::Storage motion = makeMotion(m, "Coordinates", report.time, solved.q);  // OpenSim's name for the IK motion
  if (!options.write) {
    report.motion = std::move(motion);
    return report;
  }
  AtomicFileSet own_outputs;
  AtomicFileSet& outputs = options.stage ? *options.stage : own_outputs;
  const size_t staged_before = outputs.getPaths().size();
  outputs.addContents(setup.output_motion_file, io::formatStorage(motion));
  const std::string prefix =
      (fs::path(setup.results_directory) / ((setup.name.empty() ? std::string() : setup.name + "_") + "ik_")).string();
  stageReports(setup, report, plan, solved, prefix, outputs);
  report.motion = std::move(motion);
  if (!options.stage) own_outputs.commit();
  const std::vector<std::string> paths = outputs.getPaths();
  report.outputs.assign(paths.begin() + long(staged_before), paths.end());
  return report;
}

io::Storage makeMotion(const model::Model& m, const std::string& name, const std::vector<double>& time,
                       const std::vector<Eigen::VectorXd>& q) {
  KNEESIM_CHECK(time.size() == q.size(), "one time per pose");
  const double deg = 180.0 / M_PI;
  const int nq = int(m.coordinates.size());
  io::Storage motion;
  motion.name = name;
  motion.in_degrees = true;
  motion.labels.push_back("time");
  for (const auto& c : m.coordinates) motion.labels.push_back(c.name);
  motion.data.resize(int(q.size()), nq + 1);
  for (size_t k = 0; k < q.size(); ++k) {
    motion.data(k, 0) = time[k];
    for (int c = 0; c < nq; ++c)
      motion.data(k, c + 1) = q[k][c] * (m.coordinates[c].motion_type == model::MotionType::Rotational ? deg : 1.0);
  }
  return motion;
}

void printIkSummary(const IkReport& report, std::ostream& os) {
  const auto flags = os.flags();
  const auto precision = os.precision();
  os << std::fixed << std::setprecision(2);
  os << "IK: " << report.frames_solved << " of " << report.frames_total << " frames solved in "
     << report.seconds_solving * 1e3 << " ms ("
     << (report.frames_solved > 0 ? report.seconds_solving * 1e6 / report.frames_solved : 0.0) << " us/frame, "
     << (report.frames_solved > 0 ? double(report.iterations) / report.frames_solved : 0.0) << " iterations/frame)\n";
  os << "marker error: mean RMS " << report.mean_rms * 1e3 << " mm, max " << report.max_error * 1e3 << " mm\n";
  if (report.constraints > 0)
    os << report.constraints << " constraint" << (report.constraints > 1 ? "s " : " ")
       << (std::isfinite(report.constraint_weight) ? "penalised (constraint_weight " + formatSignificant(report.constraint_weight, 6) + ")"
                                                   : std::string("enforced"))
       << ": largest violation " << std::scientific << std::setprecision(2) << report.max_constraint_error << std::fixed
       << " (m, or rad for a weld's orientation)\n";
  if (report.loose_name_matches > 0)
    os << report.loose_name_matches << " marker names matched ignoring '.', '_', '-' and ' ' (see data label)\n";
  os << "per-marker error (mm):\n  " << std::left << std::setw(22) << "marker" << std::setw(20) << "data label"
     << std::right << std::setw(7) << "frames" << std::setw(9) << "mean" << std::setw(9) << "rms" << std::setw(9)
     << "max" << "\n";
  for (const auto& s : report.markers)
    os << "  " << std::left << std::setw(22) << s.name << std::setw(20) << s.data_label << std::right << std::setw(7)
       << s.frames << std::setw(9) << s.mean * 1e3 << std::setw(9) << s.rms * 1e3 << std::setw(9) << s.max * 1e3
       << "\n";
  // The three worst frames by RMS.
  std::vector<size_t> order(report.frames.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return report.frames[a].rms_error > report.frames[b].rms_error; });
  if (!order.empty()) {
    os << "worst frames (RMS, max, worst marker):\n";
    for (size_t k = 0; k < order.size() && k < 3; ++k) {
      const size_t i = order[k];
      os << "  t = " << std::setprecision(4) << report.time[i] << " s: " << std::setprecision(2)
         << report.frames[i].rms_error * 1e3 << " mm, " << report.frames[i].max_error * 1e3 << " mm, "
         << report.worst_marker[i] << "\n";
    }
  }
  for (const auto& w : report.warnings) os << "warning: " << w << "\n";
  for (const auto& o : report.outputs) os << "wrote " << o << "\n";
  os.flags(flags);
  os.precision(precision);
}

}  // namespace kneesim::ik
