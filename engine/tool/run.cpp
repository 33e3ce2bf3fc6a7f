#include "tool/run.hpp"

#include "core/error.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "dynamics/tool.hpp"
#include "gap/tool.hpp"
#include "ik/marker_placer.hpp"
#include "ik/tool.hpp"
#include "muscle/analyze_tool.hpp"
#include "tool/batch_trial.hpp"
#include "tool/contact_area_tool.hpp"
#include "tool/knee_contact_workflow.hpp"
#include "tool/knee_model.hpp"

namespace kneesim::tool {

namespace {

void runMarkerPlacerTool(const std::string& setup_path, const RunOptions& options) {
  const ik::MarkerPlacerResult r = ik::runMarkerPlacer(ik::readMarkerPlacerSetup(setup_path));
  if (options.out) ik::printMarkerPlacerSummary(r, *options.out);
}

void runIkTool(const std::string& setup_path, const RunOptions& options) {
  const ik::IkSetup setup = ik::readIkSetup(setup_path);
  ik::IkRunOptions ro;
  if (options.progress) ro.progress = [&](int d, int t) { options.progress("IK", d, t); };
  const ik::IkReport report = ik::runIk(setup, ro);
  if (options.out) ik::printIkSummary(report, *options.out);
}

void runIdTool(const std::string& setup_path, const RunOptions& options) {
  const dynamics::IdReport report = dynamics::runInverseDynamicsTool(dynamics::readIdSetup(setup_path));
  if (options.out) dynamics::printIdSummary(report, *options.out);
}

void runAnalyzeTool(const std::string& setup_path, const RunOptions& options) {
  const muscle::AnalyzeReport report = muscle::runAnalyzeTool(muscle::readAnalyzeSetup(setup_path));
  if (options.out) muscle::printAnalyzeSummary(report, *options.out);
}

void runContactAreaTool(const std::string& setup_path, const RunOptions& options) {
  const ContactAreaSetup setup = readContactAreaSetup(setup_path);
  const ContactAreaReport report = runContactArea(setup, {options.progress});
  if (options.out) printContactAreaSummary(report, *options.out);
}

void runWorkflowTool(const std::string& setup_path, const RunOptions& options) {
  const WorkflowReport report = runWorkflow(readWorkflowSetup(setup_path), options);
  if (options.out) printWorkflowSummary(report, *options.out);
}

std::vector<ToolEntry> makeTools() {
  std::vector<ToolEntry> tools;
  // OpenSim accepts its own historical misspellings (e.g. "InverseKinemtaticsTool").
  tools.push_back({"ik", "InverseKinematicsTool",
                   [](const std::string& tag) {
                     const std::string t = toLower(tag);
                     return startsWith(t, "inversekinem") && endsWith(t, "tool");
                   },
                   runIkTool});
  tools.push_back({"id", "InverseDynamicsTool", nullptr, runIdTool});
  tools.push_back({"analyze", "AnalyzeTool", nullptr, runAnalyzeTool});
  tools.push_back({"knee-model", "KneeModelTool", nullptr, runKneeModelTool});
  tools.push_back({"marker-placer", "MarkerPlacer", nullptr, runMarkerPlacerTool});
  tools.push_back({"contact-area", "ContactAreaTool", nullptr, runContactAreaTool});
  tools.push_back({"gap", "GapTool", {}, [](const std::string& setup, const RunOptions& o) {
                     const gap::GapRunResult r = gap::runGap(gap::readGapSetup(setup));
                     if (o.out) gap::printGapSummary(r, *o.out);
                   }});
  tools.push_back({"knee-contact-workflow", "KneeContactWorkflow", nullptr, runWorkflowTool});
  tools.push_back({"batch-trial", "BatchTrial", nullptr, [](const std::string& setup, const RunOptions& o) {
                     const BatchTrialReport r = runBatchTrial(readBatchTrialSetup(setup), o);
                     if (o.out) printBatchTrialSummary(r, *o.out);
                   }});
  return tools;
}

const ToolEntry* findTool(const std::string& tag) {
  for (const ToolEntry& t : getTools())
    if (t.matches ? t.matches(tag) : t.root_tag == tag) return &t;
  return nullptr;
}

}  // namespace

const std::vector<ToolEntry>& getTools() {
  static const std::vector<ToolEntry> tools = makeTools();
  return tools;
}

std::string detectTool(const std::string& setup_path) {
  auto doc = xml::Document::load(setup_path);
  xml::Node root = doc->root();
  xml::Node selector = root;
  if (root.name() == "OpenSimDocument") {
    const auto kids = root.children();
    if (kids.empty()) root.fail("empty <OpenSimDocument> (expected a tool element inside it)");
    selector = kids.front();
  }
  if (const ToolEntry* t = findTool(selector.name())) return t->name;
  std::string known;
  for (const ToolEntry& t : getTools()) known += (known.empty() ? "" : ", ") + t.root_tag;
  selector.fail("unknown tool <" + selector.name() + "> (expected one of " + known + ")");
}

void runSetupFile(const std::string& setup_path, const RunOptions& options) {
  const std::string name = detectTool(setup_path);
  for (const ToolEntry& t : getTools())
    if (t.name == name) return t.run(setup_path, options);
}

}  // namespace kneesim::tool
