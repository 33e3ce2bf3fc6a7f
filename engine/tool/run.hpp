#pragma once
// `kneesim run SETUP.xml`: find out which tool a setup file describes and run it.

#include <functional>
#include <ostream>
#include <string>

namespace kneesim::tool {

/// How a run reports back.
struct RunOptions {
  std::ostream* out = nullptr;  ///< Summary output (nullptr: quiet).
  /// Progress callback: (what, done, total).
  std::function<void(const std::string&, int, int)> progress;
};

/// The tool a setup file describes: "ik", ... Throws InputError for an unknown root element.
std::string detectTool(const std::string& setup_path);

/// Runs the tool described by @p setup_path. Throws InputError for bad input.
void runSetupFile(const std::string& setup_path, const RunOptions& options);

}  // namespace kneesim::tool
