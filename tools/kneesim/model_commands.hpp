#pragma once
// `kneesim model info MODEL` and `kneesim model check MODEL`: what a model holds, and whether it
// loads and passes the IK round trip (tools/model-corpus.sh runs the latter over a folder).

#include <string>

#include <CLI/CLI.hpp>

namespace kneesim::cli {

/// Options of `kneesim model`, filled by CLI11.
struct ModelCommandState {
  CLI::App* model = nullptr;
  CLI::App* info = nullptr;
  CLI::App* check = nullptr;
  std::string file;
  int frames = 5;
  double tolerance_mm = 0.01;
  bool tsv = false;  ///< check: one tab-separated row (tools/model-corpus.sh reads it)
};

/// Adds `model` with its `info` and `check` subcommands to @p app.
void addModelCommands(CLI::App& app, ModelCommandState& state);
/// True when `model` was given.
bool isModelCommand(const ModelCommandState& state);
/// Runs it; returns the exit status (3 when `check` finds the round trip off). Throws InputError
/// for a model that does not load.
int runModelCommand(const ModelCommandState& state, bool quiet);

}  // namespace kneesim::cli
