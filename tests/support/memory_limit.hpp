#pragma once
// Running a reader on a file that claims an absurd size, in a child process whose address space is
// limited: a reader that tries to allocate what the file claims fails with std::bad_alloc there (a
// failed test) instead of taking the machine's memory.

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <functional>
#include <new>
#include <string>

#include "core/error.hpp"

namespace kneesim::test {

/// What a function run under a memory limit did.
struct LimitedRun {
  /// "input error" (its message in message), "out of memory", "other exception" (its what() in
  /// message), "returned" (what the function returned in message), or "crashed".
  std::string outcome;
  std::string message;
};

/// Runs @p fn in a child process allowed @p extra_mb of address space beyond what this process
/// uses now, and reports whether it threw an InputError (and its message), ran out of memory, threw
/// something else or returned (and what).
inline LimitedRun runWithMemoryLimit(const std::function<std::string()>& fn, long extra_mb = 256) {
  long pages = 0;
  std::ifstream("/proc/self/statm") >> pages;
  const rlim_t limit = rlim_t(pages) * rlim_t(sysconf(_SC_PAGESIZE)) + (rlim_t(extra_mb) << 20);
  int fds[2];
  if (pipe(fds) != 0) return {"crashed", "pipe failed"};
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    rlimit r{limit, limit};
    setrlimit(RLIMIT_AS, &r);
    int code = 0;
    std::string msg;
    try {
      msg = fn();
      code = 4;
    } catch (const InputError& e) {
      msg = e.what();
    } catch (const std::bad_alloc&) {
      code = 2;
    } catch (const std::exception& e) {
      msg = e.what();
      code = 3;
    }
    if (!msg.empty() && write(fds[1], msg.data(), msg.size()) < 0) code = 5;
    close(fds[1]);
    _exit(code);
  }
  close(fds[1]);
  std::string msg;
  char buf[4096];
  for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) > 0;) msg.append(buf, size_t(n));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (!WIFEXITED(status)) return {"crashed", msg};
  switch (WEXITSTATUS(status)) {
    case 0: return {"input error", msg};
    case 2: return {"out of memory", msg};
    case 3: return {"other exception", msg};
    case 4: return {"returned", msg};
    default: return {"crashed", msg};
  }
}

}  // namespace kneesim::test
