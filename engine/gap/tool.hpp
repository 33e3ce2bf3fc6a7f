#pragma once
// The gap tool: a <GapTool> setup file (run by `kneesim gap SETUP.xml` or `kneesim run SETUP.xml`)
// naming plugins, the baseline law, the effects and the trials, and writing gap_report.json,
// gap_report.md and the plots into the results folder.
//
//   <GapTool name="jw_gap">
//     <results_directory>gap_results</results_directory>   relative to the setup file
//     <plugins>hertz gap_effects</plugins>
//     <law>hertz</law>
//     <free_parameters>E nu</free_parameters>              identify::fit's free set
//     <assumed_values>nu 0.45</assumed_values>             name value pairs
//     <parameter_values>R 0.037</parameter_values>         name value pairs
//     <effects>all</effects>                               or a list of effect names
//     <targets>total medial lateral</targets>
//     <body_mass>66.7</body_mass>
//     <cv_folds>0</cv_folds>  <screen_top>4</screen_top>  <max_effects>3</max_effects>
//     <alpha>0.05</alpha>  <structure_alpha>0.01</structure_alpha>
//     <min_relative_improvement>0.05</min_relative_improvement>  <confidence_level>0.95</confidence_level>
//     <bootstrap_samples>200</bootstrap_samples>           of the baseline identification
//     <workflow_results>results/paper_workflow</workflow_results>   a KneeContactWorkflow's results:
//                            each trial without <contact_area> reads <dir>/<name>/<name>_contact_area.sto
//     <plots>true</plots>
//     <emg_flexors>bifeml semimem medgas latgas</emg_flexors>  <emg_extensors>vasmed vaslat rf</emg_extensors>
//     <trials>
//       <Trial name="ngait_og3" activity="gait">
//         <knee_forces>...csv</knee_forces>  <contact_area>...sto</contact_area>   (no knee_forces:
//                            the trial can only be predicted, kneesim gap --predict)
//         <c3d>...c3d</c3d>  <kinematics>...mot</kinematics>  <flexion_column>knee_flexion</flexion_column>
//         <flexion_source>auto</flexion_source>  <events>auto</events>  <event_times>...</event_times>
//         <time_range>t0 t1</time_range>
//         <gon_calibration>gain offset_deg</gon_calibration>  knee flexion = offset + gain x goniometer
//                            degrees (io/goniometer.hpp; GON in volts converted first; default JW's)
//       </Trial>
//     </trials>
//   </GapTool>

#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include "gap/diagnosis.hpp"
#include "gap/prediction.hpp"
#include "gap/report.hpp"
#include "gap/trial_inputs.hpp"

namespace kneesim::gap {

/// Everything a <GapTool> setup file says.
struct GapSetup {
  std::string setup_file;          ///< Path of the setup file ("" when built in code).
  std::string name = "gap";
  std::string results_directory = "gap_results";  ///< Absolute, or relative to the working directory.
  std::vector<std::string> plugins{"hertz", "gap_effects"};
  std::string law = "hertz";
  /// A KneeContactWorkflow's results folder ("" none): trials without a contact-area file read
  /// <workflow_results>/<name>/<name>_contact_area.sto, and trials without <knee_loads> its
  /// <name>/<name>_knee_loads.sto where the workflow's inverse dynamics wrote one (setWorkflowResults).
  std::string workflow_results;
  std::vector<std::string> effects;  ///< Empty: every loaded effect.
  std::vector<TrialSource> trials;
  DiagnosisOptions options;
  ReportOptions report;
};

/// Reads a <GapTool> setup file; paths inside it are taken relative to its folder. Throws a
/// one-line InputError for a malformed file, an unknown element, a bad number or no trials.
GapSetup readGapSetup(const std::string& path);

/// Replaces the folder of every trial's contact-area file by @p directory (keeping file names):
/// how `kneesim gap --areas DIR` points a setup at the contact-area tool's output.
void setContactAreaDirectory(GapSetup& setup, const std::string& directory);

/// Points every trial at a KneeContactWorkflow's results folder @p directory: its contact-area
/// file becomes <directory>/<name>/<name>_contact_area.sto (the workflow's output: areas at every
/// threshold, the flexion coordinate and, with area_derivatives, dS_dflexion and dS_dap), and a
/// trial without its own <knee_loads> reads <directory>/<name>/<name>_knee_loads.sto where that file
/// exists (the workflow writes it for trials with an id_setup_file: the knee_load effect's channels).
/// How `kneesim gap --workflow-results DIR` and the workflow's own gap step use its results.
void setWorkflowResults(GapSetup& setup, const std::string& directory);

/// What runGap produced.
struct GapRunResult {
  GapReport report;
  std::string directory;              ///< Where the files went.
  std::vector<std::string> files;     ///< Files written, relative to directory.
  std::vector<std::string> dead_emg;  ///< EMG channels dropped as dead.
};

/// Loads the plugins, assembles the trials, runs the diagnosis and writes the report.
GapRunResult runGap(const GapSetup& setup, const std::function<void(const std::string&)>& log = {});

/// A few lines for the terminal: verdicts, withheld errors, where the report is.
void printGapSummary(const GapRunResult& result, std::ostream& out);

/// What runPredict produced.
struct PredictRunResult {
  GapModel model;
  std::vector<TrialPrediction> predictions;
  std::string directory;
  std::vector<std::string> files;  ///< Relative to directory.
};

/// Applies the gap model @p model_path (a diagnosis's gap_model.json) to the setup's trials, which need
/// no knee forces (without them the frames are the contact-area file's; with them the report adds the
/// prediction's RMSE), and writes <results_directory>/<trial>_predicted.sto: time, cycle_phase and the
/// predicted force of every target the model has (total, medial, lateral; and "<target>_measured").
PredictRunResult runPredict(const GapSetup& setup, const std::string& model_path,
                            const std::function<void(const std::string&)>& log = {});

/// A few lines for the terminal: the model and each trial's prediction.
void printPredictSummary(const PredictRunResult& result, std::ostream& out);

}  // namespace kneesim::gap
