// Runs one batch trial's tool setups in order, then writes its summary and completion marker.
#include "tool/batch_trial.hpp"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <regex>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/json.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "ik/tool.hpp"
#include "tool/batch_completion.hpp"
#include "tool/batch_plan.hpp"
#include "tool/batch_setups.hpp"
#include "tool/contact_area_tool.hpp"
#include "tool/knee_contact_workflow.hpp"

namespace kneesim::tool {

namespace fs = std::filesystem;
using nlohmann::json;

BatchTrialSetup readBatchTrialSetup(const std::string& path) {
  auto doc = xml::Document::load(path);
  const xml::Node tool = xml::requireSetupElement(*doc, "BatchTrial");
  xml::checkChildren(tool, {"subject", "trial", "activity", "setup_files"});
  BatchTrialSetup s;
  s.setup_file = path;
  const std::string dir = fs::path(path).parent_path().string();
  s.name = tool.nameAttr();
  if (s.name.empty()) tool.fail("expected a name=\"...\" attribute (the prefix of the trial's files), got none");
  s.subject = tool.childText("subject");
  s.trial = tool.childText("trial");
  s.activity = tool.childText("activity");
  const xml::Node files = tool.requireChild("setup_files");
  for (const std::string& f : files.toWords()) {
    const std::string p = xml::resolvePath(dir, f);
    std::error_code ec;  // a name too long for the system is not found either (not a filesystem_error)
    if (!fs::is_regular_file(p, ec)) files.fail("setup file not found: " + p);
    s.setup_files.push_back(p);
  }
  if (s.setup_files.empty()) files.fail("expected at least one setup file, got none");
  s.summary_file = xml::resolvePath(dir, BatchTrialFiles::summary(s.name));
  s.completion_file = xml::resolvePath(dir, BatchTrialFiles::completion(s.name));
  s.failure_file = xml::resolvePath(dir, BatchTrialFiles::failure(s.name));
  return s;
}

namespace {

double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Files a killed run may leave: AtomicFile's hidden temporaries and backups (".x.sto.tmp123").
void removeLeftovers(const std::string& folder) {
  static const std::regex leftover(R"(\..+\.(tmp|old)[0-9]+)");
  std::error_code ec;
  std::vector<fs::path> doomed;
  for (auto it = fs::recursive_directory_iterator(folder, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec))
    if (it->is_regular_file(ec) && std::regex_match(it->path().filename().string(), leftover)) doomed.push_back(it->path());
  for (const fs::path& p : doomed) fs::remove(p, ec);
}

void removeFile(const std::string& path) {
  std::error_code ec;
  fs::remove(path, ec);
}

void peakArea(const contact::ContactSeries& series, TrialFigures& f) {
  for (size_t i = 0; i < series.frames.size(); ++i)
    if (!(series.frames[i].S * 1e6 <= f.contact_peak_mm2)) {
      f.contact_peak_mm2 = series.frames[i].S * 1e6;
      f.contact_peak_time = series.time[i];
    }
}

void runIkStep(const std::string& path, const RunOptions& options, BatchTrialReport& r) {
  ik::IkRunOptions ro;
  if (options.progress) ro.progress = [&](int d, int t) { options.progress("IK", d, t); };
  const ik::IkReport ik = ik::runIk(ik::readIkSetup(path), ro);
  if (options.out) ik::printIkSummary(ik, *options.out);
  r.figures.ik_frames = ik.frames_solved;
  r.figures.marker_rms_mm = ik.mean_rms * 1e3;
  r.figures.marker_max_mm = ik.max_error * 1e3;
  r.outputs.insert(r.outputs.end(), ik.outputs.begin(), ik.outputs.end());
}

void runContactStep(const std::string& path, const RunOptions& options, BatchTrialReport& r) {
  const ContactAreaReport c = runContactArea(readContactAreaSetup(path), {options.progress});
  if (options.out) printContactAreaSummary(c, *options.out);
  peakArea(c.series, r.figures);
  r.outputs.insert(r.outputs.end(), c.outputs.begin(), c.outputs.end());
}

void runWorkflowStep(const std::string& path, const RunOptions& options, BatchTrialReport& r) {
  const WorkflowReport w = runWorkflow(readWorkflowSetup(path), options);
  if (options.out) printWorkflowSummary(w, *options.out);
  KNEESIM_CHECK(w.trials.size() == 1, "a batch trial's workflow has one trial");
  const WorkflowTrialResult& t = w.trials.front();
  TrialFigures& f = r.figures;
  if (std::isnan(f.contact_peak_mm2)) peakArea(t.contact, f);
  const identify::FitMetrics& m = t.window_prediction.metrics;
  f.force_rmse_n = m.rmse;
  f.force_rmse_bw = m.rmse_bw;
  f.force_r2 = m.r2;
  f.force_peak_measured_n = m.peak_measured;
  f.force_trial_rmse_n = t.trial_prediction.metrics.rmse;
  for (const identify::DerivedResult& d : w.fit.derived) f.law.emplace_back(d.name, d.value);
  r.outputs.insert(r.outputs.end(), w.outputs.begin(), w.outputs.end());
}

json figuresJson(const BatchTrialReport& r) {
  const TrialFigures& f = r.figures;
  json law = json::object();
  for (const auto& [k, v] : f.law) law[k] = jsonNumber(v);
  return {{"name", r.name},
          {"subject", r.subject},
          {"trial", r.trial},
          {"activity", r.activity},
          {"tools", r.tools},
          {"ik", {{"frames", f.ik_frames}, {"marker_rms_mean_mm", jsonNumber(f.marker_rms_mm)},
                  {"marker_error_max_mm", jsonNumber(f.marker_max_mm)}}},
          {"contact_area", {{"peak_mm2", jsonNumber(f.contact_peak_mm2)}, {"peak_time_s", jsonNumber(f.contact_peak_time)}}},
          {"force", {{"window", f.force_window},
                     {"rmse_N", jsonNumber(f.force_rmse_n)},
                     {"rmse_bw", jsonNumber(f.force_rmse_bw)},
                     {"r2", jsonNumber(f.force_r2)},
                     {"peak_measured_N", jsonNumber(f.force_peak_measured_n)},
                     {"whole_trial_rmse_N", jsonNumber(f.force_trial_rmse_n)},
                     {"law", law}}}};
}

}  // namespace

BatchTrialReport runBatchTrial(const BatchTrialSetup& setup, const RunOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  // Before anything else: no stale marker may outlive a run that is about to change the outputs.
  removeFile(setup.completion_file);
  removeFile(setup.failure_file);
  removeLeftovers(fs::path(setup.setup_file).parent_path().empty() ? "." : fs::path(setup.setup_file).parent_path().string());
  BatchTrialReport r{setup.name, setup.subject, setup.trial, setup.activity, {}, {}, {}, 0};
  try {
    std::vector<std::string> contents{readFileText(setup.setup_file)};
    for (const std::string& step : setup.setup_files) {
      contents.push_back(readFileText(step));
      const std::string tool = detectTool(step);
      r.tools.push_back(tool);
      if (tool == "ik") {
        runIkStep(step, options, r);
      } else if (tool == "contact-area") {
        runContactStep(step, options, r);
      } else if (tool == "knee-contact-workflow") {
        r.figures.force_window = readWorkflowSetup(step).trials.front().window;
        runWorkflowStep(step, options, r);
      } else {
        throw InputError({setup.setup_file, 0, "BatchTrial/setup_files"},
                         "expected InverseKinematicsTool, ContactAreaTool or KneeContactWorkflow setups, got a " +
                             tool + " setup: " + step);
      }
    }
    writeFileAtomically(setup.summary_file, [&](std::ostream& os) { os << figuresJson(r).dump(2) << "\n"; });
    r.outputs.push_back(setup.summary_file);
    r.seconds = secondsSince(t0);
    writeCompletionMarker(setup.completion_file, calcSetupHash(contents), r.outputs, r.seconds);
  } catch (const std::exception& e) {
    const std::string kind = dynamic_cast<const InputError*>(&e) ? "error: " : "internal error: ";
    writeFileAtomically(setup.failure_file, [&](std::ostream& os) { os << kind << e.what() << "\n"; });
    throw;
  }
  return r;
}

void printBatchTrialSummary(const BatchTrialReport& r, std::ostream& os) {
  const TrialFigures& f = r.figures;
  os << "Batch trial " << r.name << " (subject " << r.subject << ", trial " << r.trial << "): " << join(r.tools, ", ")
     << "\n" << std::fixed << std::setprecision(2);
  if (f.ik_frames > 0) os << "  marker RMS " << f.marker_rms_mm << " mm (max " << f.marker_max_mm << " mm), " << f.ik_frames << " frames\n";
  if (std::isfinite(f.contact_peak_mm2)) os << "  contact area peak " << std::setprecision(1) << f.contact_peak_mm2 << " mm^2 at " << std::setprecision(3) << f.contact_peak_time << " s\n";
  if (std::isfinite(f.force_rmse_n))
    os << "  force RMSE " << std::setprecision(1) << f.force_rmse_n << " N over the " << f.force_window << " (" << std::setprecision(3) << f.force_rmse_bw << " BW, R^2 " << f.force_r2 << ")\n";
  os << std::defaultfloat << "  " << r.outputs.size() << " files written; completion marker " << BatchTrialFiles::completion(r.name) << "\n";
}

TrialFigures readTrialFigures(const std::string& summary_file) {
  json j;
  try {
    j = json::parse(readFileText(summary_file));
  } catch (const json::exception& e) {
    throw InputError({summary_file, 0, ""}, std::string("expected a trial summary (JSON), got: ") + e.what());
  }
  const auto get = [](const json& o, const char* k) {
    return o.is_object() && o.contains(k) && o[k].is_number() ? o[k].get<double>() : TrialFigures::nan;
  };
  TrialFigures f;
  const json ik = j.value("ik", json::object()), ca = j.value("contact_area", json::object()),
             fo = j.value("force", json::object());
  f.ik_frames = int(ik.value("frames", 0));
  f.marker_rms_mm = get(ik, "marker_rms_mean_mm");
  f.marker_max_mm = get(ik, "marker_error_max_mm");
  f.contact_peak_mm2 = get(ca, "peak_mm2");
  f.contact_peak_time = get(ca, "peak_time_s");
  f.force_window = fo.value("window", "");
  f.force_rmse_n = get(fo, "rmse_N");
  f.force_rmse_bw = get(fo, "rmse_bw");
  f.force_r2 = get(fo, "r2");
  f.force_peak_measured_n = get(fo, "peak_measured_N");
  f.force_trial_rmse_n = get(fo, "whole_trial_rmse_N");
  if (fo.contains("law") && fo["law"].is_object())
    for (const auto& [k, v] : fo["law"].items()) f.law.emplace_back(k, v.is_number() ? v.get<double>() : TrialFigures::nan);
  return f;
}

}  // namespace kneesim::tool
