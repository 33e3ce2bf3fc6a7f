#pragma once
// Internal to the knee contact workflow (tool/knee_contact_workflow.hpp): what its steps share (the
// inputs read once, each trial's state, small helpers) and the steps, one file each:
//   knee_contact_workflow.cpp  the order of the steps (runWorkflow) and the printed summary
//   workflow_setup.cpp         reading the setup file
//   workflow_trials.cpp        per trial: forces, kinematics source, gait events, poses, areas
//   workflow_area.cpp          contact areas in parallel and their derivatives
//   workflow_identify.cpp      the identification, predictions, phases and threshold refits
//   workflow_outputs.cpp       the per-trial storage files and summary.json
//   workflow_plots.cpp         the plots (the paper's Figures 6-9, goniometer calibrations)
// Not part of the public API (not installed).

#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "contact/contact_area.hpp"
#include "core/atomic_file.hpp"
#include "core/json.hpp"
#include "core/strings.hpp"
#include "io/storage.hpp"
#include "plugin/registry.hpp"
#include "tool/knee_contact_workflow.hpp"

namespace kneesim::tool::detail {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kDeg = M_PI / 180.0;
// Dao & Pouletaut 2015, section 3.3: peak contact areas of the five gaits.
constexpr double kPaperPeakLow = 1016e-6, kPaperPeakHigh = 1117e-6;

inline std::string fmt(double v, int digits = 6) { return formatSignificant(v, digits); }

using Clock = std::chrono::steady_clock;
inline double secondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

template <class T>
std::vector<T> subset(const std::vector<T>& v, const std::vector<int>& keep) {
  std::vector<T> out;
  out.reserve(keep.size());
  for (int i : keep) out.push_back(v[size_t(i)]);
  return out;
}

/// Reports progress of a step: what, done, total.
using Progress = std::function<void(const std::string&, int, int)>;

struct TrialState {
  WorkflowTrialSpec spec;
  WorkflowTrialResult result;
  io::Storage motion;        // degrees for rotations when in_degrees
  std::string motion_label;  // for messages
};

// What every trial shares, read once (members in the order they are built and must be destroyed).
struct WorkflowInputs {
  ImplantMeshes meshes;
  plugin::Registry registry;
  std::unique_ptr<contact::ContactAreaCalculator> calculator;
  // One workspace per thread (each builds the provider's structures once for the whole run).
  std::vector<std::unique_ptr<contact::ContactAreaWorkspace>> wss;
  // The area derivatives need only the main threshold: a calculator without the extra ones
  // searches a narrower band.
  std::unique_ptr<contact::ContactAreaCalculator> derivative_calculator;
  std::vector<std::unique_ptr<contact::ContactAreaWorkspace>> derivative_wss;
  model::ModelPtr model;
  bool flex_rot = false;  // the flexion coordinate is rotational
  MuscleChainModel muscle_chain;  // built when the setup's MuscleChain is on
};

// ---- per trial (workflow_trials.cpp)

// Fills states[oi].result: forces, kinematics, gait events, poses, contact areas (and their
// derivatives) and the identification's view of the trial.
void processTrial(const WorkflowSetup& setup, WorkflowInputs& in, std::vector<TrialState>& states, size_t oi,
                  WorkflowReport& report, AtomicFileSet& outputs, const Progress& progress);
// The musculoskeletal estimate's errors per phase (after identifyAndPredict made the phases).
void compareTrialMuscleLoads(const WorkflowSetup& setup, TrialState& st);
// The results folder of a trial.
std::string trialDirectory(const WorkflowSetup& setup, const std::string& trial);

// ---- contact areas (workflow_area.cpp)

// The contact series of @p X_IF with one thread per workspace, each on a contiguous block of
// frames (so a coherent distance provider keeps its warm starts within a block).
contact::ContactSeries calcSeriesInParallel(const contact::ContactAreaCalculator& calculator,
                                            std::vector<std::unique_ptr<contact::ContactAreaWorkspace>>& wss,
                                            const std::vector<double>& time,
                                            const std::vector<Eigen::Isometry3d>& X_IF,
                                            const std::function<void(int, int)>& progress);
// The areas S of a series (@p extra < 0) or those at its extra threshold @p extra.
std::vector<double> areaSeries(const contact::ContactSeries& s, int extra);
bool isRotational(const model::ModelPtr& model, const WorkflowSetup& setup);
// The step of the area's flexion derivative in the coordinate's SI unit.
double getFlexionStep(const WorkflowSetup& setup, bool rotational);
// The area derivatives of one trial (WorkflowSetup::area_derivatives), named like its channels.
std::vector<std::pair<std::string, std::vector<double>>> calcAreaDerivatives(
    const WorkflowSetup& setup, const WorkflowTrialSpec& spec, const model::ModelPtr& model, const ImplantMeshes& meshes,
    const io::Storage& motion, int motion_flex, double flex_unit, const ContactAreaSetup& cs, const ContactKinematics& k,
    const std::vector<int>& keep, const contact::ContactAreaCalculator& calculator,
    std::vector<std::unique_ptr<contact::ContactAreaWorkspace>>& wss, std::vector<std::string>& notes,
    const std::function<void(int, int)>& progress);

// ---- identification (workflow_identify.cpp)

// The window of a trial from its spec and gait events; throws when the events it needs are missing.
identify::TimeWindow resolveWindow(const WorkflowTrialSpec& spec, const io::GaitCycle& c);
// Whether @p law reads the two compartments' areas (hertz_ml): each compartment's share is then
// predicted with the other's area zeroed.
bool isPerCompartment(const identify::ContactLaw& law);
// Fits @p law on the training trials, predicts every trial (window, whole trial, phases, cycle
// bins) and refits at the extra thresholds; fills report.fit, threshold_refits and seconds_fit.
void identifyAndPredict(const WorkflowSetup& setup, const identify::ContactLaw& law, std::vector<TrialState>& states,
                        WorkflowReport& report, const Progress& progress);
nlohmann::json phaseJson(const PhaseError& e);

// ---- outputs (workflow_outputs.cpp)

// Each trial's contact-area and force storage files.
void addTrialOutputs(const WorkflowSetup& setup, const WorkflowInputs& in, const identify::ContactLaw& law,
                     const std::vector<TrialState>& states, AtomicFileSet& outputs);
// summary.json.
nlohmann::json makeSummary(const WorkflowSetup& setup, const WorkflowInputs& in, const identify::ContactLaw& law,
                           const std::vector<TrialState>& states, const std::vector<std::string>& plot_files,
                           const WorkflowReport& report);

// ---- plots (workflow_plots.cpp)

// Draws the plots (when setup.plots and gnuplot is usable) into @p outputs; returns their files.
std::vector<std::string> makeWorkflowPlots(const WorkflowSetup& setup, const WorkflowInputs& in,
                                           const identify::ContactLaw& law, const std::vector<TrialState>& states,
                                           WorkflowReport& report, AtomicFileSet& outputs);

}  // namespace kneesim::tool::detail
