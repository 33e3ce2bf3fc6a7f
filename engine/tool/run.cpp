#include "tool/run.hpp"

#include "core/error.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "ik/tool.hpp"

namespace kneesim::tool {

namespace {
bool isIkTag(const std::string& tag) {
  const std::string t = toLower(tag);
  return startsWith(t, "inversekinem") && endsWith(t, "tool");
}
}  // namespace

std::string detectTool(const std::string& setup_path) {
  auto doc = xml::Document::load(setup_path);
  xml::Node root = doc->root();
  std::vector<xml::Node> candidates = {root};
  for (const xml::Node& c : root.children()) candidates.push_back(c);
  for (const xml::Node& n : candidates) {
    if (isIkTag(n.name())) return "ik";
  }
  std::string seen = root.name();
  if (root.name() == "OpenSimDocument" && !root.children().empty()) seen = root.children().front().name();
  root.fail("unknown tool <" + seen + "> (expected InverseKinematicsTool)");
}

void runSetupFile(const std::string& setup_path, const RunOptions& options) {
  const std::string kind = detectTool(setup_path);
  if (kind == "ik") {
    const ik::IkSetup setup = ik::readIkSetup(setup_path);
    ik::IkRunOptions ro;
    if (options.progress) ro.progress = [&](int d, int t) { options.progress("IK", d, t); };
    const ik::IkReport report = ik::runIk(setup, ro);
    if (options.out) ik::printIkSummary(report, *options.out);
  }
}

}  // namespace kneesim::tool
