#pragma once
// OpenSim's InverseDynamicsTool: read its setup XML, run inverse dynamics over a coordinate
// file with external loads, write the generalised forces (and, kneesim's addition, net joint
// loads).
//
// Setup elements read as OpenSim reads them: model_file, coordinates_file,
// lowpass_cutoff_frequency_for_coordinates, time_range, external_loads_file, forces_to_exclude,
// results_directory, output_gen_force_file, coordinates_in_degrees (OpenSim 3's; when absent,
// the file's inDegrees or its "Angles are in degrees." line decides).
// kneesim's additions: joint_loads (joint names or All), joint_loads_on (child|parent),
// joint_loads_expressed_in (ground|parent|child), output_joint_loads_file; and <ForcePlates>, the
// external loads straight from a C3D file (dynamics/c3d_loads.hpp): c3d_file, threshold,
// lowpass_cutoff_frequency, marker_rotation, <Foot name=".."><body/><markers/></Foot>...,
// output_grf_file (the GRF .mot OpenSim would read, written with its ExternalLoads .xml); and
// <KneeLoads>: joint, axes (the tibial frame's x y z, e.g. "posterior superior medial"),
// output_file: the knee's net load in clinical terms (dynamics/knee_loads.hpp).
// Differences on purpose:
// - Without a time_range the analysed frames stop at the coordinate file's own first and last
//   rows (OpenSim would also analyse the reflected padding added for filtering).
// - Model forces kneesim does not simulate (muscles, ligaments, springs, actuators) are left out
//   whatever forces_to_exclude says; a run names those OpenSim would have applied.
// - joints_to_report_body_forces (OpenSim's equivalent body forces) is read, not written: a
//   warning points to joint_loads.

#include <limits>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/xml.hpp"
#include "dynamics/c3d_loads.hpp"
#include "dynamics/knee_loads.hpp"
#include "dynamics/trajectory.hpp"
#include "io/storage.hpp"

namespace kneesim::dynamics {

/// The contents of an InverseDynamicsTool setup file, paths resolved against its folder.
struct IdSetup {
  std::string setup_file;
  std::string name;
  std::string model_file;
  std::string coordinates_file;
  std::string external_loads_file;  ///< "" for none.
  std::string results_directory;
  std::string output_gen_force_file;     ///< Resolved path (results_directory/..., .sto added).
  std::string output_joint_loads_file;   ///< Resolved path.
  double cutoff_hz = -1.0;
  double time_start = -std::numeric_limits<double>::infinity();
  double time_end = std::numeric_limits<double>::infinity();
  int coordinates_in_degrees = -1;  ///< 1 yes, 0 no, -1 from the file.
  std::vector<std::string> forces_to_exclude;
  std::vector<std::string> joint_loads;  ///< Joint names, or "All".
  LoadOnBody joint_loads_on = LoadOnBody::Child;
  LoadFrame joint_loads_frame = LoadFrame::Child;
  std::vector<std::string> joints_to_report_body_forces;
  std::string plates_c3d_file;        ///< <ForcePlates>: "" when the loads come from external_loads_file.
  PlateLoadOptions plates;
  std::string output_grf_file;        ///< Resolved .mot path; the .xml beside it.
  std::string knee_joint;             ///< <KneeLoads>: "" for none.
  KneeAxes knee_axes;
  std::string output_knee_loads_file; ///< Resolved path.
  std::map<std::string, SourceLocation> locations;

  /// Location of element @p element (the tool element if it was not written).
  SourceLocation locate(const std::string& element) const;
};

/// The path element @p tag of a setup names, resolved against @p dir; "" when empty or "Unassigned".
std::string optionalPath(const xml::Node& tool, const char* tag, const std::string& dir);

/// Whether a coordinate file's angles are in degrees (inDegrees=yes, or OpenSim 2's "Angles are in
/// degrees." header line).
bool fileSaysDegrees(const io::Storage& s);

/// Reads an InverseDynamicsTool setup (<OpenSimDocument><InverseDynamicsTool> or bare). Throws
/// InputError (file:line: element: ...) for a missing file, unknown element or bad value.
IdSetup readIdSetup(const std::string& path);

/// What a run did.
struct IdReport {
  io::Storage generalized_forces;  ///< As written.
  io::Storage joint_loads;         ///< As written (no columns if none were asked for).
  io::Storage knee_loads;          ///< As written (no columns without <KneeLoads>).
  std::vector<std::string> notes;     ///< What was decided (plate assignments).
  std::vector<std::string> warnings;
  std::vector<std::string> outputs;
  int frames = 0;
  double seconds_solving = 0;      ///< CPU time of the frame loop (smoothing excluded).
  double seconds_total = 0;        ///< CPU time of the whole run.
};

/// Options for running.
struct IdRunOptions {
  /// If set, outputs are staged here instead of committed (see ik::IkRunOptions::stage).
  AtomicFileSet* stage = nullptr;
  /// If set, the coordinates (as a coordinates_file would hold them) instead of reading
  /// coordinates_file, which then only names them in messages (a workflow's IK motion, staged
  /// but not yet written).
  const io::Storage* coordinates = nullptr;
};

/// Runs the setup and writes its outputs, all after every frame is computed. Throws InputError
/// for bad input: a missing file, a body or column that does not exist, NaN, times of the force
/// data that do not overlap the analysed frames.
IdReport runInverseDynamicsTool(const IdSetup& setup, const IdRunOptions& options = {});

/// A readable summary of @p report.
void printIdSummary(const IdReport& report, std::ostream& os);

}  // namespace kneesim::dynamics
