#pragma once
// KneeContactWorkflow: Dao & Pouletaut 2015 end to end from one setup file.
//
// Per trial: knee kinematics (IK from the trial's marker file with an OpenSim IK setup, an existing
// motion, or knee flexion from the eKnee goniometer) -> the implant contact area per frame (the
// femoral component and tibial insert placed by the model, or by the paper's seated hinge) -> the
// measured knee force (eKnee load cells, equation 4, rows re-timed to the C3D frames and resampled
// at the motion's frames) -> gait events from the force plates. Then a contact law is identified on
// the training trial(s) and predicts every trial. Outputs (all written together after everything
// is computed): per trial the motion, the contact-area storage and a force storage (measured and
// predicted), a summary.json (identified parameters with intervals and identifiability, errors per
// trial and phase, contact-area peaks, timings) and PNG plots after the paper's Figures 6-9.
//
// Each step reuses the engine: ik::runIk, tool::calcModelKinematics / calcHingeKinematics,
// contact::calcContactSeries, io::readKneeForces / retimeToFrames / resampleKneeForces,
// io::findFootContacts, identify::fit / predict, tool::renderPlots.

#include <limits>
#include <cmath>
#include <map>
#include <memory>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "contact/contact_area.hpp"
#include "gap/tool.hpp"
#include "identify/fit.hpp"
#include "io/gait_events.hpp"
#include "io/goniometer.hpp"
#include "io/knee_forces.hpp"
#include "tool/contact_area_tool.hpp"
#include "tool/run.hpp"
#include "tool/workflow_knee_loads.hpp"
#include "tool/workflow_muscles.hpp"

