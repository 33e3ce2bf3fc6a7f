// The kneesim command: `kneesim run SETUP.xml` runs whatever tool a setup file describes.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>

#include "batch_command.hpp"
#include "core/error.hpp"
#include "gap_commands.hpp"
#include "model_commands.hpp"
#include "motion_commands.hpp"
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

  // `kneesim ik` and `kneesim compare-motion A B` (tools/kneesim/motion_commands.cpp).
  kneesim::cli::MotionCommandState motion_state;
  kneesim::cli::addMotionCommands(app, motion_state);

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
    } else if (kneesim::cli::isIkCommand(motion_state)) {
      kneesim::cli::runIkCommand(motion_state, quiet, [](int d, int t) { showProgress("IK", d, t); });
    } else if (kneesim::cli::isCompareCommand(motion_state)) {
      return kneesim::cli::runCompareCommand(motion_state);
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
