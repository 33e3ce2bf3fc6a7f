// The Slurm job files, run here as Slurm would run them (bash with SLURM_ARRAY_TASK_ID set, sbatch
// replaced by a recorder): task i runs trial i from its folder into its log; submit.sh queues the
// summary after the array with afterany. The real cluster run is tests/cli/batch_slurm_test.sh.
#include "tool/batch_slurm.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "core/strings.hpp"
#include "core/subprocess.hpp"
#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim::tool {
namespace {

namespace fs = std::filesystem;

std::string writeScript(const std::string& path, const std::string& body) {
  std::ofstream(path) << "#!/bin/sh\n" << body << "\n";
  fs::permissions(path, fs::perms::owner_all);
  return path;
}

struct Job {
  std::string dir;
  std::vector<BatchTrialPlan> plans;
  SlurmJobFiles files;
};

Job writeJob(const std::string& name, const SlurmOptions& options) {
  Job j;
  j.dir = test::scratchDir(name);
  std::ofstream(j.dir + "/m.osim") << "";
  std::ofstream(j.dir + "/a.trc") << "";
  std::ofstream(j.dir + "/m.csv") << "subject,trial,tools,model,markers\ns1,walk,ik,m.osim,a.trc\ns2,run,ik,m.osim,a.trc\n";
  j.plans = planBatch(readManifest(j.dir + "/m.csv"), j.dir + "/out");
  for (const auto& p : j.plans) writeTrialSetups(p);
  j.files = writeSlurmJob(j.dir + "/slurm", {&j.plans[0], &j.plans[1]}, j.dir + "/m.csv", j.dir + "/out", options);
  return j;
}

TEST(BatchSlurm, TheArrayRunsOneTrialPerTaskFromItsFolder) {
  SlurmOptions o;
  o.kneesim = "/nowhere/kneesim";
  o.partition = "short";
  o.account = "knee-lab";
  o.time = "00:20:00";
  o.mem = "4G";
  o.max_running = 8;
  o.extra = {"--qos=low"};
  const Job j = writeJob("slurm_files", o);
  EXPECT_EQ(j.files.tasks, 2);
  EXPECT_EQ(readFileText(j.files.trial_list), j.plans[0].setup_file + "\n" + j.plans[1].setup_file + "\n");
  const std::string array = readFileText(j.files.array_script);
  for (const char* line : {"#SBATCH --array=1-2%8\n", "#SBATCH --partition=short\n", "#SBATCH --account=knee-lab\n",
                           "#SBATCH --time=00:20:00\n", "#SBATCH --mem=4G\n", "#SBATCH --qos=low\n",
                           "KNEESIM=\"${KNEESIM:-/nowhere/kneesim}\"\n"})
    EXPECT_NE(array.find(line), std::string::npos) << line << " not in\n" << array;
  EXPECT_TRUE(fs::is_directory(j.dir + "/slurm/logs")) << "Slurm does not create its --output folder";

  // Task 2 as Slurm runs it: the second trial, from its folder, output in its log.
  const std::string fake = writeScript(j.dir + "/fake_kneesim", "echo \"$@\" in $(pwd)");
  ::setenv("KNEESIM", fake.c_str(), 1);
  ::setenv("SLURM_ARRAY_TASK_ID", "2", 1);
  const ProcessResult r = runProcess({"/bin/bash", j.files.array_script}, j.dir, j.dir + "/task.out");
  ::unsetenv("SLURM_ARRAY_TASK_ID");
  EXPECT_TRUE(r.succeeded()) << readFileText(j.dir + "/task.out");
  EXPECT_EQ(readFileText(j.plans[1].log_file), "run s2_run_batch.xml in " + fs::canonical(j.plans[1].folder).string() + "\n");
  EXPECT_FALSE(fs::exists(j.plans[0].log_file));

  // The summary job reads the trials' files.
  runProcess({"/bin/bash", j.files.summary_script}, j.dir, j.dir + "/summary.out");
  ::unsetenv("KNEESIM");
  EXPECT_EQ(readFileText(j.dir + "/summary.out"), "batch " + j.dir + "/m.csv --output " + j.dir + "/out --summary-only in " +
                                                      fs::canonical(j.dir).string() + "\n");
}

TEST(BatchSlurm, SubmitQueuesTheSummaryAfterTheArray) {
  const Job j = writeJob("slurm_submit", SlurmOptions{});
  // sbatch replaced by a recorder answering job ids as `sbatch --parsable` does ("id;cluster").
  fs::create_directories(j.dir + "/bin");
  writeScript(j.dir + "/bin/sbatch", "echo \"$@\" >> " + j.dir + "/sbatch.calls\n"
                                     "if [ -f " + j.dir + "/first ]; then echo 43; else touch " + j.dir + "/first; echo '42;cluster'; fi");
  const std::string path = j.dir + "/bin:" + std::getenv("PATH");
  const ProcessResult r = runProcess({"/usr/bin/env", "PATH=" + path, "/bin/sh", j.files.submit_script}, j.dir, j.dir + "/submit.out");
  EXPECT_TRUE(r.succeeded()) << readFileText(j.dir + "/submit.out");
  EXPECT_EQ(readFileText(j.dir + "/sbatch.calls"), "--parsable " + j.files.array_script + "\n--parsable --dependency=afterany:42 " +
                                                       j.files.summary_script + "\n");
  EXPECT_EQ(readFileText(j.dir + "/submit.out"), "submitted array job 42 (2 tasks) and summary job 43\n");
}

TEST(BatchSlurm, BadOptionsAreRefused) {
  const std::string dir = test::scratchDir("slurm_bad");
  SlurmOptions o;
  o.partition = "a\nb";
  EXPECT_EQ(test::inputErrorOf([&] { writeSlurmJob(dir, {}, "m.csv", dir, o); }),
            "m.csv: expected trials to submit, got none (all finished?)");
  std::vector<BatchTrialPlan> none(1);
  EXPECT_EQ(test::inputErrorOf([&] { writeSlurmJob(dir, {&none[0]}, "m.csv", dir, o); }),
            "kneesim batch: slurm option: expected one line, got a line break");
}

}  // namespace
}  // namespace kneesim::tool
