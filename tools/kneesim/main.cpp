// The kneesim command: `kneesim run SETUP.xml` runs whatever tool a setup file describes.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>

#include "core/error.hpp"
#include "gap_commands.hpp"
#include "ik/tool.hpp"
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
  bool quiet = false;
  app.add_flag("-q,--quiet", quiet, "Print no summary");

  std::string setup;
  auto* run = app.add_subcommand("run", "Run the tool a setup file describes (OpenSim's IK setup, kneesim tools)");
  run->add_option("setup", setup, "Setup XML file")->required();

  kneesim::ik::IkSetup ik;
  std::vector<double> time_range;
  std::string tasks_file;
  auto* ikcmd = app.add_subcommand("ik", "Inverse kinematics from a model and a marker file, without a setup file");
  ikcmd->add_option("-m,--model", ik.model_file, "Model (.osim or .urdf)")->required();
  ikcmd->add_option("-t,--markers", ik.marker_file, "Marker file (.trc or .c3d)")->required();
  ikcmd->add_option("-o,--output", ik.output_motion_file, "Output motion (.mot)")->required();
  ikcmd->add_option("--tasks", tasks_file, "IKTaskSet XML (default: every model marker found in the data, weight 1)");
  ikcmd->add_option("--time-range", time_range, "Start and end time (s)")->expected(2);
  ikcmd->add_flag("--marker-locations", ik.report_marker_locations, "Also write model marker locations");

  // Sim-to-real gap diagnosis: `kneesim gap` and `kneesim synth` (tools/kneesim/gap_commands.cpp).
  kneesim::cli::GapCommandState gap_state;
  kneesim::cli::addGapCommands(app, gap_state);

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
    } else if (kneesim::cli::isGapCommand(gap_state)) {
      kneesim::cli::runGapCommand(gap_state, quiet);
    } else if (*ikcmd) {
      if (time_range.size() == 2) {
        ik.time_start = time_range[0];
        ik.time_end = time_range[1];
      }
      ik.setup_file = "(command line)";
      ik.results_directory = ".";
      ik.name = "ik";
      if (!tasks_file.empty()) ik.tasks = kneesim::ik::readTaskFile(tasks_file);
      kneesim::ik::IkRunOptions ro;
      ro.progress = [](int d, int t) { showProgress("IK", d, t); };
      const auto report = kneesim::ik::runIk(ik, ro);
      if (!quiet) kneesim::ik::printIkSummary(report, std::cout);
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
