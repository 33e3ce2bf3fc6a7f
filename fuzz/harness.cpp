#include "harness.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <map>

#include "core/error.hpp"

namespace kneesim::fuzz {

namespace fs = std::filesystem;

namespace {

// The folder of this process's input files, removed at exit (libFuzzer's -fork and -jobs run
// several processes: each has its own folder). In /dev/shm when there is one: written and read
// once per execution, the input on a disk-backed /tmp made the targets five times slower (250
// against 1500 exec/s for the CSV reader on 2026-11-28), waiting on the disk.
const fs::path& inputDir() {
  static const fs::path dir = [] {
    const fs::path base = ::access("/dev/shm", W_OK) == 0 ? fs::path("/dev/shm") : fs::temp_directory_path();
    // The pid padded to a fixed width: every path then has the same length, so the string code
    // an input runs through (and the coverage libFuzzer steers by) does not change with the pid.
    char pid[16];
    std::snprintf(pid, sizeof pid, "%010d", int(::getpid()));
    fs::path d = base / (std::string("kneesim-fuzz-") + pid);
    fs::create_directories(d);
    std::atexit([] {
      std::error_code ec;
      fs::remove_all(inputDir(), ec);
    });
    return d;
  }();
  return dir;
}

[[noreturn]] void finding(const char* what, const std::string& message) {
  std::fprintf(stderr, "==kneesim-fuzz== FINDING: %s: %s\n", what, message.c_str());
  std::abort();
}

}  // namespace

const std::string& inputPath(const std::string& ext) {
  static std::map<std::string, std::string> paths;
  auto it = paths.find(ext);
  if (it == paths.end()) it = paths.emplace(ext, (inputDir() / ("input" + ext)).string()).first;
  return it->second;
}

const std::string& writeInput(const uint8_t* data, size_t size, const std::string& ext) {
  const std::string& path = inputPath(ext);
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) finding("harness", "cannot write " + path);
  if (size && std::fwrite(data, 1, size, f) != size) finding("harness", "cannot write " + path);
  std::fclose(f);
  return path;
}

void expectInputErrorOnly(const std::function<void()>& read) {
  try {
    read();
  } catch (const InputError& e) {
    const std::string msg = e.what();
    if (msg.find('\n') != std::string::npos) finding("InputError of more than one line", msg);
  } catch (const std::exception& e) {
    finding("an exception other than InputError", e.what());
  } catch (...) {
    finding("a non-standard exception", "(unknown)");
  }
}

int runReader(const uint8_t* data, size_t size, const std::string& ext,
              const std::function<void(const std::string& path)>& read) {
  const std::string& path = writeInput(data, size, ext);
  expectInputErrorOnly([&] { read(path); });
  return 0;
}

}  // namespace kneesim::fuzz
