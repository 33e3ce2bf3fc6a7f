// runBatch: every trial runs once whatever the number of jobs, a failing trial does not stop the
// others, resumption skips finished trials; runTrialInChildProcess judges a child by its exit and
// its files.
#include "tool/batch_run.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>

#include "core/strings.hpp"
#include "support/test_data.hpp"
#include "tool/batch_completion.hpp"

namespace kneesim::tool {
namespace {

namespace fs = std::filesystem;

std::vector<BatchTrialPlan> planTrials(const std::string& dir, int n) {
  std::ofstream(dir + "/m.osim") << "";
  std::ofstream(dir + "/a.trc") << "";
  std::string csv = "subject,trial,tools,model,markers\n";
  for (int i = 0; i < n; ++i) csv += "s" + std::to_string(i) + ",walk,ik,m.osim,a.trc\n";
  std::ofstream(dir + "/m.csv") << csv;
  return planBatch(readManifest(dir + "/m.csv"), dir + "/out");
}

// A runner standing in for `kneesim run`: writes one output and the marker, or fails.
TrialOutcome fakeRun(const BatchTrialPlan& p, const std::set<std::string>& failing) {
  if (failing.count(p.spec.subject)) return {TrialOutcome::Status::failed, "error: " + p.spec.subject + " is corrupt", 0.1};
  const std::string out = p.folder + "/" + p.spec.name + "_ik.mot";
  std::ofstream(out) << p.spec.name << "\n";
  writeCompletionMarker(p.completion_file, p.setup_hash, {out}, 1.0);
  return {TrialOutcome::Status::done, "", 1.0};
}

TEST(BatchRun, AFailingTrialDoesNotStopTheOthers) {
  const std::string dir = test::scratchDir("batch_run_fail");
  const auto plans = planTrials(dir, 7);
  std::mutex m;
  std::map<std::string, int> runs;
  int events = 0, last_finished = 0, max_running = 0;
  BatchRunOptions o;
  o.jobs = 3;
  o.runner = [&](const BatchTrialPlan& p) {
    {
      const std::lock_guard<std::mutex> g(m);
      ++runs[p.spec.name];
    }
    if (p.spec.subject == "s2") throw InputError({"x.c3d", 0, ""}, "truncated");
    return fakeRun(p, {"s4"});
  };
  o.on_event = [&](const BatchEvent& e) {
    ++events;
    max_running = std::max(max_running, e.running);
    EXPECT_LE(e.running, 3);
    if (e.kind == BatchEvent::Kind::finished) {
      EXPECT_EQ(e.finished, last_finished + 1);
      last_finished = e.finished;
    }
    EXPECT_EQ(e.total, 7);
  };
  const auto outcomes = runBatch(plans, o);
  ASSERT_EQ(outcomes.size(), 7u);
  for (size_t i = 0; i < plans.size(); ++i) {
    EXPECT_EQ(runs[plans[i].spec.name], 1) << plans[i].spec.name;
    EXPECT_TRUE(fs::is_regular_file(plans[i].setup_file)) << "every setup is written first";
    const bool bad = i == 2 || i == 4;
    EXPECT_EQ(outcomes[i].status, bad ? TrialOutcome::Status::failed : TrialOutcome::Status::done) << i;
  }
  EXPECT_EQ(outcomes[2].message, "x.c3d: truncated") << "a runner's exception fails its trial only";
  EXPECT_EQ(outcomes[4].message, "error: s4 is corrupt");
  EXPECT_EQ(events, 14);
  EXPECT_GE(max_running, 1);
}

TEST(BatchRun, ResumptionSkipsFinishedTrialsOnly) {
  const std::string dir = test::scratchDir("batch_run_resume");
  const auto plans = planTrials(dir, 4);
  std::atomic<int> runs{0};
  BatchRunOptions o;
  o.jobs = 2;
  o.runner = [&](const BatchTrialPlan& p) {
    ++runs;
    return fakeRun(p, {"s3"});
  };
  runBatch(plans, o);
  EXPECT_EQ(runs, 4);
  std::ofstream(plans[1].folder + "/s1_walk_ik.mot") << "damaged\n";  // s1's output changed
  o.resume = true;
  runs = 0;
  const auto outcomes = runBatch(plans, o);
  EXPECT_EQ(runs, 2) << "s1 (damaged) and s3 (failed) run again";
  EXPECT_EQ(outcomes[0].status, TrialOutcome::Status::done_earlier);
  EXPECT_DOUBLE_EQ(outcomes[0].seconds, 1.0) << "from its marker";
  EXPECT_EQ(outcomes[1].status, TrialOutcome::Status::done);
  EXPECT_EQ(outcomes[2].status, TrialOutcome::Status::done_earlier);
  EXPECT_EQ(outcomes[3].status, TrialOutcome::Status::failed);
  o.resume = false;
  runs = 0;
  runBatch(plans, o);
  EXPECT_EQ(runs, 4) << "without --resume every trial runs";
}

TEST(BatchRun, ReadsHowATrialStandsFromItsFiles) {
  const std::string dir = test::scratchDir("batch_run_read");
  const auto plans = planTrials(dir, 4);
  for (const auto& p : plans) writeTrialSetups(p);
  fakeRun(plans[0], {});
  std::ofstream(plans[1].failure_file) << "error: /data/a.trc:3: expected 4 columns, got 2\n";
  EXPECT_EQ(readTrialOutcome(plans[0]).status, TrialOutcome::Status::done_earlier);
  const TrialOutcome f = readTrialOutcome(plans[1]);
  EXPECT_EQ(f.status, TrialOutcome::Status::failed);
  EXPECT_EQ(f.message, "/data/a.trc:3: expected 4 columns, got 2") << "an InputError's own line";
  EXPECT_EQ(readTrialOutcome(plans[2]).status, TrialOutcome::Status::not_run);
  // A trial's setup named relative to its folder (the trial runs there) is named from the output
  // folder, where the summary is; an internal error is kept as it is.
  std::ofstream(plans[3].failure_file) << "error: s3_walk_ik.xml:7: InverseKinematicsTool/time_range: bad\n";
  EXPECT_EQ(readTrialOutcome(plans[3]).message, "s3/walk/s3_walk_ik.xml:7: InverseKinematicsTool/time_range: bad");
  std::ofstream(plans[3].failure_file) << "internal error: s3_walk_ik.xml: check failed\n";
  EXPECT_EQ(readTrialOutcome(plans[3]).message, "internal error: s3_walk_ik.xml: check failed");
  fs::remove(plans[0].folder + "/s0_walk_ik.mot");
  const TrialOutcome gone = readTrialOutcome(plans[0]);
  EXPECT_EQ(gone.status, TrialOutcome::Status::not_run);
  EXPECT_EQ(gone.message, "not finished: output " + plans[0].folder + "/s0_walk_ik.mot is missing");
}

// A stand-in for the kneesim executable: a shell script doing what @p body says.
std::string fakeKneesim(const std::string& dir, const std::string& body) {
  const std::string path = dir + "/fake_kneesim";
  std::ofstream(path) << "#!/bin/sh\n" << body << "\n";
  fs::permissions(path, fs::perms::owner_all);
  return path;
}

TEST(BatchRun, AChildIsJudgedByItsExitAndItsFiles) {
  const std::string dir = test::scratchDir("batch_run_child");
  const auto plans = planTrials(dir, 1);
  const BatchTrialPlan& p = plans[0];
  writeTrialSetups(p);
  // The child runs in the trial's folder with the setup's file name, its output in the log.
  const std::string ok = fakeKneesim(dir, "echo \"$@\" in $(pwd)");
  TrialOutcome o = runTrialInChildProcess(ok, p);
  EXPECT_EQ(o.status, TrialOutcome::Status::failed);
  EXPECT_EQ(o.message, "finished without a valid completion marker (no completion marker)");
  EXPECT_EQ(readFileText(p.log_file), "run s0_walk_batch.xml in " + fs::canonical(p.folder).string() + "\n");
  writeCompletionMarker(p.completion_file, p.setup_hash, {p.setup_file}, 1.0);
  o = runTrialInChildProcess(ok, p);
  EXPECT_EQ(o.status, TrialOutcome::Status::done);
  EXPECT_GE(o.seconds, 0.0);

  const std::string failing = fakeKneesim(dir, "echo 'error: x.c3d: truncated' > s0_walk.failed; exit 1");
  o = runTrialInChildProcess(failing, p);
  EXPECT_EQ(o.status, TrialOutcome::Status::failed);
  EXPECT_EQ(o.message, "x.c3d: truncated");
  fs::remove(p.failure_file);
  const std::string crashing = fakeKneesim(dir, "kill -SEGV $$");
  o = runTrialInChildProcess(crashing, p);
  EXPECT_EQ(o.status, TrialOutcome::Status::failed);
  EXPECT_EQ(o.message, "kneesim run ended with killed by signal 11 (Segmentation fault) (see " + p.log_file + ")");
}

}  // namespace
}  // namespace kneesim::tool
