// Runs a planned batch on worker threads, each starting one trial at a time in a child process.
#include "tool/batch_run.hpp"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <mutex>
#include <thread>

#include "core/paths.hpp"
#include "core/strings.hpp"
#include "core/subprocess.hpp"
#include "tool/batch_completion.hpp"

namespace kneesim::tool {

namespace fs = std::filesystem;

std::string toString(TrialOutcome::Status status) {
  switch (status) {
    case TrialOutcome::Status::done: return "done";
    case TrialOutcome::Status::done_earlier: return "done-earlier";
    case TrialOutcome::Status::failed: return "failed";
    case TrialOutcome::Status::not_run: return "not-run";
  }
  return "?";
}

namespace {

// The first line of the trial's failure note, or "" without one, as the batch reports it: an
// InputError's own "file:line: ..." line (the note's "error: " kind dropped; "internal error: "
// kept), a file the trial names relative to its folder named from the batch's output folder
// (<subject>/<trial>/<file>), so that the summary's line leads to it and reads the same wherever
// the output folder is (here and on the cluster).
std::string readFailureNote(const BatchTrialPlan& plan) {
  std::error_code ec;
  if (!fs::is_regular_file(plan.failure_file, ec)) return "";
  const std::string text = readFileText(plan.failure_file);  // splitLines gives views into it
  const auto lines = splitLines(text);
  std::string note = lines.empty() ? "" : std::string(trim(lines.front()));
  const std::string input_kind = "error: ";
  if (!startsWith(note, input_kind)) return note;
  note = note.substr(input_kind.size());
  const size_t colon = note.find(':');
  if (colon != std::string::npos && colon > 0) {
    const fs::path file = note.substr(0, colon);
    if (file.is_relative() && fs::is_regular_file(fs::path(plan.folder) / file, ec))
      note = (fs::path(plan.spec.subject) / plan.spec.trial / file).string() + note.substr(colon);
  }
  return note;
}

}  // namespace

TrialOutcome readTrialOutcome(const BatchTrialPlan& plan) {
  TrialOutcome o;
  std::string why;
  if (isTrialComplete(plan.completion_file, plan.setup_hash, &why)) {
    o.status = TrialOutcome::Status::done_earlier;
    o.seconds = readCompletionSeconds(plan.completion_file);
  } else if (std::string note = readFailureNote(plan); !note.empty()) {
    o.status = TrialOutcome::Status::failed;
    o.message = note;
  } else if (pathExists(plan.completion_file)) {
    o.message = "not finished: " + why;  // a marker that no longer holds
  }
  return o;
}

TrialOutcome runTrialInChildProcess(const std::string& kneesim, const BatchTrialPlan& plan) {
  const auto t0 = std::chrono::steady_clock::now();
  TrialOutcome o;
  const ProcessResult p = runProcess({kneesim, "run", fs::path(plan.setup_file).filename().string()}, plan.folder,
                                     plan.log_file);
  o.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::string why;
  if (p.succeeded() && isTrialComplete(plan.completion_file, plan.setup_hash, &why)) {
    o.status = TrialOutcome::Status::done;
    return o;
  }
  o.status = TrialOutcome::Status::failed;
  o.message = readFailureNote(plan);
  if (o.message.empty())
    o.message = p.succeeded() ? "finished without a valid completion marker (" + why + ")"
                              : "kneesim run ended with " + p.describe() + " (see " + plan.log_file + ")";
  return o;
}

std::vector<TrialOutcome> runBatch(const std::vector<BatchTrialPlan>& plans, const BatchRunOptions& options) {
  KNEESIM_CHECK(options.runner != nullptr, "runBatch: no runner");
  for (const BatchTrialPlan& p : plans) writeTrialSetups(p);
  std::vector<TrialOutcome> outcomes(plans.size());
  std::mutex lock;
  BatchEvent counts;
  counts.total = int(plans.size());
  const auto report = [&](BatchEvent::Kind kind, size_t i) {
    // Called with the lock held.
    BatchEvent e = counts;
    e.kind = kind;
    e.plan = &plans[i];
    e.outcome = kind == BatchEvent::Kind::finished ? &outcomes[i] : nullptr;
    if (options.on_event) options.on_event(e);
  };
  std::vector<size_t> todo;
  for (size_t i = 0; i < plans.size(); ++i) {
    if (options.resume && isTrialComplete(plans[i].completion_file, plans[i].setup_hash)) {
      outcomes[i] = readTrialOutcome(plans[i]);
      const std::lock_guard<std::mutex> g(lock);
      ++counts.finished;
      report(BatchEvent::Kind::finished, i);
    } else {
      todo.push_back(i);
    }
  }
  std::atomic<size_t> next{0};
  const auto work = [&]() {
    for (size_t k = next++; k < todo.size(); k = next++) {
      const size_t i = todo[k];
      {
        const std::lock_guard<std::mutex> g(lock);
        ++counts.running;
        report(BatchEvent::Kind::started, i);
      }
      TrialOutcome o;
      try {
        o = options.runner(plans[i]);
      } catch (const std::exception& e) {
        o.status = TrialOutcome::Status::failed;
        o.message = e.what();
      }
      const std::lock_guard<std::mutex> g(lock);
      outcomes[i] = o;
      --counts.running;
      ++counts.finished;
      if (o.status == TrialOutcome::Status::failed) ++counts.failed;
      report(BatchEvent::Kind::finished, i);
    }
  };
  const int n = std::max(1, std::min<int>(options.jobs, int(todo.size())));
  std::vector<std::thread> pool;
  for (int t = 1; t < n; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  return outcomes;
}

}  // namespace kneesim::tool
