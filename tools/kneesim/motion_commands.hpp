#pragma once
// `kneesim ik` (inverse kinematics from flags, without a setup file) and `kneesim compare-motion`
// (two motions column by column, as OpenSim's regression tests compare them).

#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "ik/tool.hpp"

namespace kneesim::cli {

/// Options of the two subcommands, filled by CLI11.
struct MotionCommandState {
  CLI::App* ik = nullptr;
  CLI::App* compare = nullptr;
  // kneesim ik: the InverseKinematicsTool's settings as flags.
  ik::IkSetup setup;
  std::vector<double> time_range, marker_rotation;
  std::string tasks_file;
  bool no_errors = false;
  // kneesim compare-motion
  std::string motion_a, motion_b;
  double compare_tolerance = -1, time_tolerance = 1e-6;
};

/// Adds `ik` and `compare-motion` to @p app.
void addMotionCommands(CLI::App& app, MotionCommandState& state);
/// True when `ik` was given.
bool isIkCommand(const MotionCommandState& state);
/// True when `compare-motion` was given.
bool isCompareCommand(const MotionCommandState& state);
/// Runs `ik`, reporting frames done out of the total to @p progress. Throws InputError for bad input.
void runIkCommand(MotionCommandState& state, bool quiet, const std::function<void(int, int)>& progress);
/// Runs `compare-motion` and returns the exit status: 3 when --tolerance is given and a column's
/// RMS difference exceeds it, 0 otherwise. Throws InputError for bad input.
int runCompareCommand(const MotionCommandState& state);

}  // namespace kneesim::cli
