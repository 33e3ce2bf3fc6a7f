// runProcess: exit status, signals, the working folder and the log, a program that cannot start.
#include "core/subprocess.hpp"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <thread>

#include "core/strings.hpp"
#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim {
namespace {

namespace fs = std::filesystem;

TEST(Subprocess, ExitStatusWorkingFolderAndLog) {
  const std::string dir = test::scratchDir("subprocess_exit");
  const std::string log = dir + "/run.log";
  const ProcessResult r = runProcess({"/bin/sh", "-c", "echo out; echo err >&2; pwd; exit 3"}, dir, log);
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_EQ(r.signal, 0);
  EXPECT_FALSE(r.succeeded());
  EXPECT_EQ(r.describe(), "exit status 3");
  EXPECT_EQ(readFileText(log), "out\nerr\n" + fs::canonical(dir).string() + "\n");
  EXPECT_TRUE(runProcess({"/bin/sh", "-c", "exit 0"}, "", log).succeeded());
  EXPECT_EQ(readFileText(log), "") << "the log is truncated by each run";
}

TEST(Subprocess, KilledBySignal) {
  const std::string dir = test::scratchDir("subprocess_signal");
  const ProcessResult r = runProcess({"/bin/sh", "-c", "kill -9 $$"}, dir, dir + "/log");
  EXPECT_EQ(r.exit_code, -1);
  EXPECT_EQ(r.signal, SIGKILL);
  EXPECT_EQ(r.describe().rfind("killed by signal 9", 0), 0u) << r.describe();
}

TEST(Subprocess, AProgramThatCannotStartExits127AndSaysWhy) {
  const std::string dir = test::scratchDir("subprocess_missing");
  const ProcessResult r = runProcess({dir + "/no_such_program"}, dir, dir + "/log");
  EXPECT_EQ(r.exit_code, 127);
  EXPECT_NE(readFileText(dir + "/log").find("no_such_program: No such file or directory"), std::string::npos)
      << readFileText(dir + "/log");
  const ProcessResult in_missing_folder = runProcess({"/bin/true"}, dir + "/no_such_folder", dir + "/log");
  EXPECT_EQ(in_missing_folder.exit_code, 127);
}

TEST(Subprocess, AnUnwritableLogIsAnInputError) {
  const std::string dir = test::scratchDir("subprocess_log");
  const std::string msg = test::inputErrorOf([&] { runProcess({"/bin/true"}, dir, dir + "/missing/run.log"); });
  EXPECT_EQ(msg.rfind(dir + "/missing/run.log: cannot create the log file: ", 0), 0u) << msg;
}

// Whether process @p pid still runs (a zombie waiting for its reaper does not).
bool isRunning(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string pid_s, comm, state;
  if (!(stat >> pid_s >> comm >> state)) return false;
  return state != "Z" && state != "X";
}

TEST(Subprocess, TheChildDiesWithItsParent) {
  // A helper process starts a long child through runProcess and is then killed: an interrupted
  // batch must not leave trials running that a resumed batch would start again.
  const std::string dir = test::scratchDir("subprocess_orphan");
  const std::string pid_file = dir + "/child.pid";
  const pid_t helper = ::fork();
  ASSERT_GE(helper, 0);
  if (helper == 0) {
    runProcess({"/bin/sh", "-c", "echo $$ > child.pid.tmp && mv child.pid.tmp child.pid && exec sleep 60"}, dir, "");
    ::_exit(0);
  }
  pid_t child = 0;
  for (int i = 0; i < 500 && child == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    std::ifstream in(pid_file);
    in >> child;
  }
  ASSERT_GT(child, 0) << "the child never started";
  EXPECT_TRUE(isRunning(child));
  ::kill(helper, SIGKILL);
  ::waitpid(helper, nullptr, 0);
  bool gone = false;
  for (int i = 0; i < 500 && !gone; ++i) {
    gone = !isRunning(child);
    if (!gone) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_TRUE(gone) << "child " << child << " outlived its parent";
  if (!gone) ::kill(child, SIGKILL);
}

TEST(Subprocess, FindsItsOwnExecutable) {
  const std::string self = findOwnExecutable();
  EXPECT_TRUE(fs::is_regular_file(self)) << self;
  EXPECT_NE(self.find("test_core"), std::string::npos) << self;
}

}  // namespace
}  // namespace kneesim
