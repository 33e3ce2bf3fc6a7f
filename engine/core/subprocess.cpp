#include "core/subprocess.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "core/error.hpp"

namespace kneesim {

std::string ProcessResult::describe() const {
  if (signal != 0) return "killed by signal " + std::to_string(signal) + " (" + strsignal(signal) + ")";
  return "exit status " + std::to_string(exit_code);
}

namespace {

// Between fork() and exec() a multi-threaded parent's child may only make async-signal-safe
// calls: everything it needs (argument array, messages) is prepared before the fork.
[[noreturn]] void failInChild(const char* what) {
  const char* reason = std::strerror(errno);
  const char* parts[] = {"kneesim: cannot start the child process: ", what, ": ", reason, "\n"};
  for (const char* p : parts) {
    if (::write(STDERR_FILENO, p, std::strlen(p)) < 0) break;
  }
  ::_exit(127);
}

}  // namespace

ProcessResult runProcess(const std::vector<std::string>& argv, const std::string& cwd, const std::string& log_path) {
  KNEESIM_CHECK(!argv.empty(), "runProcess: no program");
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  int log_fd = -1;
  if (!log_path.empty()) {
    log_fd = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (log_fd < 0) throw InputError({log_path, 0, ""}, std::string("cannot create the log file: ") + std::strerror(errno));
  }
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int e = errno;
    if (log_fd >= 0) ::close(log_fd);
    throw InputError({argv[0], 0, ""}, std::string("cannot start a process: ") + std::strerror(e));
  }
  if (pid == 0) {
    // Die with the parent (checked again in case the parent died before prctl).
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(128 + SIGKILL);
    if (log_fd >= 0) {
      if (::dup2(log_fd, STDOUT_FILENO) < 0 || ::dup2(log_fd, STDERR_FILENO) < 0) failInChild("log file");
    }
    const int null_fd = ::open("/dev/null", O_RDONLY);
    if (null_fd >= 0) ::dup2(null_fd, STDIN_FILENO);
    if (!cwd.empty() && ::chdir(cwd.c_str()) != 0) failInChild(cwd.c_str());
    ::execv(args[0], args.data());
    failInChild(args[0]);
  }
  if (log_fd >= 0) ::close(log_fd);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    KNEESIM_CHECK(errno == EINTR, std::string("waitpid failed: ") + std::strerror(errno));
  }
  ProcessResult r;
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) r.signal = WTERMSIG(status);
  return r;
}

std::string findOwnExecutable() {
  std::error_code ec;
  const auto p = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : p.string();
}

}  // namespace kneesim
