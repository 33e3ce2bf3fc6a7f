#pragma once
// Running another program as a child process and waiting for it (POSIX), with its output in a
// log file: how a batch runs each trial in a process of its own.

#include <string>
#include <vector>

namespace kneesim {

/// What became of a child process.
struct ProcessResult {
  int exit_code = -1;  ///< The exit status (0..255), or -1 when a signal ended it.
  int signal = 0;      ///< The signal that ended it, or 0.
  /// True when it exited with status 0.
  bool succeeded() const { return signal == 0 && exit_code == 0; }
  /// "exit status 3" or "killed by signal 9 (Killed)".
  std::string describe() const;
};

/// Runs the program at @p argv[0] (a path, not looked up in PATH) with the arguments @p argv[1..]
/// in the folder @p cwd ("" : this process's), its standard output and error written to
/// @p log_path (created or truncated; "" : inherited), and waits for it. The child is killed when
/// this process dies (Linux PR_SET_PDEATHSIG), so an interrupted batch leaves no orphan working.
/// Safe to call from several threads at once. Throws InputError naming @p log_path when the log
/// cannot be created; a program that cannot be executed exits with status 127 and says why in
/// the log.
ProcessResult runProcess(const std::vector<std::string>& argv, const std::string& cwd, const std::string& log_path);

/// The absolute path of this process's executable (/proc/self/exe), or "" when unknown.
std::string findOwnExecutable();

}  // namespace kneesim
