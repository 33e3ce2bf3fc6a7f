#pragma once
// `kneesim run SETUP.xml`: find out which tool a setup file describes and run it.
//
// Each tool registers itself in the table of run.cpp by the root tag(s) of its setup file; adding a
// tool is one row there.

#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace kneesim::tool {

/// How a run reports back.
struct RunOptions {
  std::ostream* out = nullptr;  ///< Summary output (nullptr: quiet).
  /// Progress callback: (what, done, total).
  std::function<void(const std::string&, int, int)> progress;
};

/// A tool that `kneesim run` can start from a setup file.
struct ToolEntry {
  std::string name;         ///< Short name, e.g. "ik".
  std::string root_tag;     ///< Setup-file element that selects it, e.g. "InverseKinematicsTool".
  /// Whether @p tag (any case) selects this tool; defaults to equality with root_tag.
  std::function<bool(const std::string& tag)> matches;
  /// Runs the tool described by the setup file at the path.
  std::function<void(const std::string& setup_path, const RunOptions&)> run;
};

/// The tools `kneesim run` knows, in the order they are tried.
const std::vector<ToolEntry>& getTools();

/// The tool a setup file describes (its ToolEntry::name). The root element or, inside an
/// <OpenSimDocument>, its first child selects it. Throws InputError naming the file, the element
/// and the known root tags for anything else.
std::string detectTool(const std::string& setup_path);

/// Runs the tool described by @p setup_path. Throws InputError for bad input.
void runSetupFile(const std::string& setup_path, const RunOptions& options);

}  // namespace kneesim::tool
