#pragma once
// Running a planned batch (batch_plan.hpp) on a pool of workers: every trial's setup files are
// written first, finished trials are skipped on resumption, the others run `--jobs` at a time,
// and a failing trial is recorded without stopping the rest.
//
// Each trial runs in a child process (`kneesim run <name>_batch.xml` in the trial's folder, its
// output in the trial's log) rather than on a thread of this process, for three reasons: Ipopt's
// MUMPS is not thread-safe, so in one process the workflows' fits would queue behind identify/'s
// mutex, while processes fit in parallel; a crash or abort in one trial (a bug, a bad library
// call) ends that trial only; and it is exactly what a Slurm array task runs, so the outputs of
// `kneesim batch` and of the cluster are the same by construction. A trial's outputs depend on
// its setup files alone, never on the number of jobs or on the other trials.

#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "tool/batch_plan.hpp"

namespace kneesim::tool {

/// How one trial of a batch ended.
struct TrialOutcome {
  enum class Status {
    done,          ///< Ran now and finished (completion marker written).
    done_earlier,  ///< Skipped: finished by an earlier run (--resume, or read from the files).
    failed,        ///< Ran and failed (message says why); its completion marker is absent.
    not_run        ///< Neither finished nor failed (e.g. a Slurm task still queued or killed).
  };
  Status status = Status::not_run;
  std::string message;  ///< The failure's one line.
  double seconds = std::numeric_limits<double>::quiet_NaN();  ///< Run time (from the marker when earlier).
};

/// "done", "done-earlier", "failed" or "not-run".
std::string toString(TrialOutcome::Status status);

/// Runs one trial whose setup files are written and says how it ended (it should not throw).
using TrialRunner = std::function<TrialOutcome(const BatchTrialPlan&)>;

/// A trial starting or ending, for progress reports; counts over the whole batch.
struct BatchEvent {
  enum class Kind { started, finished } kind = Kind::started;
  const BatchTrialPlan* plan = nullptr;
  const TrialOutcome* outcome = nullptr;  ///< For finished.
  int finished = 0, failed = 0, running = 0, total = 0;
};

/// How to run a batch.
struct BatchRunOptions {
  int jobs = 1;         ///< Trials at once (>= 1).
  bool resume = false;  ///< Skip trials whose completion marker is valid (batch_completion.hpp).
  TrialRunner runner;   ///< Required.
  /// Called for every event, one call at a time (under a lock), from the worker threads.
  std::function<void(const BatchEvent&)> on_event;
};

/// Writes every trial's setup files, then runs the trials as the options say. Returns one outcome
/// per plan, in plan order. Throws InputError only when a setup file cannot be written.
std::vector<TrialOutcome> runBatch(const std::vector<BatchTrialPlan>& plans, const BatchRunOptions& options);

/// The runner of `kneesim batch`: `<kneesim> run <name>_batch.xml` in a child process started in
/// the trial's folder, its standard output and error in the trial's log; done when it exits with
/// status 0 and left a valid completion marker, else failed with the trial's failure note (an input
/// error's own "file:line: ..." line, a file of the trial's folder named <subject>/<trial>/<file>),
/// or the way the process ended.
TrialOutcome runTrialInChildProcess(const std::string& kneesim, const BatchTrialPlan& plan);

/// How a trial stands according to its files, without running it: done_earlier (valid completion
/// marker), failed (failure note), or not_run. For the summary of a batch run elsewhere (Slurm).
TrialOutcome readTrialOutcome(const BatchTrialPlan& plan);

}  // namespace kneesim::tool
