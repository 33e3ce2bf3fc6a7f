// Writes and checks batch trials' completion markers (JSON: setup hash, outputs' sizes and hashes).
#include "tool/batch_completion.hpp"

#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/strings.hpp"
#include "tool/batch_plan.hpp"

namespace kneesim::tool {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string hashFile(const std::string& path) { return calcSetupHash({readFileText(path)}); }

// The marker as JSON, or null when it is missing or unreadable (a marker is never half-written,
// but a user may have edited it).
json readMarker(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return nullptr;
  try {
    json j = json::parse(readFileText(path));
    return j.is_object() ? j : json(nullptr);
  } catch (const std::exception&) {
    return nullptr;
  }
}

}  // namespace

void writeCompletionMarker(const std::string& path, const std::string& setup_hash,
                           const std::vector<std::string>& outputs, double seconds) {
  const fs::path folder = fs::absolute(fs::path(path)).parent_path();
  json list = json::array();
  for (const std::string& o : outputs) {
    const fs::path abs = fs::absolute(fs::path(o)).lexically_normal();
    list.push_back({{"file", abs.lexically_relative(folder).string()},
                    {"bytes", fs::file_size(abs)},
                    {"fnv1a64", hashFile(abs.string())}});
  }
  const json j = {{"setup_hash", setup_hash}, {"seconds", seconds}, {"outputs", list}};
  writeFileAtomically(path, [&](std::ostream& os) { os << j.dump(2) << "\n"; });
}

bool isTrialComplete(const std::string& path, const std::string& setup_hash, std::string* why) {
  const auto fail = [&](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  const json j = readMarker(path);
  if (j.is_null()) return fail("no completion marker");
  if (j.value("setup_hash", "") != setup_hash) return fail("its setup files changed since it finished");
  if (!j.contains("outputs") || !j["outputs"].is_array()) return fail("its completion marker lists no outputs");
  const fs::path folder = fs::absolute(fs::path(path)).parent_path();
  for (const json& o : j["outputs"]) {
    const std::string file = (folder / o.value("file", "")).lexically_normal().string();
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) return fail("output " + file + " is missing");
    if (fs::file_size(file, ec) != o.value("bytes", std::uintmax_t(0)) || hashFile(file) != o.value("fnv1a64", ""))
      return fail("output " + file + " changed since it finished");
  }
  return true;
}

double readCompletionSeconds(const std::string& path) {
  const json j = readMarker(path);
  if (j.is_null() || !j.contains("seconds") || !j["seconds"].is_number()) return std::numeric_limits<double>::quiet_NaN();
  return j["seconds"].get<double>();
}

}  // namespace kneesim::tool
