// The kneesim command: `kneesim run SETUP.xml` runs whatever tool a setup file describes.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "batch_command.hpp"
#include "core/error.hpp"
#include "gap_commands.hpp"
#include "ik/tool.hpp"
#include "io/motion_compare.hpp"
#include "io/storage.hpp"
#include "model_commands.hpp"
#include "tool/run.hpp"

namespace {

// A one-line progress bar on a terminal; silent when stderr is redirected.
void showProgress(const std::string& what, int done, int total) {
  static const bool tty = isatty(fileno(stderr));
  if (!tty || total <= 0) return;
  const int width = 30, fill = int(double(done) / total * width);
  std::fprintf(stderr, "\r%-8s [%.*s%*s] %3d%% (%d/%d)", what.c_str(), fill, "==============================",
               width - fill, "", int(100.0 * done / total), done, total);
  if (done == total) std::fprintf(stderr, "\n");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"kneesim: OpenSim-style musculoskeletal engine for instrumented-knee studies"};
  app.require_subcommand(1);
  // Subcommands hand options they do not know to the app, so global flags go anywhere
  // (`kneesim ik ... -q`); subcommands added below inherit this.
  app.fallthrough();
  app.set_version_flag("--version", std::string("kneesim ") + KNEESIM_VERSION);
  app.footer("Each subcommand has its own --help. Manual: man kneesim; docs/cli.md.");
  bool quiet = false;
  app.add_flag("-q,--quiet", quiet, "Print no summary");

  std::string setup;
  auto* run = app.add_subcommand("run", "Run the tool a setup file describes (OpenSim's IK setup, kneesim tools)");
  run->add_option("setup", setup, "Setup XML file")->required();

  // `kneesim ik`: the InverseKinematicsTool's settings as flags.
  kneesim::ik::IkSetup ik;
  std::vector<double> time_range, marker_rotation;
  std::string tasks_file;
  bool no_errors = false;
  auto* ikcmd = app.add_subcommand("ik", "Inverse kinematics from a model and a marker file, without a setup file");
  ikcmd->add_option("-m,--model", ik.model_file, "Model (.osim or .urdf)")->required();
  ikcmd->add_option("-t,--markers", ik.marker_file, "Marker file (.trc or .c3d)")->required();
  ikcmd->add_option("-o,--output", ik.output_motion_file, "Output motion (.mot, angles in degrees)")->required();
  ikcmd->add_option("--tasks", tasks_file, "IKTaskSet XML (default: every model marker found in the data, weight 1)");
  ikcmd->add_option("--time-range", time_range, "Start and end time (s)")->expected(2);
  ikcmd->add_option("--accuracy", ik.accuracy, "Convergence tolerance per frame (rad or m; default 1e-5)");
  ikcmd->add_option("--marker-rotation", marker_rotation,
                    "Rotate the marker data into the model's ground: body-fixed X Y Z angles in degrees "
                    "(e.g. -90 0 0 for Z-up lab data and a Y-up model)")
      ->expected(3);
  ikcmd->add_option("--results-dir", ik.results_directory, "Folder for the error reports (default: the output's folder)");
  ikcmd->add_flag("--no-errors", no_errors, "Do not write the marker-error reports");
  ikcmd->add_flag("--marker-locations", ik.report_marker_locations, "Also write model marker locations");

  // `kneesim compare-motion A B`: per-column RMS difference, as OpenSim's regression tests do.
  std::string motion_a, motion_b;
  double compare_tolerance = -1, time_tolerance = 1e-6;
  auto* cmpcmd = app.add_subcommand(
      "compare-motion", "Compare two motions (.mot/.sto) column by column, the second interpolated at the first one's times");
  cmpcmd->add_option("first", motion_a, "Motion, e.g. kneesim's result")->required();
  cmpcmd->add_option("second", motion_b, "Reference motion, e.g. OpenSim's stored answer")->required();
  cmpcmd->add_option("--tolerance", compare_tolerance,
                     "Exit with status 3 if any column's RMS difference exceeds this (the files' unit)");
  cmpcmd->add_option("--time-tolerance", time_tolerance,
                     "Rows within this many seconds count as the same time; others are interpolated (default 1e-6)");

  // `kneesim model info|check MODEL` (tools/kneesim/model_commands.cpp).
  kneesim::cli::ModelCommandState model_state;
  kneesim::cli::addModelCommands(app, model_state);

