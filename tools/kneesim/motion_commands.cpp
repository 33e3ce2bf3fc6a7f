// `kneesim ik` and `kneesim compare-motion`: their flags and what they run.
#include "motion_commands.hpp"

#include <cstdio>
#include <filesystem>
#include <iostream>

#include "core/error.hpp"
#include "io/motion_compare.hpp"
#include "io/storage.hpp"

namespace kneesim::cli {

void addMotionCommands(CLI::App& app, MotionCommandState& s) {
  ik::IkSetup& ik = s.setup;
  s.ik = app.add_subcommand("ik", "Inverse kinematics from a model and a marker file, without a setup file");
  s.ik->add_option("-m,--model", ik.model_file, "Model (.osim or .urdf)")->required();
  s.ik->add_option("-t,--markers", ik.marker_file, "Marker file (.trc or .c3d)")->required();
  s.ik->add_option("-o,--output", ik.output_motion_file, "Output motion (.mot, angles in degrees)")->required();
  s.ik->add_option("--tasks", s.tasks_file, "IKTaskSet XML (default: every model marker found in the data, weight 1)");
  s.ik->add_option("--time-range", s.time_range, "Start and end time (s)")->expected(2);
  s.ik->add_option("--accuracy", ik.accuracy, "Convergence tolerance per frame (rad or m; default 1e-5)");
  s.ik->add_option("--marker-rotation", s.marker_rotation,
                   "Rotate the marker data into the model's ground: body-fixed X Y Z angles in degrees "
                   "(e.g. -90 0 0 for Z-up lab data and a Y-up model)")
      ->expected(3);
  s.ik->add_option("--results-dir", ik.results_directory, "Folder for the error reports (default: the output's folder)");
  s.ik->add_flag("--no-errors", s.no_errors, "Do not write the marker-error reports");
  s.ik->add_flag("--marker-locations", ik.report_marker_locations, "Also write model marker locations");

  s.compare = app.add_subcommand(
      "compare-motion", "Compare two motions (.mot/.sto) column by column, the second interpolated at the first one's times");
  s.compare->add_option("first", s.motion_a, "Motion, e.g. kneesim's result")->required();
  s.compare->add_option("second", s.motion_b, "Reference motion, e.g. OpenSim's stored answer")->required();
  s.compare->add_option("--tolerance", s.compare_tolerance,
                        "Exit with status 3 if any column's RMS difference exceeds this (the files' unit)");
  s.compare->add_option("--time-tolerance", s.time_tolerance,
                        "Rows within this many seconds count as the same time; others are interpolated (default 1e-6)");
}

bool isIkCommand(const MotionCommandState& s) { return s.ik && *s.ik; }
bool isCompareCommand(const MotionCommandState& s) { return s.compare && *s.compare; }

void runIkCommand(MotionCommandState& s, bool quiet, const std::function<void(int, int)>& progress) {
  ik::IkSetup& ik = s.setup;
  if (s.time_range.size() == 2) {
    ik.time_start = s.time_range[0];
    ik.time_end = s.time_range[1];
  }
  if (s.marker_rotation.size() == 3) ik.marker_rotation_deg = Eigen::Vector3d(s.marker_rotation.data());
  ik.setup_file = "kneesim ik";
  for (const char* flag : {"model_file:--model", "marker_file:--markers", "time_range:--time-range",
                           "IKTaskSet:--tasks", "coordinate_file:--coordinates"}) {
    const std::string f(flag);
    const size_t colon = f.find(':');
    ik.locations[f.substr(0, colon)] = {"kneesim ik", 0, f.substr(colon + 1)};
  }
  if (!(ik.accuracy > 0)) throw InputError({"kneesim ik", 0, "--accuracy"}, "expected a value > 0");
  ik.solver.step_tolerance = ik.accuracy;
  if (ik.results_directory.empty())
    ik.results_directory = std::filesystem::path(ik.output_motion_file).parent_path().string();
  if (ik.results_directory.empty()) ik.results_directory = ".";
  ik.report_errors = !s.no_errors;
  ik.name = std::filesystem::path(ik.output_motion_file).stem().string();
  if (!s.tasks_file.empty()) ik.tasks = ik::readTaskFile(s.tasks_file);
  ik::IkRunOptions ro;
  ro.progress = progress;
  const auto report = ik::runIk(ik, ro);
  if (!quiet) ik::printIkSummary(report, std::cout);
}

int runCompareCommand(const MotionCommandState& s) {
  const auto a = io::readStorage(s.motion_a);
  const auto b = io::readStorage(s.motion_b);
  const auto cmp = io::compareMotions(a, b, s.motion_b, s.time_tolerance);
  std::printf("%d rows compared (%d in %s, %d in %s): %d at the same time, %d with %s interpolated linearly, "
              "%d outside its time span left out; %zu columns compared\n",
              cmp.getRowsCompared(), cmp.rows_first, s.motion_a.c_str(), cmp.rows_second, s.motion_b.c_str(),
              cmp.rows_matched, cmp.rows_interpolated, s.motion_b.c_str(), cmp.rows_outside, cmp.columns.size());
  std::printf("  %-24s %12s %12s\n", "column", "rms", "max");
  for (const auto& c : cmp.columns) std::printf("  %-24s %12.6f %12.6f\n", c.label.c_str(), c.rms, c.max);
  for (const auto& l : cmp.only_in_first) std::printf("  only in %s: %s\n", s.motion_a.c_str(), l.c_str());
  for (const auto& l : cmp.only_in_second) std::printf("  only in %s: %s\n", s.motion_b.c_str(), l.c_str());
  const auto* worst = cmp.findWorst();
  if (worst) std::printf("worst column: %s, rms %.6f, max %.6f\n", worst->label.c_str(), worst->rms, worst->max);
  if (s.compare_tolerance < 0) return 0;
  bool ok = worst != nullptr;
  for (const auto& c : cmp.columns) ok = ok && c.rms <= s.compare_tolerance;
  std::printf("%s: every column within %g rms\n", ok ? "PASS" : "FAIL", s.compare_tolerance);
  return ok ? 0 : 3;
}

}  // namespace kneesim::cli
