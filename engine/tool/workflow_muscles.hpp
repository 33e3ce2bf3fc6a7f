#pragma once
// The knee contact force the musculoskeletal way, per KneeContactWorkflow trial (<MuscleChain>):
// the workflow's IK motion and the trial's inverse-dynamics setup (coordinates filtered as it
// says, ground reactions from its C3D force plates) -> static optimization with the muscles of
// a donor model (JW's UF model) carried onto the workflow's model (muscle/adopt_muscles.hpp) and
// reserve CoordinateActuators from actuator-set files -> the knee joint's reaction on the tibial
// component with those muscle forces -> its compressive force, split medial/lateral by the
// frontal-plane moment about the two compartments' contact centroids the contact-area step
// found at each frame -> errors against the eKnee total, medial and lateral forces per phase.
//
// The split: the reaction on the tibial body (force f, moment m about the frame's origin, in its
// frame) is carried by two compressive forces along -superior at the medial and lateral contact
// centroids c_m, c_l and a shear at their mid-point O: F_m + F_l = F = -f.superior and, about the
// anterior axis a through O, -(d/2)(F_m - F_l) = (m - O x f).a with d = (c_m - c_l).medial. A
// compartment without contact at a frame uses its centroid averaged over the trial's frames.

#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "contact/contact_area.hpp"
#include "core/error.hpp"
#include "core/xml.hpp"
#include "dynamics/knee_loads.hpp"
#include "identify/metrics.hpp"
#include "io/knee_forces.hpp"
#include "io/storage.hpp"
#include "model/model.hpp"
#include "muscle/static_optimization.hpp"
#include "tool/plot.hpp"

namespace kneesim::tool {

/// The <MuscleChain> element of a workflow setup, paths resolved.
struct MuscleChainSetup {
  bool on = false;
  std::string muscle_model_file;  ///< The donor of the muscles (an .osim).
  /// "donor:target" body names where they differ (e.g. tibial_tray:tibial_component).
  std::vector<std::pair<std::string, std::string>> body_map;
  /// Bodies whose frame differs between the models: placed as the donor's default pose places
  /// them on their parent (muscle::calcDefaultPoseCorrespondence).
  std::vector<std::string> reframe_bodies;
  std::vector<std::string> exclude_muscles;  ///< Donor muscles left out by name.
  std::vector<std::string> force_set_files;  ///< Reserve actuator sets (OpenSim <ForceSet> files).
  muscle::SoOptions so;                      ///< activation_exponent, use_muscle_physiology.
  std::string knee_joint = "knee";           ///< Its child is the tibial component.
  /// A reserve "carries load" at a frame where |its force| >= this (N·m or N).
  double reserve_threshold = 1.0;
  SourceLocation where;
};

/// Reads <MuscleChain> (@p dir resolves its paths). Throws InputError for unknown elements and
/// bad values.
MuscleChainSetup readMuscleChainSetup(const xml::Node& element, const std::string& dir);

/// The workflow's model with the donor's muscles and the reserves, built once for every trial.
struct MuscleChainModel {
  model::ModelPtr model;
  std::vector<std::string> adopted, left_out;
  std::vector<std::string> residuals;  ///< Actuators on the root joint's coordinates (not reserves).
};

/// Builds the chain's model on @p target. Throws InputError at the setup's elements.
MuscleChainModel buildMuscleChainModel(const MuscleChainSetup& setup, const model::ModelPtr& target);

/// One actuator that is not a muscle, over a trial.
struct ChainReserve {
  std::string name;
  bool residual = false;     ///< On the root joint (carries what the model's missing parts need).
  int frames_loaded = 0;     ///< Frames with |force| >= the threshold.
  double peak = 0;           ///< Largest |force| (N·m or N).
  double time_of_peak = std::numeric_limits<double>::quiet_NaN();
};

/// The errors of the musculoskeletal estimate over one part of a trial.
struct ChainPhase {
  std::string name;
  double begin = 0, end = 0;
  identify::FitMetrics total, medial, lateral;
  double r_total = std::numeric_limits<double>::quiet_NaN(), r_medial = r_total, r_lateral = r_total;
};

/// The chain's results for one trial.
struct TrialMuscleLoads {
  std::vector<double> time;        ///< Chain frames (the inverse-dynamics setup's), s.
  Eigen::MatrixX3d force, moment;  ///< Reaction on the tibial body, its frame; moment about its origin.
  io::Storage activations, forces;  ///< Static optimization's, OpenSim's layout.
  io::Storage reaction;             ///< Per chain frame: compressive force, shears, moments.
  dynamics::KneeAxes axes;
  /// At the workflow's frames (N): compressive total, medial, lateral.
  std::vector<double> total, medial, lateral;
  std::vector<double> split_time;  ///< The workflow's frames of total, medial and lateral, s.
  int frames_without_contact_centroid = 0;  ///< Frames using a trial-mean centroid.
  std::vector<ChainReserve> reserves;
  int short_frames = 0;               ///< Frames where the actuators fall short of ID.
  std::vector<std::string> warnings;
  std::vector<ChainPhase> phases;     ///< "trial", "window", then the workflow's phases.
  double seconds = 0, cpu_ms_per_frame = 0;
};

/// Runs static optimization and the knee reaction over @p motion (the trial's IK, in place of
/// the ID setup's coordinates_file; @p motion_file names it) with the ID setup's filtering,
/// frames and ground reactions. Throws InputError for bad input.
TrialMuscleLoads runTrialMuscleChain(const MuscleChainSetup& setup, const MuscleChainModel& chain,
                                     const std::string& id_setup_file, const io::Storage& motion,
                                     const std::string& motion_file, const SourceLocation& where);

/// Fills total, medial and lateral at the workflow's frames @p time from the reaction and the
/// contact centroids of @p contact (one frame per time).
void splitMuscleLoads(TrialMuscleLoads& loads, const std::vector<double>& time, const contact::ContactSeries& contact);

/// Fills loads.phases: errors against @p forces (at @p time) over the trial, the window
/// [window_begin, window_end] and each of @p phases (name, begin, end); @p body_mass in kg.
void compareMuscleLoads(TrialMuscleLoads& loads, const std::string& trial, const std::vector<double>& time,
                        const io::KneeForces& forces, double window_begin, double window_end,
                        const std::vector<std::pair<std::string, std::pair<double, double>>>& phases,
                        double body_mass);

/// Measured and musculoskeletal total, medial and lateral forces (and @p hertz, the contact
/// law's total, when not empty) against @p x.
Plot makeMuscleLoadPlot(const TrialMuscleLoads& loads, const io::KneeForces& forces, const std::vector<double>& hertz,
                        const std::vector<double>& x, const std::string& xlabel, const std::string& trial);

/// The knee's net loads of inverse dynamics (@p knee_loads: time and knee_* columns, at the chain's
/// frames) with the musculoskeletal compressive force beside them as knee_muscle_total and its
/// medial/lateral split (splitMuscleLoads) as knee_muscle_medial and knee_muscle_lateral: the
/// channels a gap diagnosis testing the muscle_load effect reads (plugins/muscle_load; on a
/// compartment target the diagnosis reads that compartment's column as knee_muscle_total).
io::Storage makeGapLoadTable(const io::Storage& knee_loads, const TrialMuscleLoads& loads);

/// summary.json's muscle_chain entry of a trial.
nlohmann::json toJson(const TrialMuscleLoads& loads, bool timings = true);

}  // namespace kneesim::tool
