#pragma once
// A batch trial's completion marker: when a trial counts as finished. The marker is written last,
// atomically, after every output of the trial has been committed; it records the hash of the
// setup files that made the outputs and each output's size and hash. A trial counts as finished
// only when its marker exists, names the current setup files' hash and every output it lists is
// still there unchanged: an interrupted run (no marker), a changed manifest row (another hash) or
// a damaged output (another size or hash) all make the trial run again.

#include <string>
#include <vector>

namespace kneesim::tool {

/// Writes the completion marker @p path (JSON, atomically) for the outputs @p outputs (paths as the
/// tools reported them, relative to this process's folder or absolute), recorded relative to the
/// marker's folder.
void writeCompletionMarker(const std::string& path, const std::string& setup_hash,
                           const std::vector<std::string>& outputs, double seconds);

/// Whether the marker @p path exists, records @p setup_hash, and every output it lists has its
/// recorded size and hash. When not, @p why (if given) gets the reason, e.g. "no completion marker".
bool isTrialComplete(const std::string& path, const std::string& setup_hash, std::string* why = nullptr);

/// The seconds the trial took according to its marker (NaN without a readable marker).
double readCompletionSeconds(const std::string& path);

}  // namespace kneesim::tool