  // Sim-to-real gap diagnosis: `kneesim gap` and `kneesim synth` (tools/kneesim/gap_commands.cpp).
  kneesim::cli::GapCommandState gap_state;
  kneesim::cli::addGapCommands(app, gap_state);
  kneesim::cli::BatchCommandState batch_state;  // `kneesim batch` (tools/kneesim/batch_command.cpp)
  kneesim::cli::addBatchCommand(app, batch_state);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  try {
    if (*run) {
      kneesim::tool::RunOptions opt;
      opt.out = quiet ? nullptr : &std::cout;
      opt.progress = showProgress;
      kneesim::tool::runSetupFile(setup, opt);
    } else if (kneesim::cli::isBatchCommand(batch_state)) {
      kneesim::cli::runBatchCommand(batch_state, quiet);
    } else if (kneesim::cli::isModelCommand(model_state)) {
      return kneesim::cli::runModelCommand(model_state, quiet);
    } else if (kneesim::cli::isGapCommand(gap_state)) {
      kneesim::cli::runGapCommand(gap_state, quiet);
    } else if (*ikcmd) {
      if (time_range.size() == 2) {
        ik.time_start = time_range[0];
        ik.time_end = time_range[1];
      }
      if (marker_rotation.size() == 3) ik.marker_rotation_deg = Eigen::Vector3d(marker_rotation.data());
      ik.setup_file = "kneesim ik";
      for (const char* flag : {"model_file:--model", "marker_file:--markers", "time_range:--time-range",
                               "IKTaskSet:--tasks", "coordinate_file:--coordinates"}) {
        const std::string f(flag);
        const size_t colon = f.find(':');
        ik.locations[f.substr(0, colon)] = {"kneesim ik", 0, f.substr(colon + 1)};
      }
      if (!(ik.accuracy > 0)) throw kneesim::InputError({"kneesim ik", 0, "--accuracy"}, "expected a value > 0");
      ik.solver.step_tolerance = ik.accuracy;
      if (ik.results_directory.empty())
        ik.results_directory = std::filesystem::path(ik.output_motion_file).parent_path().string();
      if (ik.results_directory.empty()) ik.results_directory = ".";
      ik.report_errors = !no_errors;
      ik.name = std::filesystem::path(ik.output_motion_file).stem().string();
      if (!tasks_file.empty()) ik.tasks = kneesim::ik::readTaskFile(tasks_file);
      kneesim::ik::IkRunOptions ro;
      ro.progress = [](int d, int t) { showProgress("IK", d, t); };
      const auto report = kneesim::ik::runIk(ik, ro);
      if (!quiet) kneesim::ik::printIkSummary(report, std::cout);
    } else if (*cmpcmd) {
      const auto a = kneesim::io::readStorage(motion_a);
      const auto b = kneesim::io::readStorage(motion_b);
      const auto cmp = kneesim::io::compareMotions(a, b, motion_b, time_tolerance);
      std::printf("%d rows compared (%d in %s, %d in %s): %d at the same time, %d with %s interpolated linearly, "
                  "%d outside its time span left out; %zu columns compared\n",
                  cmp.getRowsCompared(), cmp.rows_first, motion_a.c_str(), cmp.rows_second, motion_b.c_str(),
                  cmp.rows_matched, cmp.rows_interpolated, motion_b.c_str(), cmp.rows_outside, cmp.columns.size());
      std::printf("  %-24s %12s %12s\n", "column", "rms", "max");
      for (const auto& c : cmp.columns) std::printf("  %-24s %12.6f %12.6f\n", c.label.c_str(), c.rms, c.max);
      for (const auto& l : cmp.only_in_first) std::printf("  only in %s: %s\n", motion_a.c_str(), l.c_str());
      for (const auto& l : cmp.only_in_second) std::printf("  only in %s: %s\n", motion_b.c_str(), l.c_str());
      const auto* worst = cmp.findWorst();
      if (worst) std::printf("worst column: %s, rms %.6f, max %.6f\n", worst->label.c_str(), worst->rms, worst->max);
      if (compare_tolerance >= 0) {
        bool ok = worst != nullptr;
        for (const auto& c : cmp.columns) ok = ok && c.rms <= compare_tolerance;
        std::printf("%s: every column within %g rms\n", ok ? "PASS" : "FAIL", compare_tolerance);
        if (!ok) return 3;
      }
    }
  } catch (const kneesim::InputError& e) {
    std::cerr << "kneesim: error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "kneesim: internal error: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
