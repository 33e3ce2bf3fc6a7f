#pragma once
// OpenSim's InverseKinematicsTool: read its setup XML, run IK over a marker file, write results.
//
// Differences from OpenSim, on purpose:
// - Coordinate couplers are always enforced exactly (eliminated: the dependent coordinate is
//   computed from its independents), as OpenSim does with constraint_weight = Infinity. A finite
//   constraint_weight, which OpenSim turns into a penalty on the coupler errors, is not used for
//   them; the run says so in a warning when the model has couplers. The other constraints
//   (Point, PointOnLine, ConstantDistance, Weld) follow constraint_weight as OpenSim does.
// - coordinate_file values are interpolated linearly (OpenSim fits GCV splines).
// - accuracy is the convergence tolerance of each frame: a frame is solved when the next
//   Gauss-Newton step would change no coordinate by more than accuracy (rad or m), or would move
//   no tracked marker by more than accuracy (m).
// - Marker names are matched exactly, then with a Vicon subject prefix ("JW:RAsis"), then
//   ignoring the separators '.', '_', '-' and ' ' ("R.Thigh.Superior" finds "RThighSuperior").
// - <marker_rotation> (kneesim's addition) rotates the marker data into the model's ground, e.g.
//   "-90 0 0" for a Z-up laboratory and a Y-up OpenSim model.
// - Every output of a run is written after all frames are solved, and all appear together or
//   not at all.

#include <functional>
#include <limits>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/xml.hpp"
#include "ik/solver.hpp"
#include "io/marker_table.hpp"
#include "io/storage.hpp"
#include "model/model.hpp"

namespace kneesim::ik {

/// One IKMarkerTask or IKCoordinateTask as written in the setup file.
struct TaskSpec {
  enum class Kind { Marker, Coordinate } kind = Kind::Marker;
  std::string name;
  bool apply = true;
  double weight = 1.0;
  /// Coordinate tasks: "default_value", "manual_value" or "from_file".
  std::string value_type = "default_value";
  double value = 0.0;  ///< manual_value, in the coordinate's SI unit (rad or m).
  SourceLocation where;
};

/// The contents of an InverseKinematicsTool setup file, with paths resolved against the setup
/// file's folder.
struct IkSetup {
  std::string setup_file;
  std::string name;
  std::string model_file;
  std::string marker_file;
  std::string coordinate_file;     ///< "" if none.
  std::string output_motion_file;  ///< Resolved path.
  std::string results_directory;   ///< Resolved path for error/marker reports.
  std::vector<TaskSpec> tasks;
  double constraint_weight = std::numeric_limits<double>::infinity();
  double accuracy = 1e-5;
  double time_start = -std::numeric_limits<double>::infinity();
  double time_end = std::numeric_limits<double>::infinity();
  bool report_errors = true;
  bool report_marker_locations = false;
  SolverOptions solver;
  /// Rotation applied to the marker data before IK, as body-fixed X-Y-Z angles in degrees
  /// (kneesim's <marker_rotation>): p_model_ground = R p_file.
  Eigen::Vector3d marker_rotation_deg = Eigen::Vector3d::Zero();
  /// Where each element was found in the setup file (element name -> location), for errors.
  std::map<std::string, SourceLocation> locations;

