#include "batch_command.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "core/error.hpp"
#include "core/subprocess.hpp"
#include "tool/batch_run.hpp"
#include "tool/batch_summary.hpp"

namespace kneesim::cli {

namespace fs = std::filesystem;

void addBatchCommand(CLI::App& app, BatchCommandState& s) {
  s.batch = app.add_subcommand("batch", "Run the trials of a manifest (CSV or TOML), here or as a Slurm job array");
  s.batch->add_option("manifest", s.manifest, "Manifest: one row per trial (docs/batch.md)")->required();
  s.batch->add_option("-o,--output", s.output, "Output folder (default: <manifest>_results beside the manifest)");
  s.batch->add_option("-j,--jobs", s.jobs, "Trials run at once, each in its own process (default 1)")
      ->check(CLI::Range(1, 1024));
  s.batch->add_flag("--resume", s.resume, "Skip the trials a previous run finished (valid completion marker)");
  s.batch->add_flag("--summary-only", s.summary_only, "Run nothing: write and print the summary of the trials' files");
  s.batch->add_option("--emit-slurm", s.emit_slurm,
                      "Write a Slurm job array (one task per trial) and a dependent summary job into this folder, "
                      "run nothing");
  const char* g = "Slurm (with --emit-slurm)";
  s.batch->add_option("--partition", s.slurm.partition, "sbatch --partition")->group(g);
  s.batch->add_option("--account", s.slurm.account, "sbatch --account")->group(g);
  s.batch->add_option("--time", s.slurm.time, "sbatch --time per trial (default 01:00:00)")->group(g);
  s.batch->add_option("--mem", s.slurm.mem, "sbatch --mem per trial (default 2G)")->group(g);
  s.batch->add_option("--max-running", s.slurm.max_running, "At most this many array tasks at once")->group(g);
  s.batch->add_option("--sbatch-option", s.slurm.extra, "Another sbatch option, e.g. --qos=short (repeatable)")
      ->group(g);
  s.batch->add_option("--kneesim", s.slurm.kneesim, "kneesim on the compute nodes (default: this one)")->group(g);
}

bool isBatchCommand(const BatchCommandState& s) { return s.batch && s.batch->parsed(); }

namespace {

// Progress on stderr: a bar redrawn in place on a terminal, one plain line per finished trial
// otherwise (logs, Slurm, CI).
void showBatchEvent(const tool::BatchEvent& e) {
  static const bool tty = isatty(fileno(stderr));
  const bool failed = e.outcome && e.outcome->status == tool::TrialOutcome::Status::failed;
  if (!tty) {
    if (e.kind != tool::BatchEvent::Kind::finished) return;
    std::fprintf(stderr, "batch: [%d/%d] %s %s", e.finished, e.total, e.plan->label().c_str(),
                 tool::toString(e.outcome->status).c_str());
    if (std::isfinite(e.outcome->seconds)) std::fprintf(stderr, " (%.1f s)", e.outcome->seconds);
    if (failed) std::fprintf(stderr, ": %s", e.outcome->message.c_str());
    std::fprintf(stderr, "\n");
    return;
  }
  if (failed) std::fprintf(stderr, "\r\033[Kfailed: %s: %s\n", e.plan->label().c_str(), e.outcome->message.c_str());
  const int width = 30, fill = e.total > 0 ? e.finished * width / e.total : width;
  std::fprintf(stderr, "\r\033[Kbatch [%.*s%*s] %d/%d finished, %d failed, %d running", fill,
               "==============================", width - fill, "", e.finished, e.total, e.failed, e.running);
  if (e.finished == e.total) std::fprintf(stderr, "\n");
  std::fflush(stderr);
}

void finish(const BatchCommandState& s, const std::vector<tool::BatchTrialPlan>& plans,
            const std::vector<tool::TrialOutcome>& outcomes, const std::string& out, bool quiet) {
  const auto rows = tool::collectBatchSummary(plans, outcomes);
  const std::string csv = (fs::path(out) / "batch_summary.csv").string();
  tool::writeBatchSummaryCsv(csv, rows);
  if (!quiet) {
    tool::printBatchSummary(rows, std::cout);
    std::cout << "summary: " << csv << "\n";
  }
  int bad = 0;
  for (const auto& o : outcomes)
    if (o.status == tool::TrialOutcome::Status::failed || o.status == tool::TrialOutcome::Status::not_run) ++bad;
  if (bad > 0)
    throw InputError({s.manifest, 0, ""}, std::to_string(bad) + " of " + std::to_string(outcomes.size()) +
                                              " trials failed or did not run (see " + csv + " and the trials' logs)");
}

}  // namespace

void runBatchCommand(const BatchCommandState& s, bool quiet) {
  const tool::Manifest manifest = tool::readManifest(s.manifest);
  const fs::path mpath = fs::absolute(fs::path(s.manifest));
  const std::string out = s.output.empty() ? (mpath.parent_path() / (mpath.stem().string() + "_results")).string()
                                           : fs::absolute(fs::path(s.output)).lexically_normal().string();
  const std::vector<tool::BatchTrialPlan> plans = tool::planBatch(manifest, out);
  const std::string self = findOwnExecutable();

  if (!s.emit_slurm.empty()) {
    std::vector<const tool::BatchTrialPlan*> todo;
    for (const auto& p : plans) {
      tool::writeTrialSetups(p);
      if (!s.resume || tool::readTrialOutcome(p).status != tool::TrialOutcome::Status::done_earlier) todo.push_back(&p);
    }
    tool::SlurmOptions o = s.slurm;
    if (o.kneesim.empty()) o.kneesim = self;
    const auto f = tool::writeSlurmJob(s.emit_slurm, todo, mpath.string(), out, o);
    if (!quiet)
      std::cout << "Slurm job array of " << f.tasks << " trial(s) (of " << plans.size() << ") written:\n  " << f.array_script
                << "\n  " << f.summary_script << "\n  " << f.trial_list << "\nSubmit with: sh " << f.submit_script << "\n";
    return;
  }
  std::vector<tool::TrialOutcome> outcomes;
  if (s.summary_only) {
    for (const auto& p : plans) outcomes.push_back(tool::readTrialOutcome(p));
  } else {
    tool::BatchRunOptions o;
    o.jobs = s.jobs;
    o.resume = s.resume;
    o.runner = [&](const tool::BatchTrialPlan& p) { return tool::runTrialInChildProcess(self, p); };
    o.on_event = showBatchEvent;
    outcomes = tool::runBatch(plans, o);
  }
  finish(s, plans, outcomes, out, quiet);
}

}  // namespace kneesim::cli
