#pragma once
// The kneesim setup files of one batch trial, as text: an InverseKinematicsTool, a
// ContactAreaTool and a KneeContactWorkflow setup (each runnable alone with `kneesim run`), and
// the BatchTrial setup that runs them in order (batch_trial.hpp).

#include <string>

#include "tool/batch_plan.hpp"

namespace kneesim::tool {

/// File names of a trial's setups and outputs, in its folder (all start with the trial's name).
struct BatchTrialFiles {
  static std::string batchSetup(const std::string& name) { return name + "_batch.xml"; }
  static std::string toolSetup(const std::string& name, const std::string& tool) { return name + "_" + tool + ".xml"; }
  static std::string ikMotion(const std::string& name) { return name + "_ik.mot"; }
  static std::string log(const std::string& name) { return name + ".log"; }
  static std::string summary(const std::string& name) { return name + "_summary.json"; }
  static std::string completion(const std::string& name) { return name + ".done"; }
  static std::string failure(const std::string& name) { return name + ".failed"; }
};

/// The setup file of @p tool ("ik", "contact" or "workflow") for the trial @p spec: inputs by
/// absolute path, outputs relative to the trial's folder.
std::string makeToolSetup(const BatchTrialSpec& spec, const std::string& tool);

/// The BatchTrial setup running the trial's tool setups in order.
std::string makeBatchTrialSetup(const BatchTrialSpec& spec);

}  // namespace kneesim::tool