  /// The location of element @p element of the setup file (its line if it was read from one).
  SourceLocation locate(const std::string& element) const;
};

/// Reads an InverseKinematicsTool setup file (also OpenSim's misspelled root tags, an IKTaskSet
/// inline or in a file="..." attribute). Throws InputError with file, line and element.
IkSetup readIkSetup(const std::string& path);

/// Appends the IKMarkerTask and IKCoordinateTask elements of an <IKTaskSet> element (its
/// <objects>, or its own children) to @p out. Throws InputError for an unknown task type.
void readTaskSet(const xml::Node& set, std::vector<TaskSpec>& out);

/// Reads an IKTaskSet file (root <IKTaskSet> or <OpenSimDocument><IKTaskSet>).
std::vector<TaskSpec> readTaskFile(const std::string& path);

/// Reads the <IKTaskSet> element @p set of a setup file in folder @p setup_dir: the tasks of the
/// file its file="..." attribute names (relative to @p setup_dir; "Unassigned" or empty means
/// none), else its own tasks. Throws InputError at @p set when the named file does not exist.
std::vector<TaskSpec> readTaskSetElement(const xml::Node& set, const std::string& setup_dir);

/// Per-marker error summary over a run (metres).
struct MarkerErrorSummary {
  std::string name;        ///< Model marker name.
  std::string data_label;  ///< The marker-file label it was matched with.
  int frames = 0;          ///< Frames in which the marker was present and used.
  double mean = 0, rms = 0, max = 0;
};

/// What a run did.
struct IkReport {
  int frames_total = 0;
  int frames_solved = 0;
  std::vector<double> time;            ///< Per solved frame.
  std::vector<FrameResult> frames;     ///< Per solved frame.
  std::vector<std::string> worst_marker;  ///< Per solved frame.
  std::vector<MarkerErrorSummary> markers;
  std::vector<std::string> warnings;
  std::vector<std::string> outputs;    ///< Files written (or staged, see IkRunOptions::stage).
  io::Storage motion;                  ///< The motion as written (angles in degrees).
  model::ModelPtr model;               ///< The model the run used.
  double mean_rms = 0, max_error = 0;
  double seconds_solving = 0;
  int iterations = 0;                  ///< Gauss-Newton iterations over all frames.
  int loose_name_matches = 0;          ///< Markers matched ignoring separators.
  int constraints = 0;                 ///< Model::constraints enforced or penalised.
  /// Largest violation of Model::constraints over the solved frames (m, or rad for a weld's
  /// orientation; see FrameResult::max_constraint_error).
  double max_constraint_error = 0;
  double constraint_weight = 0;        ///< The setup's constraint_weight (infinity: enforced).
};

/// Options for running.
struct IkRunOptions {
  /// Called now and then with (frames done, frames total).
  std::function<void(int, int)> progress;
  /// If set, the outputs are staged in this set instead of being committed, so that a larger
  /// workflow can publish them together with its own outputs (or not at all if it fails later).
  AtomicFileSet* stage = nullptr;
  /// False: nothing is written or staged (the report's motion holds the result), for callers
  /// that keep the answer in memory, such as the Python bindings.
  bool write = true;
};

/// Runs IK as the setup describes and writes the motion (degrees for rotational coordinates, as
/// OpenSim does) and, if asked, the marker-error reports (<name>_ik_marker_errors.sto per frame,
/// <name>_ik_marker_error_table.sto per frame and marker, <name>_ik_marker_error_summary.csv
/// per marker) and the model marker locations. Every output is written after all frames are
/// solved, and all of them commit together: a failed run leaves none. Throws InputError naming
/// the file and element for bad input.
IkReport runIk(const IkSetup& setup, const IkRunOptions& options = {});

/// Runs IK as @p setup describes on @p model and @p markers, which were read or built by the
/// caller: the setup's model_file and marker_file only name them in messages. The setup's
/// marker_rotation is applied to @p markers. Writes what runIk() writes unless options.write is
/// false.
IkReport runIk(const IkSetup& setup, model::ModelPtr model, io::MarkerTable markers,
               const IkRunOptions& options = {});

/// The coordinates @p q (SI, one vector per time in @p time) as OpenSim writes a motion: a time
/// column, then one column per model coordinate, rotations in degrees (in_degrees = yes).
io::Storage makeMotion(const model::Model& m, const std::string& name, const std::vector<double>& time,
                       const std::vector<Eigen::VectorXd>& q);

/// Writes a readable summary of @p report (per-marker table, worst frames) to @p os.
void printIkSummary(const IkReport& report, std::ostream& os);

}  // namespace kneesim::ik
