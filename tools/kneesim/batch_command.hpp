#pragma once
// `kneesim batch MANIFEST`: many trials from a manifest, on this machine or as a Slurm job array.

#include <string>

#include <CLI/CLI.hpp>

#include "tool/batch_slurm.hpp"

namespace kneesim::cli {

/// Options of the subcommand, filled by CLI11.
struct BatchCommandState {
  CLI::App* batch = nullptr;
  std::string manifest, output, emit_slurm;
  int jobs = 1;
  bool resume = false, summary_only = false;
  tool::SlurmOptions slurm;
};

/// Adds `batch` to @p app.
void addBatchCommand(CLI::App& app, BatchCommandState& state);
/// True when it was given.
bool isBatchCommand(const BatchCommandState& state);
/// Runs it. Throws InputError for bad input and when a trial failed or did not run (after every
/// other trial has run and the summary is written).
void runBatchCommand(const BatchCommandState& state, bool quiet);

}  // namespace kneesim::cli
