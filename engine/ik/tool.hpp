#pragma once
// OpenSim's InverseKinematicsTool: read its setup XML, run IK over a marker file, write results.

#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/xml.hpp"
#include "ik/solver.hpp"

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
};

/// Reads an InverseKinematicsTool setup file (also OpenSim's misspelled root tags, an IKTaskSet
/// inline or in a file="..." attribute). Throws InputError with file, line and element.
IkSetup readIkSetup(const std::string& path);

/// Appends the IKMarkerTask and IKCoordinateTask elements of an <IKTaskSet> element (its
/// <objects>, or its own children) to @p out. Throws InputError for an unknown task type.
void readTaskSet(const xml::Node& set, std::vector<TaskSpec>& out);

/// Reads an IKTaskSet file (root <IKTaskSet> or <OpenSimDocument><IKTaskSet>).
std::vector<TaskSpec> readTaskFile(const std::string& path);

/// Per-marker error summary over a run (metres).
struct MarkerErrorSummary {
  std::string name;
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
  std::vector<std::string> outputs;    ///< Files written.
  double mean_rms = 0, max_error = 0;
  double seconds_solving = 0;
};

/// Options for running.
struct IkRunOptions {
  /// Called now and then with (frames done, frames total).
  std::function<void(int, int)> progress;
};

/// Runs IK as the setup describes and writes the motion (degrees for rotational coordinates, as
/// OpenSim does) and, if asked, the marker-error and marker-location reports. Every output is
/// written atomically after all frames are solved, so a failed run leaves no partial files.
IkReport runIk(const IkSetup& setup, const IkRunOptions& options = {});

/// Writes a readable summary of @p report (per-marker table, worst frames) to @p os.
void printIkSummary(const IkReport& report, std::ostream& os);

}  // namespace kneesim::ik
