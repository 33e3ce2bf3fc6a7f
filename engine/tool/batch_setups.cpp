// Writes the text of a batch trial's setup files (IK, contact area, workflow, BatchTrial).
#include "tool/batch_setups.hpp"

#include <cstdio>
#include <sstream>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"

namespace kneesim::tool {

namespace {

// "  <tag>value</tag>\n" with the value escaped; nothing for an empty value.
std::string element(const std::string& indent, const std::string& tag, const std::string& value) {
  if (value.empty()) return "";
  return indent + "<" + tag + ">" + xml::escape(value) + "</" + tag + ">\n";
}

std::string header(const BatchTrialSpec& spec, const std::string& what, const std::string& tool) {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!-- " + what + " of trial " + spec.trial + " of subject " +
         spec.subject + ", written by kneesim batch. Run this step alone: kneesim run " +
         BatchTrialFiles::toolSetup(spec.name, tool) + " -->\n";
}

bool runsTool(const BatchTrialSpec& spec, const std::string& tool) {
  for (const std::string& t : spec.tools)
    if (t == tool) return true;
  return false;
}

// The motion the contact and workflow steps read: this trial's IK output, or the manifest's.
std::string motionOf(const BatchTrialSpec& spec) {
  return runsTool(spec, "ik") ? BatchTrialFiles::ikMotion(spec.name) : spec.motion;
}

std::string makeIkSetup(const BatchTrialSpec& s) {
  std::ostringstream x;
  x << header(s, "Inverse kinematics", "ik") << "<OpenSimDocument Version=\"40000\">\n"
    << "  <InverseKinematicsTool name=\"" << xml::escape(s.name) << "\">\n"
    << element("    ", "model_file", s.model);
  if (!s.ik_tasks.empty()) x << "    <IKTaskSet file=\"" << xml::escape(s.ik_tasks) << "\" />\n";
  x << element("    ", "marker_file", s.markers) << element("    ", "time_range", s.time_range)
    << element("    ", "accuracy", formatRoundTrip(s.accuracy)) << element("    ", "marker_rotation", s.marker_rotation)
    << element("    ", "output_motion_file", BatchTrialFiles::ikMotion(s.name))
    << element("    ", "results_directory", ".") << element("    ", "report_errors", "true")
    << element("    ", "report_marker_locations", "false") << "  </InverseKinematicsTool>\n</OpenSimDocument>\n";
  return x.str();
}

// The elements the contact-area and workflow setups share: meshes, threshold, provider.
std::string implantElements(const BatchTrialSpec& s) {
  return element("  ", "femoral_component_file", s.femoral_component) + element("  ", "insert_file", s.insert) +
         element("  ", "threshold", formatRoundTrip(s.threshold)) + element("  ", "distance_provider", s.distance_provider);
}

std::string makeContactSetup(const BatchTrialSpec& s) {
  std::ostringstream x;
  x << header(s, "Implant contact area", "contact") << "<ContactAreaTool name=\"" << xml::escape(s.name) << "\">\n"
    << implantElements(s) << "  <ModelKinematics>\n"
    << element("    ", "model_file", s.model) << element("    ", "motion_file", motionOf(s))
    << element("    ", "femoral_body", s.femoral_body) << element("    ", "insert_body", s.insert_body)
    << element("    ", "femoral_mesh", s.femoral_mesh) << element("    ", "insert_mesh", s.insert_mesh)
    << "  </ModelKinematics>\n"
    << element("  ", "results_directory", ".") << "</ContactAreaTool>\n";
  return x.str();
}

// The workflow of one trial: its contact area, its measured force and the paper's Hertz law
// (R = 37 mm, nu held at 0.45: only K = E/(1-nu^2) is identifiable) fitted on its own window, so
// the errors are the law's in-sample errors against the measured force.
std::string makeWorkflowSetup(const BatchTrialSpec& s) {
  std::ostringstream x;
  x << header(s, "Contact area, measured knee force and the Hertz law fitted", "workflow") << "<KneeContactWorkflow name=\""
    << xml::escape(s.name) << "\">\n"
    << element("  ", "model_file", s.model) << implantElements(s) << element("  ", "femoral_body", s.femoral_body)
    << element("  ", "insert_body", s.insert_body) << element("  ", "femoral_mesh", s.femoral_mesh)
    << element("  ", "insert_mesh", s.insert_mesh) << element("  ", "kinematics", "model")
    << (s.body_mass > 0 ? element("  ", "body_mass", formatRoundTrip(s.body_mass)) : "")
    << "  <Trial name=\"" << xml::escape(s.name) << "\">\n"
    << element("    ", "fit", "true") << element("    ", "motion_file", motionOf(s))
    << element("    ", "c3d_file", s.c3d) << element("    ", "knee_forces_file", s.knee_forces)
    << element("    ", "window", s.window) << "  </Trial>\n"
    << "  <ContactLaw>\n    <plugins>hertz</plugins>\n    <name>hertz</name>\n"
    << "    <free_parameters>E nu</free_parameters>\n    <parameter name=\"R\">0.037</parameter>\n"
    << "    <assumed name=\"nu\">0.45</assumed>\n    <bounds name=\"E\">1e3 1e12</bounds>\n  </ContactLaw>\n"
    << element("  ", "results_directory", s.name + "_workflow") << element("  ", "plots", s.plots ? "true" : "false")
    << element("  ", "threads", "1") << element("  ", "timings", "false") << "</KneeContactWorkflow>\n";
  return x.str();
}

}  // namespace

std::string makeToolSetup(const BatchTrialSpec& spec, const std::string& tool) {
  if (tool == "ik") return makeIkSetup(spec);
  if (tool == "contact") return makeContactSetup(spec);
  if (tool == "workflow") return makeWorkflowSetup(spec);
  KNEESIM_CHECK(false, "makeToolSetup: unknown tool " + tool);
  return {};
}

std::string makeBatchTrialSetup(const BatchTrialSpec& s) {
  std::vector<std::string> files;
  for (const std::string& t : s.tools) files.push_back(BatchTrialFiles::toolSetup(s.name, t));
  std::ostringstream x;
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!-- Trial " << s.trial << " of subject " << s.subject
    << ", written by kneesim batch: runs the setup files below in order from this folder, then writes "
    << BatchTrialFiles::summary(s.name) << " and the completion marker " << BatchTrialFiles::completion(s.name)
    << ". Run: kneesim run " << BatchTrialFiles::batchSetup(s.name) << " -->\n"
    << "<BatchTrial name=\"" << xml::escape(s.name) << "\">\n"
    << element("  ", "subject", s.subject) << element("  ", "trial", s.trial) << element("  ", "activity", s.activity)
    << element("  ", "setup_files", join(files, " ")) << "</BatchTrial>\n";
  return x.str();
}

}  // namespace kneesim::tool
