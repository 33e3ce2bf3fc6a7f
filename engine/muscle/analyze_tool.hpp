#pragma once
// OpenSim's AnalyzeTool with StaticOptimization and JointReaction analyses: read its setup XML,
// run static optimisation over a coordinate file (with external loads and reserve actuators),
// writing <name>_StaticOptimization_activation.sto and _force.sto as OpenSim names them, and joint
// reactions with a forces file (e.g. those forces), writing <name>_JointReaction_ReactionLoads.sto.
//
// Setup elements read as OpenSim reads them: model_file, replace_force_set, force_set_files,
// results_directory, initial_time, final_time, external_loads_file, coordinates_file,
// lowpass_cutoff_frequency_for_coordinates; in <StaticOptimization>: on, start_time, end_time,
// step_interval, in_degrees, use_model_force_set, activation_exponent, use_muscle_physiology,
// optimizer_convergence_criterion, optimizer_max_iterations; in <JointReaction>: on, start_time,
// end_time, step_interval, in_degrees, forces_file, joint_names, apply_on_bodies,
// express_in_frame (muscle/joint_reaction.hpp); states_file (q and u columns) for joint
// reactions alone. The integrator and output settings
// (output_precision, maximum_number_of_integrator_steps, ...) are accepted and have no effect.
// As in OpenSim, the speeds are the coordinate splines' derivatives sampled at the coordinate
// times, and the accelerations the derivatives of quintic splines through those speeds.
// Differences on purpose:
// - speeds_file is refused; states_file is read for joint reactions alone (static optimisation
//   takes coordinates).
// - Joint reactions apply the forces file's actuator forces only (without one, no actuator
//   force), as OpenSim does with a forces file; a muscle's own states are never simulated.
// - use_model_force_set = false (coordinate actuators only) is refused.
// - Without a time range, the analysed frames stop at the coordinate file's own first and last
//   rows (OpenSim would also analyse the reflected padding added for filtering).
// - Frames where Ipopt does not converge, or the equations of motion are not met (a model too
//   weak without reserves), are kept as OpenSim keeps them and listed as warnings naming the
//   time, the coordinate and the shortfall.

#include <limits>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "io/storage.hpp"
#include "muscle/static_optimization.hpp"

namespace kneesim::muscle {

/// The contents of an AnalyzeTool setup with a StaticOptimization, paths resolved.
struct AnalyzeSetup {
  std::string setup_file;
  std::string name;
  std::string model_file;
  std::vector<std::string> force_set_files;
  bool replace_force_set = false;
  std::string results_directory;
  std::string coordinates_file;
  std::string external_loads_file;  ///< "" for none.
  double cutoff_hz = -1.0;
  double initial_time = -std::numeric_limits<double>::infinity();
  double final_time = std::numeric_limits<double>::infinity();
  bool so_on = false;                ///< A StaticOptimization analysis is present and on.
  std::string so_name = "StaticOptimization";
  double so_start = -std::numeric_limits<double>::infinity();
  double so_end = std::numeric_limits<double>::infinity();
  int step_interval = 1;
  int in_degrees = -1;               ///< Of the coordinates file: 1, 0, -1 from the file.
  SoOptions so;
  std::string states_file;           ///< "" for none.
  bool jr_on = false;                ///< A JointReaction analysis is present and on.
  std::string jr_name = "JointReaction";
  std::string jr_forces_file;        ///< "" for none.
  std::vector<std::string> jr_joints, jr_on_bodies, jr_frames;
  double jr_start = -std::numeric_limits<double>::infinity();
  double jr_end = std::numeric_limits<double>::infinity();
  std::map<std::string, SourceLocation> locations;

  SourceLocation locate(const std::string& element) const;
};

/// Reads an AnalyzeTool setup (<OpenSimDocument><AnalyzeTool> or bare). Throws InputError
/// (file:line: element: ...) for a missing file, unknown element or bad value.
AnalyzeSetup readAnalyzeSetup(const std::string& path);

/// What a run did.
struct AnalyzeReport {
  io::Storage activations;  ///< As written.
  io::Storage forces;       ///< As written.
  io::Storage reactions;    ///< As written (no rows without a JointReaction).
  std::vector<std::string> warnings;
  std::vector<std::string> outputs;
  /// Per reserve (coordinate actuator): frames where it carries at least 5 % of its optimal force.
  std::vector<std::pair<std::string, int>> reserve_frames;
  int frames = 0;            ///< Static optimisation's.
  int reaction_frames = 0;
  int failed_frames = 0;
  double seconds_solving = 0;  ///< CPU time of the frame loop.
};

/// Runs the setup's analyses and writes their files (all after everything is computed).
AnalyzeReport runAnalyzeTool(const AnalyzeSetup& setup);

/// A few lines: frames, outputs, warnings.
void printAnalyzeSummary(const AnalyzeReport& report, std::ostream& out);

}  // namespace kneesim::muscle
