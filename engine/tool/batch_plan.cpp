// Gives a manifest's rows their meaning and lays out each trial's folder and setup files.
#include "tool/batch_plan.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <set>

#include "core/atomic_file.hpp"
#include "core/paths.hpp"
#include "core/strings.hpp"
#include "tool/batch_setups.hpp"

namespace kneesim::tool {

namespace fs = std::filesystem;

namespace {

const std::set<std::string> kTools = {"ik", "contact", "workflow"};

std::string textOr(const ManifestRow& row, const std::string& column, const std::string& fallback) {
  const ManifestValue* v = row.find(column);
  return v ? v->text : fallback;
}

const ManifestValue& require(const ManifestRow& row, const std::string& column, const std::string& why) {
  const ManifestValue* v = row.find(column);
  if (!v) throw InputError({row.where.file, row.where.line, row.where.element + "/" + column}, "expected " + why + ", got an empty cell");
  return *v;
}

// Folder and file names are built from subject and trial: keep them portable.
std::string checkName(const ManifestValue& v) {
  for (char c : v.text)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.'))
      throw InputError(v.where, "expected letters, digits, '.', '_' or '-' (it names folders and files), got '" + v.text + "'");
  if (v.text.front() == '.') throw InputError(v.where, "expected a name not starting with '.', got '" + v.text + "'");
  return v.text;
}

// An input file named by a cell: resolved against the manifest's folder, made absolute, required.
std::string inputFile(const ManifestValue* v, const std::string& dir) {
  if (!v) return "";
  const fs::path p = fs::path(v->text).is_absolute() ? fs::path(v->text) : fs::absolute(fs::path(dir) / v->text);
  const std::string path = p.lexically_normal().string();
  if (fs::is_directory(path)) throw InputError(v->where, "expected a file, got a folder: " + path);
  if (!fs::is_regular_file(path)) throw InputError(v->where, "file not found: " + path);
  return path;
}

double positive(const ManifestValue* v, double fallback, const std::string& what) {
  if (!v) return fallback;
  const double x = parseDouble(v->text, v->where);
  if (!(x > 0) || !std::isfinite(x)) throw InputError(v->where, "expected " + what + " > 0, got '" + v->text + "'");
  return x;
}

// "a b" with both numbers (and, for a time range, a <= b); @p n numbers in all.
std::string numbers(const ManifestValue* v, size_t n, const std::string& what, bool ordered = false) {
  if (!v) return "";
  const auto words = splitWhitespace(v->text);
  std::vector<double> x;
  for (std::string_view w : words) x.push_back(parseDouble(w, v->where));
  if (x.size() != n) throw InputError(v->where, "expected " + what + ", got '" + v->text + "'");
  if (ordered && x[0] > x[1]) throw InputError(v->where, "expected " + what + " with start <= end, got '" + v->text + "'");
  return join(words, " ");
}

std::vector<std::string> readTools(const ManifestValue& v) {
  std::string text = v.text;
  for (char& c : text)
    if (c == ';' || c == '+' || c == ',') c = ' ';
  std::vector<std::string> tools;
  for (std::string_view w : splitWhitespace(text)) {
    const std::string t = toLower(w);
    if (!kTools.count(t)) throw InputError(v.where, "expected tools among ik, contact, workflow, got '" + t + "'");
    for (const std::string& prev : tools)
      if (prev == t) throw InputError(v.where, "tool '" + t + "' is named twice");
    tools.push_back(t);
  }
  if (tools.empty()) throw InputError(v.where, "expected at least one tool (ik, contact, workflow), got none");
  // They run in their natural order whatever the cell's order: ik makes the motion the others read.
  std::vector<std::string> ordered;
  for (const char* t : {"ik", "contact", "workflow"})
    for (const std::string& x : tools)
      if (x == t) ordered.push_back(x);
  return ordered;
}

// The workflow's window from the activity: stance for gait and stairs (heel strike to toe-off on
// the force plates), the whole trial for anything else.
std::string windowFor(const std::string& activity) {
  const std::string a = toLower(activity);
  if (startsWith(a, "gait") || startsWith(a, "walk") || startsWith(a, "stair")) return "stance";
  return "trial";
}

}  // namespace

BatchTrialSpec readBatchTrialSpec(const ManifestRow& row, const std::string& manifest_dir) {
  BatchTrialSpec s;
  s.where = row.where;
  s.subject = checkName(require(row, "subject", "a subject name"));
  s.trial = checkName(require(row, "trial", "a trial name"));
  s.name = s.subject + "_" + s.trial;
  s.tools = readTools(require(row, "tools", "the tools to run (ik, contact, workflow)"));
  const auto runs = [&](const char* t) { return std::find(s.tools.begin(), s.tools.end(), t) != s.tools.end(); };
  s.model = inputFile(&require(row, "model", "a model file"), manifest_dir);
  s.activity = textOr(row, "activity", "");
  if (runs("ik")) s.markers = inputFile(&require(row, "markers", "a marker file for ik"), manifest_dir);
  else s.markers = inputFile(row.find("markers"), manifest_dir);
  s.ik_tasks = inputFile(row.find("ik_tasks"), manifest_dir);
  s.time_range = numbers(row.find("time_range"), 2, "two times 'start end' (s)", true);
  s.marker_rotation = numbers(row.find("marker_rotation"), 3, "three angles 'x y z' (deg)");
  s.accuracy = positive(row.find("accuracy"), s.accuracy, "an accuracy");
  s.motion = inputFile(row.find("motion"), manifest_dir);
  const bool needs_motion = runs("contact") || runs("workflow");
  if (needs_motion && !runs("ik") && s.motion.empty())
    require(row, "motion", "a motion for contact/workflow (or ik among the tools)");
  if (needs_motion) {
    s.femoral_component = inputFile(&require(row, "femoral_component", "the femoral component's STL"), manifest_dir);
    s.insert = inputFile(&require(row, "insert", "the insert's STL"), manifest_dir);
  }
  if (runs("workflow")) s.knee_forces = inputFile(&require(row, "knee_forces", "measured knee forces for workflow"), manifest_dir);
  s.c3d = inputFile(row.find("c3d"), manifest_dir);
  if (s.c3d.empty() && endsWith(toLower(s.markers), ".c3d")) s.c3d = s.markers;
  s.window = textOr(row, "window", windowFor(s.activity));
  s.femoral_body = textOr(row, "femoral_body", s.femoral_body);
  s.insert_body = textOr(row, "insert_body", s.insert_body);
  s.femoral_mesh = textOr(row, "femoral_mesh", "");
  s.insert_mesh = textOr(row, "insert_mesh", "");
  s.threshold = positive(row.find("threshold"), s.threshold, "a threshold (m)");
  s.distance_provider = textOr(row, "distance_provider", s.distance_provider);
  s.body_mass = positive(row.find("body_mass"), 0.0, "a body mass (kg)");
  if (const ManifestValue* v = row.find("plots")) s.plots = parseBool(v->text, v->where);
  return s;
}

std::string calcSetupHash(const std::vector<std::string>& contents) {
  std::uint64_t h = 14695981039346656037ull;
  for (const std::string& c : contents) {
    for (unsigned char ch : c) h = (h ^ ch) * 1099511628211ull;
    h = (h ^ 0xffu) * 1099511628211ull;  // separates the files
  }
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

std::vector<BatchTrialPlan> planBatch(const Manifest& manifest, const std::string& output_dir) {
  const std::string manifest_dir = fs::absolute(fs::path(manifest.file)).parent_path().string();
  const fs::path out = fs::absolute(fs::path(output_dir)).lexically_normal();
  std::vector<BatchTrialPlan> plans;
  std::set<std::string> names;
  for (const ManifestRow& row : manifest.rows) {
    BatchTrialPlan p;
    p.spec = readBatchTrialSpec(row, manifest_dir);
    if (!names.insert(p.spec.subject + "/" + p.spec.trial).second)
      throw InputError(row.where, "subject " + p.spec.subject + " has trial " + p.spec.trial +
                                      " twice (each trial writes its own folder)");
    const BatchTrialSpec& s = p.spec;
    p.folder = (out / s.subject / s.trial).string();
    const auto inFolder = [&](const std::string& f) { return (fs::path(p.folder) / f).string(); };
    p.setup_file = inFolder(BatchTrialFiles::batchSetup(s.name));
    p.setup_files.emplace_back(p.setup_file, makeBatchTrialSetup(s));
    for (const std::string& t : s.tools) p.setup_files.emplace_back(inFolder(BatchTrialFiles::toolSetup(s.name, t)), makeToolSetup(s, t));
    std::vector<std::string> contents;
    for (const auto& f : p.setup_files) contents.push_back(f.second);
    p.setup_hash = calcSetupHash(contents);
    p.log_file = inFolder(BatchTrialFiles::log(s.name));
    p.summary_file = inFolder(BatchTrialFiles::summary(s.name));
    p.completion_file = inFolder(BatchTrialFiles::completion(s.name));
    p.failure_file = inFolder(BatchTrialFiles::failure(s.name));
    plans.push_back(std::move(p));
  }
  return plans;
}

void writeTrialSetups(const BatchTrialPlan& plan) {
  createFolder(plan.folder);
  for (const auto& [path, text] : plan.setup_files) {
    std::error_code ec;
    if (fs::is_regular_file(path, ec) && readFileText(path) == text) continue;
    // C++17 lambdas cannot capture structured bindings (g++ allows it, clang does not).
    const std::string& contents = text;
    writeFileAtomically(path, [&](std::ostream& os) { os << contents; });
  }
}

}  // namespace kneesim::tool
