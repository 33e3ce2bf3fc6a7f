#pragma once
// A batch as a Slurm job array: `kneesim batch MANIFEST --emit-slurm DIR` writes
//   DIR/kneesim_trials.txt      one BatchTrial setup per line (the trials to run)
//   DIR/kneesim_array.sbatch    the array job: task i runs `kneesim run` on line i, from the
//                               trial's folder, its output in the trial's log (as `kneesim batch`)
//   DIR/kneesim_summary.sbatch  the summary job (`kneesim batch MANIFEST --summary-only`)
//   DIR/submit.sh               submits the array, then the summary with --dependency=afterany
//   DIR/logs/                   Slurm's own output files
// The trials' setup files are written by the caller first (batch_plan.hpp).

#include <string>
#include <vector>

#include "tool/batch_plan.hpp"

namespace kneesim::tool {

/// Where and how the jobs run on the user's cluster.
struct SlurmOptions {
  std::string job_name = "kneesim";
  std::string partition;            ///< --partition ("" : the cluster's default).
  std::string account;              ///< --account ("" : the user's default).
  std::string time = "01:00:00";    ///< --time per trial.
  std::string mem = "2G";           ///< --mem per trial.
  int cpus_per_task = 1;            ///< --cpus-per-task.
  int max_running = 0;              ///< The array's %N throttle (0: none).
  std::vector<std::string> extra;   ///< More sbatch options, one #SBATCH line each (e.g. --qos=short).
  std::string kneesim;              ///< kneesim on the compute nodes (the KNEESIM variable overrides it).
};

/// The files written.
struct SlurmJobFiles {
  std::string trial_list, array_script, summary_script, submit_script;
  int tasks = 0;
};

/// Writes the job files for @p trials into @p dir (created). @p manifest and @p output_dir are
/// what the summary job passes to `kneesim batch`. Throws InputError for no trials, an option
/// holding a line break, or a file that cannot be written.
SlurmJobFiles writeSlurmJob(const std::string& dir, const std::vector<const BatchTrialPlan*>& trials,
                            const std::string& manifest, const std::string& output_dir, const SlurmOptions& options);

}  // namespace kneesim::tool
