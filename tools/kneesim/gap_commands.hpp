#pragma once
// `kneesim gap` and `kneesim synth`: the sim-to-real gap diagnosis from the command line.

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace kneesim::cli {

/// Options of the two subcommands, filled by CLI11.
struct GapCommandState {
  CLI::App* gap = nullptr;
  CLI::App* synth = nullptr;
  std::string setup, areas, output, trials, outside, predict;
  std::vector<std::string> effects, targets;
  bool no_plots = false, blind_suite = false, details = false;
  std::string workflow_results;
  double noise = 100;
  int replicates = 3, seeds = 20, folds = 5;
  std::string cases;  ///< Blind suite: comma-separated case names (default: all).
  unsigned long long seed = 1;
};

/// Adds `gap` and `synth` to @p app.
void addGapCommands(CLI::App& app, GapCommandState& state);
/// True when one of them was given.
bool isGapCommand(const GapCommandState& state);
/// Runs the one that was given. Throws InputError for bad input.
void runGapCommand(const GapCommandState& state, bool quiet);

}  // namespace kneesim::cli
