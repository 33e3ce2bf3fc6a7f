#include "ik/tool.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <map>
#include <ostream>
#include <set>
#include <sstream>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "io/marker_table.hpp"
#include "io/storage.hpp"
#include "model/osim_reader.hpp"
#include "model/urdf.hpp"

namespace kneesim::ik {

namespace fs = std::filesystem;

namespace {

std::string resolve(const std::string& base_dir, const std::string& p) {
  if (p.empty()) return p;
  const fs::path path(p);
  return path.is_absolute() ? p : (fs::path(base_dir) / path).lexically_normal().string();
}

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

std::vector<TaskSpec> readTaskFile(const std::string& path) {
  auto doc = xml::Document::load(path);
  xml::Node root = doc->root();
  xml::Node set = root.name() == "IKTaskSet" ? root : root.child("IKTaskSet");
  if (!set) root.fail("no <IKTaskSet> in task file");
  std::vector<TaskSpec> tasks;
  readTaskSet(set, tasks);
  return tasks;
}

IkSetup readIkSetup(const std::string& path) {
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

  static const std::set<std::string> known = {
      "model_file",  "constraint_weight",      "accuracy",          "IKTaskSet",     "marker_file",
      "coordinate_file", "time_range",         "report_errors",     "output_motion_file",
      "report_marker_locations", "results_directory", "input_directory", "max_iterations"};
  for (const xml::Node& c : tool.children())
    if (!known.count(c.name()))
      c.fail("unknown element <" + c.name() +
             "> in InverseKinematicsTool (expected one of model_file, marker_file, IKTaskSet, coordinate_file, "
             "time_range, accuracy, constraint_weight, output_motion_file, results_directory, report_errors, "
             "report_marker_locations)");

  s.model_file = resolve(dir, tool.childText("model_file"));
  if (s.model_file.empty()) tool.fail("missing <model_file>");
  s.marker_file = resolve(dir, tool.childText("marker_file"));
  if (s.marker_file.empty()) tool.fail("missing <marker_file>");
  const std::string coord = tool.childText("coordinate_file");
  if (!coord.empty() && coord != "Unassigned") s.coordinate_file = resolve(dir, coord);
  std::string out = tool.childText("output_motion_file");
  if (out.empty() || out == "Unassigned") out = (s.name.empty() ? std::string("ik") : s.name) + "_ik.mot";
  s.output_motion_file = resolve(dir, out);
  std::string results = tool.childText("results_directory");
  if (results.empty() || results == "Unassigned") results = ".";
  s.results_directory = resolve(dir, results);

  if (xml::Node cw = tool.child("constraint_weight"); cw && !cw.text().empty()) s.constraint_weight = cw.toDouble();
  s.accuracy = tool.childDouble("accuracy", 1e-5);
  if (!(s.accuracy > 0)) tool.child("accuracy").fail("expected accuracy > 0, got " + tool.childText("accuracy"));
  s.solver.step_tolerance = std::min(1e-9, s.accuracy * 1e-3);
  if (xml::Node mi = tool.child("max_iterations")) s.solver.max_iterations = int(mi.toInt());
  if (xml::Node tr = tool.child("time_range"); tr && !tr.text().empty()) {
    const auto v = tr.toDoubles();
    if (v.size() != 2) tr.fail("expected 2 numbers (start end), got " + std::to_string(v.size()));
    if (v[0] > v[1]) tr.fail("expected start <= end, got " + tr.text());
    s.time_start = v[0];
    s.time_end = v[1];
  }
  s.report_errors = tool.childBool("report_errors", true);
  s.report_marker_locations = tool.childBool("report_marker_locations", false);

  if (xml::Node set = tool.child("IKTaskSet")) {
    if (auto file = set.attr("file"); file && !trim(*file).empty() && *file != "Unassigned") {
      const std::string task_path = resolve(dir, std::string(trim(*file)));
      if (!fs::exists(task_path)) set.fail("IKTaskSet file not found: " + task_path);
      s.tasks = readTaskFile(task_path);
    } else {
      readTaskSet(set, s.tasks);
    }
  }
  return s;
}

namespace {

model::ModelPtr loadModel(const std::string& path, const SourceLocation& where) {
  if (!fs::exists(path)) throw InputError(where, "model file not found: " + path);
  const std::string low = toLower(path);
  if (endsWith(low, ".urdf")) return model::readUrdf(path);
  return model::readOsim(path);
}

}  // namespace

IkReport runIk(const IkSetup& setup, const IkRunOptions& options) {
  IkReport report;
  const SourceLocation at_setup{setup.setup_file, 0, ""};
  model::ModelPtr model = loadModel(setup.model_file, {setup.setup_file, 0, "model_file"});
  const model::Model& m = *model;
  sim::System system(model);
  for (const auto& w : system.getWarnings()) report.warnings.push_back(w);

  if (!fs::exists(setup.marker_file))
    throw InputError({setup.setup_file, 0, "marker_file"}, "marker file not found: " + setup.marker_file);
  const io::MarkerTable markers = io::readMarkerFile(setup.marker_file);

  // Tasks -> model indices. A task naming something the model lacks is an error: the user
  // asked for it, and silently dropping it changes the answer.
  std::vector<MarkerTask> marker_tasks;
  std::vector<int> marker_columns;
  std::vector<std::string> marker_names;
  std::vector<CoordinateTask> coord_tasks;
  std::vector<const TaskSpec*> coord_specs;
  std::set<std::string> tasked;
  for (const TaskSpec& t : setup.tasks) {
    if (t.kind == TaskSpec::Kind::Marker) {
      const int mi = m.findMarker(t.name);
      if (mi < 0) throw InputError(t.where, "task names marker '" + t.name + "' which the model (" + setup.model_file + ") does not have");
      tasked.insert(t.name);
      if (!t.apply || t.weight == 0) continue;
      const int col = markers.findMarker(t.name);
      if (col < 0) {
        report.warnings.push_back("marker '" + t.name + "' is in the task set but not in " + setup.marker_file + "; ignored");
        continue;
      }
      marker_tasks.push_back({mi, t.weight});
      marker_columns.push_back(col);
      marker_names.push_back(t.name);
    } else {
      const int ci = m.findCoordinate(t.name);
      if (ci < 0) throw InputError(t.where, "task names coordinate '" + t.name + "' which the model does not have");
      if (!t.apply || t.weight == 0) continue;
      coord_tasks.push_back({ci, t.weight});
      coord_specs.push_back(&t);
    }
  }
  if (setup.tasks.empty()) {
    // OpenSim with no task set: every model marker found in the data, weight 1.
    for (size_t i = 0; i < m.markers.size(); ++i) {
      const int col = markers.findMarker(m.markers[i].name);
      if (col < 0) continue;
      marker_tasks.push_back({int(i), 1.0});
      marker_columns.push_back(col);
      marker_names.push_back(m.markers[i].name);
    }
  }
  if (marker_tasks.empty())
    throw InputError(at_setup, "no marker task matches a marker of " + setup.marker_file +
                                   " (expected IKMarkerTask names that are both model and data markers)");

  // Coordinate references from a file, interpolated at marker frame times.
  io::Storage coord_file;
  bool need_file = false;
  for (const TaskSpec* t : coord_specs) need_file = need_file || t->value_type == "from_file";
  if (need_file) {
    if (setup.coordinate_file.empty())
      throw InputError({setup.setup_file, 0, "coordinate_file"}, "a coordinate task uses from_file but no coordinate_file is given");
    if (!fs::exists(setup.coordinate_file))
      throw InputError({setup.setup_file, 0, "coordinate_file"}, "coordinate file not found: " + setup.coordinate_file);
    coord_file = io::readStorage(setup.coordinate_file);
  }

  // Frames in the time range.
  std::vector<int> frames;
  const double eps = 1e-9;
  for (int f = 0; f < markers.getNumFrames(); ++f)
    if (markers.time[f] >= setup.time_start - eps && markers.time[f] <= setup.time_end + eps) frames.push_back(f);
  if (frames.empty()) {
    std::ostringstream os;
    os << "time range " << setup.time_start << " to " << setup.time_end << " s lies outside the marker data ("
       << (markers.time.empty() ? 0.0 : markers.time.front()) << " to "
       << (markers.time.empty() ? 0.0 : markers.time.back()) << " s)";
    throw InputError({setup.setup_file, 0, "time_range"}, os.str());
  }
  report.frames_total = int(frames.size());

  Solver solver(system, marker_tasks, coord_tasks, setup.solver);
  auto ws = system.createWorkspace();
  Eigen::VectorXd q = system.getDefaultCoordinates();
  std::vector<Eigen::Vector3d> observed(marker_tasks.size());
  std::vector<double> reference(coord_tasks.size());

  const int nq = system.getNumCoordinates();
  const int nm = int(marker_tasks.size());
  std::vector<Eigen::VectorXd> solutions;
  std::vector<std::vector<double>> marker_errors;
  std::vector<std::vector<Eigen::Vector3d>> marker_locations;
  solutions.reserve(frames.size());

  const auto t0 = std::chrono::steady_clock::now();
  for (size_t k = 0; k < frames.size(); ++k) {
    const int f = frames[k];
    const double t = markers.time[f];
    int present = 0;
    for (int i = 0; i < nm; ++i) {
      observed[i] = markers.getPosition(f, marker_columns[i]);
      present += observed[i].allFinite() ? 1 : 0;
    }
    if (present == 0) {
      std::ostringstream os;
      os << "frame " << markers.frame_numbers[f] << " (t = " << t << " s): every tracked marker is missing; frame skipped";
      report.warnings.push_back(os.str());
      continue;
    }
    for (size_t j = 0; j < coord_tasks.size(); ++j) {
      const TaskSpec& spec = *coord_specs[j];
      const model::Coordinate& c = m.coordinates[coord_tasks[j].coordinate];
      if (spec.value_type == "default_value") {
        reference[j] = c.default_value;
      } else if (spec.value_type == "manual_value") {
        reference[j] = spec.value;
      } else {
        const int col = coord_file.findColumn(c.name);
        if (col < 0)
          throw InputError(spec.where, "coordinate '" + c.name + "' is not a column of " + setup.coordinate_file);
        const Eigen::VectorXd times = coord_file.data.col(0);
        const Eigen::VectorXd vals = coord_file.data.col(col);
        // Linear interpolation, clamped at the ends.
        double v = vals[0];
        if (t >= times[times.size() - 1]) {
          v = vals[vals.size() - 1];
        } else if (t > times[0]) {
          int hi = 1;
          while (times[hi] < t) ++hi;
          const double a = (t - times[hi - 1]) / (times[hi] - times[hi - 1]);
          v = (1 - a) * vals[hi - 1] + a * vals[hi];
        }
        if (coord_file.in_degrees && c.motion_type == model::MotionType::Rotational) v *= M_PI / 180.0;
        reference[j] = v;
      }
    }
    const FrameResult r = solver.solveFrame(*ws, observed, reference, q);
    report.time.push_back(t);
    report.frames.push_back(r);
    report.worst_marker.push_back(r.worst_marker >= 0 ? marker_names[r.worst_marker] : "");
    solutions.push_back(q);
    marker_errors.push_back(solver.getLastMarkerErrors());
    if (setup.report_marker_locations) marker_locations.push_back(solver.getLastModelMarkers());
    if (options.progress && (k % 16 == 0 || k + 1 == frames.size())) options.progress(int(k + 1), int(frames.size()));
  }
  report.seconds_solving = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  report.frames_solved = int(solutions.size());
  if (solutions.empty()) throw InputError({setup.marker_file, 0, ""}, "no frame could be solved: every tracked marker is missing in every frame");

  // Per-marker summary.
  for (int i = 0; i < nm; ++i) {
    MarkerErrorSummary s;
    s.name = marker_names[i];
    double sum = 0, sum2 = 0;
    for (const auto& e : marker_errors)
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

  // Outputs, all prepared before any is written.
  const double deg = 180.0 / M_PI;
  io::Storage motion;
  motion.name = setup.name.empty() ? "ik" : setup.name;
  motion.in_degrees = true;
  motion.labels.push_back("time");
  for (const auto& c : m.coordinates) motion.labels.push_back(c.name);
  motion.data.resize(int(solutions.size()), nq + 1);
  for (size_t k = 0; k < solutions.size(); ++k) {
    motion.data(k, 0) = report.time[k];
    for (int c = 0; c < nq; ++c)
      motion.data(k, c + 1) =
          solutions[k][c] * (m.coordinates[c].motion_type == model::MotionType::Rotational ? deg : 1.0);
  }
  io::writeStorage(setup.output_motion_file, motion);
  report.outputs.push_back(setup.output_motion_file);

  const std::string prefix = (fs::path(setup.results_directory) / (motion.name + "_ik_")).string();
  if (setup.report_errors) {
    io::Storage err;
    err.name = motion.name + " marker errors";
    err.labels = {"time", "total_squared_error", "marker_error_RMS", "marker_error_max", "markers_used"};
    err.data.resize(int(report.frames.size()), 5);
    for (size_t k = 0; k < report.frames.size(); ++k) {
      const auto& r = report.frames[k];
      err.data.row(k) << report.time[k], r.total_squared_error, r.rms_error, r.max_error, double(r.markers_used);
    }
    io::writeStorage(prefix + "marker_errors.sto", err);
    report.outputs.push_back(prefix + "marker_errors.sto");

    // Per-marker error table (m), NaN where the marker was missing (opensim-core#2748).
    io::Storage table;
    table.name = motion.name + " per-marker errors";
    table.labels.push_back("time");
    for (const auto& n : marker_names) table.labels.push_back(n);
    table.data.resize(int(marker_errors.size()), nm + 1);
    for (size_t k = 0; k < marker_errors.size(); ++k) {
      table.data(k, 0) = report.time[k];
      for (int i = 0; i < nm; ++i) table.data(k, i + 1) = marker_errors[k][i];
    }
    io::writeStorage(prefix + "marker_error_table.sto", table);
    report.outputs.push_back(prefix + "marker_error_table.sto");
  }
  if (setup.report_marker_locations) {
    io::Storage loc;
    loc.name = motion.name + " model marker locations";
    loc.labels.push_back("time");
    for (const auto& n : marker_names)
      for (const char* ax : {"_tx", "_ty", "_tz"}) loc.labels.push_back(n + ax);
    loc.data.resize(int(marker_locations.size()), 3 * nm + 1);
    for (size_t k = 0; k < marker_locations.size(); ++k) {
      loc.data(k, 0) = report.time[k];
      for (int i = 0; i < nm; ++i) loc.data.block<1, 3>(k, 1 + 3 * i) = marker_locations[k][i].transpose();
    }
    io::writeStorage(prefix + "model_marker_locations.sto", loc);
    report.outputs.push_back(prefix + "model_marker_locations.sto");
  }
  return report;
}

void printIkSummary(const IkReport& report, std::ostream& os) {
  os << std::fixed << std::setprecision(2);
  os << "IK: " << report.frames_solved << " of " << report.frames_total << " frames solved in "
     << report.seconds_solving * 1e3 << " ms ("
     << (report.frames_solved > 0 ? report.seconds_solving * 1e6 / report.frames_solved : 0.0) << " us/frame)\n";
  os << "marker RMS error: mean " << report.mean_rms * 1e3 << " mm, max marker error " << report.max_error * 1e3
     << " mm\n";
  os << "per-marker error (mm):\n  " << std::left << std::setw(24) << "marker" << std::right << std::setw(8)
     << "frames" << std::setw(9) << "mean" << std::setw(9) << "rms" << std::setw(9) << "max" << "\n";
  for (const auto& s : report.markers)
    os << "  " << std::left << std::setw(24) << s.name << std::right << std::setw(8) << s.frames << std::setw(9)
       << s.mean * 1e3 << std::setw(9) << s.rms * 1e3 << std::setw(9) << s.max * 1e3 << "\n";
  for (const auto& w : report.warnings) os << "warning: " << w << "\n";
  for (const auto& o : report.outputs) os << "wrote " << o << "\n";
  os.unsetf(std::ios::floatfield);
}

}  // namespace kneesim::ik
