#pragma once
// <BatchTrial>: one trial of a batch, run by `kneesim run <name>_batch.xml` (what `kneesim batch`
// starts in a child process and what a Slurm array task runs). It runs its tool setups in order
// (IK, contact area, workflow), then writes <name>_summary.json (the trial's figures) and last the
// completion marker <name>.done (batch_completion.hpp). A failure writes <name>.failed with the
// one-line error instead and rethrows. Setup files are expanded from a manifest (batch_plan.hpp).

#include <limits>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "tool/run.hpp"

namespace kneesim::tool {

/// The contents of a BatchTrial setup file, paths resolved against its folder.
struct BatchTrialSetup {
  std::string setup_file;
  std::string name, subject, trial, activity;
  std::vector<std::string> setup_files;  ///< Tool setups, run in this order (resolved).
  std::string summary_file, completion_file, failure_file;  ///< In the setup's folder.
};

/// Reads a BatchTrial setup. Throws InputError with file, line and element for an unknown element,
/// a missing name or setup file.
BatchTrialSetup readBatchTrialSetup(const std::string& path);

/// The figures of one trial (NaN where its tools do not give them).
struct TrialFigures {
  static constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  int ik_frames = 0;                 ///< Frames solved by IK.
  double marker_rms_mm = nan;        ///< IK: mean over frames of the per-frame marker RMS.
  double marker_max_mm = nan;        ///< IK: largest single marker error.
  double contact_peak_mm2 = nan;     ///< Largest contact area S over the trial.
  double contact_peak_time = nan;    ///< s.
  std::string force_window;          ///< Window of the force errors (stance, trial, ...).
  double force_rmse_n = nan;         ///< Law against measured total force over the window, N.
  double force_rmse_bw = nan;        ///< The same in body weights.
  double force_r2 = nan;             ///< Coefficient of determination over the window.
  double force_trial_rmse_n = nan;   ///< Over every frame of the trial, N.
  double force_peak_measured_n = nan;  ///< Largest measured force in the window, N.
  std::vector<std::pair<std::string, double>> law;  ///< Identified quantities (e.g. K in Pa).
};

/// What a BatchTrial run did.
struct BatchTrialReport {
  std::string name, subject, trial, activity;
  std::vector<std::string> tools;  ///< Tool names run, e.g. ik, contact-area, knee-contact-workflow.
  TrialFigures figures;
  std::vector<std::string> outputs;  ///< Every file written, the summary included.
  double seconds = 0;
};

/// Runs the trial: removes its old completion marker, failure note and files left by killed runs
/// (hidden AtomicFile temporaries), runs each setup (InverseKinematicsTool, ContactAreaTool or
/// KneeContactWorkflow), writes the summary and then the completion marker. On an error writes the
/// failure note (the error's one line) and rethrows.
BatchTrialReport runBatchTrial(const BatchTrialSetup& setup, const RunOptions& options = {});

/// Writes a short summary (figures, outputs) to @p os.
void printBatchTrialSummary(const BatchTrialReport& report, std::ostream& os);

/// Reads the figures of a trial's <name>_summary.json. Throws InputError naming the file when it
/// is missing or malformed.
TrialFigures readTrialFigures(const std::string& summary_file);

}  // namespace kneesim::tool
