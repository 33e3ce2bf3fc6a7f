#pragma once
// Marker registration, after OpenSim's MarkerPlacer: solve the pose by IK, move the markers in
// their body frames to where the measured markers are, and repeat.
//
// OpenSim's MarkerPlacer poses the model once, from one static trial, and puts each marker
// exactly where it was measured. kneesim's placer does the same with one frame, and with many
// frames (several trials, static and dynamic) it alternates the two steps on
//
//   J(q_1..q_F, p) = sum_f sum_m w_m |x_fm - X_GB(q_f) p_m|^2  +  sum_m mu_m |p_m - p0_m|^2
//
// IK over every frame with the markers held (q step), then each marker at the average of its
// measured positions expressed in its body frame, pulled toward its model location p0 by mu
// "frames' worth" of prior and kept within max_marker_movement of it (p step). Each step lowers J,
// so the loop converges; it stops when no marker moves by more than the tolerance. Directions the
// data cannot see (a rotation of all of a segment's markers about its joint, which a coordinate
// offset undoes) are held where the first IK pass put them: at the model's own markers' gauge.
//
// Markers flagged as unplaced (a placeholder location, e.g. the body origin) get no prior and no
// IK weight until they have been placed once. Markers with Model::Marker::fixed are not moved.
#include <limits>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "ik/solver.hpp"
#include "ik/tool.hpp"
#include "io/marker_table.hpp"

namespace kneesim::ik {

/// Settings of the alternation.
struct MarkerPlacerOptions {
  int max_iterations = 20;           ///< q/p alternations at most.
  double tolerance = 1e-5;           ///< Stop once no marker moves more than this in one p step (m).
  double prior_weight = 1.0;         ///< mu: weight of each marker's model location, in frames.
  /// Largest distance a marker may move from its model location (m); infinity: unbounded.
  double max_marker_movement = std::numeric_limits<double>::infinity();
  SolverOptions solver;              ///< IK settings of the q step.
};

/// One marker of the registration.
struct PlacerMarker {
  int marker = -1;        ///< Index into Model::markers.
  double weight = 1.0;    ///< IK weight in the q step (0: placed but does not steer the pose).
  bool move = true;       ///< False keeps the model's location (Marker::fixed, or asked for).
  bool unplaced = false;  ///< Placeholder location: no prior, no IK weight before it is placed.
};

/// Frames of one trial, already matched to the placer's markers.
struct PlacerTrial {
  std::string name;
  std::vector<double> time;                           ///< s, one per frame.
  /// Per frame, one measured position per PlacerMarker (ground, m; NaN when missing).
  std::vector<std::vector<Eigen::Vector3d>> observed;
  double weight = 1.0;                                ///< Weight of each frame of this trial.
};

/// Figures of one q step (with the markers it started from).
struct PlacerIteration {
  double mean_rms = 0;      ///< Mean over frames of the per-frame marker RMS (m).
  double max_movement = 0;  ///< Largest marker movement of the following p step (m).
  double objective = 0;     ///< J before the p step.
};

/// Per-marker outcome.
struct PlacedMarkerReport {
  std::string name;
  std::string body;
  Eigen::Vector3d initial = Eigen::Vector3d::Zero();  ///< Model location before (body frame, m).
  Eigen::Vector3d placed = Eigen::Vector3d::Zero();   ///< After (body frame, m).
  int frames = 0;           ///< Frames in which it was measured.
  double rms_error = 0;     ///< RMS distance to the measurements with the final markers and poses (m).
  bool clamped = false;     ///< Its movement was limited by max_marker_movement.
};

/// What a registration produced.
struct MarkerPlacerResult {
  std::shared_ptr<model::Model> model;       ///< The input model with the placed markers.
  std::vector<PlacerIteration> iterations;
  std::vector<PlacedMarkerReport> markers;   ///< One per PlacerMarker.
  std::vector<double> trial_mean_rms;        ///< Per trial, final markers (m).
  std::vector<std::vector<Eigen::VectorXd>> poses;  ///< Final IK solution per trial and frame.
  bool converged = false;
};

/// Registers the markers of @p model against @p trials (see the file comment). Coordinate tasks
/// (default_value or manual_value references) regularise the IK of the q step.
MarkerPlacerResult placeMarkers(const model::ModelPtr& model, const std::vector<PlacerMarker>& markers,
                                const std::vector<CoordinateTask>& coordinate_tasks,
                                const std::vector<double>& coordinate_references,
                                const std::vector<PlacerTrial>& trials, const MarkerPlacerOptions& options);

/// One trial of a <MarkerPlacer> setup file.
struct PlacerTrialSpec {
  std::string name;
  std::string marker_file;  ///< Resolved path.
  double time_start = -std::numeric_limits<double>::infinity();
  double time_end = std::numeric_limits<double>::infinity();
  int frame_stride = 1;     ///< Every n-th frame of the time range.
  double weight = 1.0;      ///< Weight of each of its frames.
  SourceLocation where;
};

/// The contents of a <MarkerPlacer> setup file, paths resolved against its folder.
struct MarkerPlacerSetup {
  std::string setup_file;
  std::string name;
  std::string model_file;
  std::vector<TaskSpec> tasks;            ///< IKTaskSet (inline or file=).
  std::vector<PlacerTrialSpec> trials;    ///< <marker_file>/<time_range>, or a MarkerPlacerTrialSet.
  std::vector<std::string> unplaced_markers;
  std::vector<std::string> fixed_markers;
  MarkerPlacerOptions options;
  std::string output_model_file;          ///< Resolved; required.
  std::string output_marker_file;         ///< CSV of the placed markers ("" for none).
  std::string output_motion_file;         ///< IK of the first trial with the placed markers ("" for none).
};

/// Reads a <MarkerPlacer> setup file. Throws InputError (file, line, element) on bad input.
MarkerPlacerSetup readMarkerPlacerSetup(const std::string& path);

/// Runs a setup: loads the model and the trials, registers, writes the outputs atomically after
/// everything is computed. Returns the result (its model is what was written).
MarkerPlacerResult runMarkerPlacer(const MarkerPlacerSetup& setup);

/// Writes the iterations, per-trial RMS and per-marker table of @p result.
void printMarkerPlacerSummary(const MarkerPlacerResult& result, std::ostream& os);

}  // namespace kneesim::ik