namespace kneesim::tool {

/// One trial of a workflow setup.
struct WorkflowTrialSpec {
  std::string name;
  /// Whether the trial is fitted (training) or only predicted.
  bool fit = false;
  /// Where the knee kinematics come from.
  enum class Source { ik, motion, goniometer } source = Source::motion;
  std::string ik_setup_file;    ///< Source::ik: an InverseKinematicsTool setup (resolved).
  std::string motion_file;      ///< Source::motion: a .mot/.sto with the model's coordinates (resolved).
  std::string knee_forces_file;  ///< eKnee CSV (resolved).
  /// An InverseDynamicsTool setup with <KneeLoads> (resolved; "" none), run on the trial's motion:
  /// the knee's net loads beside the measured forces (tool/workflow_knee_loads.hpp).
  std::string id_setup_file;
  /// C3D of the trial (resolved; "" none): aligns the force rows with its frames and gives the
  /// gait events. Defaults to the IK setup's marker file when that is a .c3d.
  std::string c3d_file;
  /// Source::goniometer: flexion from GON by io::calcKneeFlexionDeg with this calibration (GON in
  /// volts converted to goniometer degrees first), its line given (<scale>, <offset_deg>) or
  /// fitted on the trials named in calibrate_on (pooled, io::fitGoniometerCalibration).
  io::GoniometerCalibration goniometer;
  std::vector<std::string> calibrate_on;
  std::string heel_marker = "RHeel";  ///< Foot whose plate contacts define the gait events.
  /// Gait events given by hand (s): strike, toe-off, next strike (any may be NaN); empty: from the
  /// C3D's force plates.
  std::vector<double> gait_events;
  /// Frames the fit uses and the trial's main error figures cover: "stance" (heel strike to
  /// toe-off), "cycle" (heel strike to the next), "trial" (every frame) or explicit times.
  std::string window = "stance";
  double window_begin = std::numeric_limits<double>::quiet_NaN();
  double window_end = std::numeric_limits<double>::quiet_NaN();
  double time_start = -std::numeric_limits<double>::infinity();
  double time_end = std::numeric_limits<double>::infinity();
  SourceLocation where;  ///< The <Trial> element.
};

/// The contents of a KneeContactWorkflow setup file, paths resolved against its folder.
struct WorkflowSetup {
  std::string setup_file;
  std::string name = "workflow";
  std::string model_file;  ///< The model placing the components (and the IK model of the trials).
  /// Meshes, thresholds, distance provider, component directions; model.femoral_body etc. name the
  /// bodies and meshes of the components; hinge.seating_grid the hinge's grid.
  ContactAreaSetup contact;
  /// "model": the model's kinematics at every frame; "hinge": the paper's hinge (flexion only,
  /// seated) driven by the flexion coordinate of the motion.
  std::string kinematics = "model";
  std::string flexion_coordinate = "knee_flexion";
  double body_mass = 0;  ///< kg (0: errors are not reported in body weights).
  /// Also compute the area's derivatives along the flexion coordinate and along an anterior shift
  /// of the femoral component (central differences of S, S_medial, S_lateral at poses with the
  /// flexion shifted by +-flexion_step through the model's couplers or the hinge, and with the
  /// femur translated by +-ap_step along the insert's anterior direction): the channels
  /// dS_dflexion, dS_medial_dflexion, dS_lateral_dflexion (m^2/rad), dS_dap, dS_medial_dap,
  /// dS_lateral_dap (m^2/m) the gap diagnosis's kinematic-input effects read. Four more area
  /// evaluations per frame (at the main threshold only).
  bool area_derivatives = false;
  /// Step of the flexion coordinate in its SI unit (NaN: 0.5 degree for a rotational coordinate,
  /// 0.1 mm for a translational one).
  double flexion_step = std::numeric_limits<double>::quiet_NaN();
  double ap_step = 2e-4;                   ///< m.
  /// <GapTool> setups (resolved) run after the workflow's outputs are written, on this run's
  /// contact-area files (their workflow_results set to results_directory), each report in
  /// <results_directory>/gap/<GapTool name>/.
  std::vector<std::string> gap_setup_files;
  std::vector<WorkflowTrialSpec> trials;
  /// <MuscleChain>: the knee contact force from muscle forces on every trial with an
  /// id_setup_file (tool/workflow_muscles.hpp).
  MuscleChainSetup muscles;
  std::vector<std::string> law_plugins{"hertz"};  ///< Plugins registering the law.
  std::string law = "hertz";
  identify::FitOptions fit;  ///< Free parameters, values, bounds, assumed values, intervals.
  /// Refit with each extra threshold's area in place of S (no intervals), to show how the fit
  /// depends on the threshold.
  bool threshold_sensitivity = true;
  /// A frame agrees when |predicted - measured| <= agreement_fraction * the window's peak
  /// measured force (the paper's "good convergence", section 3.4, made a number).
  double agreement_fraction = 0.1;
  std::string results_directory;  ///< Resolved.
  bool plots = true;
  std::string gnuplot = "gnuplot";
  bool plot_scripts = true;  ///< Also write each plot's gnuplot script.
  /// Report each step's seconds in summary.json (false: leave them out, so that two runs of the
  /// same setup write the same bytes, as `kneesim batch` checks).
  bool timings = true;
  /// Threads computing the contact area (each with its own distance-provider context); the
  /// reader turns 0 into one per core, at most 4.
  int threads = 1;
};

/// Reads a KneeContactWorkflow setup (root <KneeContactWorkflow>, or inside <OpenSimDocument>).
/// Throws InputError with file, line and element for unknown elements, bad values, a trial without
/// kinematics or forces, no training trial, a calibration naming an unknown trial.
WorkflowSetup readWorkflowSetup(const std::string& path);

/// Error statistics over one named part of a trial.
struct PhaseError {
  std::string name;
  double begin = 0, end = 0;   ///< s.
  double begin_percent = std::numeric_limits<double>::quiet_NaN();  ///< Of the gait cycle, if any.
  double end_percent = std::numeric_limits<double>::quiet_NaN();
  identify::FitMetrics metrics{};
  double agreement = std::numeric_limits<double>::quiet_NaN();  ///< Fraction of frames that agree.
};

/// Everything computed for one trial.
struct WorkflowTrialResult {
  std::string name;
  bool fit = false;
  std::string kinematics_description;
  std::vector<std::string> notes;  ///< Plain statements (sources, calibrations, frames dropped).
  std::vector<double> time;        ///< s, the frames with kinematics and measured force.
  std::vector<double> flexion;     ///< rad, the flexion coordinate at those frames.
  contact::ContactSeries contact;
  std::vector<std::pair<std::string, std::vector<double>>> kinematics_columns;  ///< Hinge columns.
  io::KneeForces forces;           ///< At those frames (N).
  std::vector<io::FootContact> contacts;
  io::GaitCycle cycle;             ///< Incomplete without two strikes.
  identify::Trial trial;           ///< The identification's view (channels, windows).
  identify::PredictionReport window_prediction;  ///< Over the window.
  identify::PredictionReport trial_prediction;   ///< Over every frame.
  std::vector<double> predicted_medial, predicted_lateral;  ///< Per compartment (laws on S_medial/S_lateral).
  std::vector<PhaseError> phases;  ///< Gait phases or stance/outside.
  std::vector<PhaseError> cycle_bins;  ///< 10% bins of the gait cycle (complete cycles only).
  double window_agreement = std::numeric_limits<double>::quiet_NaN();  ///< Fraction of window frames.
  double cycle_agreement = std::numeric_limits<double>::quiet_NaN();   ///< Fraction of cycle frames.
  double ik_mean_rms = std::numeric_limits<double>::quiet_NaN();      ///< m, when IK ran.
  TrialKneeLoads knee_loads;  ///< When the trial has an id_setup_file (else an empty table).
  /// The musculoskeletal knee force (MuscleChain on and an id_setup_file; else total is empty).
  TrialMuscleLoads muscle_loads;
  /// The goniometer calibration used (Source::goniometer) and whether the trial's GON was in volts.
  io::GoniometerCalibration goniometer;
  bool goniometer_in_volts = false;
  /// The area derivative channels (WorkflowSetup::area_derivatives), in storage order.
  std::vector<std::pair<std::string, std::vector<double>>> area_derivatives;
  double seconds_ik = 0, seconds_kinematics = 0, seconds_area = 0, seconds_area_derivatives = 0;
};

/// A refit with another threshold's area as S.
struct ThresholdRefit {
  std::string channel;  ///< e.g. "S@1mm".
  double threshold = 0;  ///< m.
  std::map<std::string, double> derived;  ///< e.g. K.
  std::vector<std::pair<std::string, identify::FitMetrics>> per_trial;  ///< Window metrics.
  std::string solver_status;
};

/// What a workflow run did.
struct WorkflowReport {
  std::string name;
  std::vector<WorkflowTrialResult> trials;
  identify::FitReport fit;
  std::vector<ThresholdRefit> threshold_refits;
  std::string law_description;
  std::vector<std::string> outputs;
  std::vector<std::string> warnings;
  std::string summary_file;
  std::string plots_problem;  ///< Why plots were not drawn ("" if they were or were not asked for).
  /// The gap diagnoses run after the workflow (WorkflowSetup::gap_setup_files).
  std::vector<std::shared_ptr<const gap::GapRunResult>> gap;
  /// The MuscleChain's muscles: adopted, and left out with the reason.
  std::vector<std::string> muscles_adopted, muscles_left_out;
  double seconds_total = 0, seconds_fit = 0, seconds_plots = 0, seconds_gap = 0;
};

/// Runs the workflow. Every output is staged and committed together at the end: a failed run
/// leaves none. Throws InputError naming the file and element for bad input. Missing gnuplot is
/// not an error: the report says why there are no plots.
WorkflowReport runWorkflow(const WorkflowSetup& setup, const RunOptions& options = {});

/// A least-squares line y = a + b x through finite pairs; NaNs skipped. Returns {a, b, r, rms}.
struct LineFit {
  double a = 0, b = 0, r = 0, rms = 0;
  int n = 0;
};
LineFit fitLine(const std::vector<double>& x, const std::vector<double>& y);

/// Writes a readable summary (trials, identified parameters, errors, outputs) to @p os.
void printWorkflowSummary(const WorkflowReport& report, std::ostream& os);

}  // namespace kneesim::tool
