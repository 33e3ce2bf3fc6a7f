#pragma once
// Ground reactions straight from a C3D file's force plates, as OpenSim's ExternalLoads want them:
// the plates' analog outputs low-passed, each plate's force, centre of pressure and free moment
// (io::calcPlateWrench: FORCE_PLATFORM TYPE 2 or 4 with CAL_MATRIX, CORNERS, ORIGIN, CHANNEL),
// zero below a threshold, each loaded stretch of a plate given to the foot whose markers stand
// over it, summed per foot, and written as OpenSim's GRF .mot with its ExternalLoads XML.
//
// Per foot <p> the columns are <p>_ground_force_v{x,y,z} (N), <p>_ground_force_p{x,y,z} (m, on the
// floor) and <p>_ground_torque_{x,y,z} (N·m, the free moment about the vertical), all in the
// model's ground (the lab frame turned by the marker rotation); the ExternalForce of a foot with a
// body applies them to it, expressed in ground.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "dynamics/external_loads.hpp"
#include "io/c3d.hpp"
#include "io/storage.hpp"

namespace kneesim::dynamics {

/// A foot that plates can be assigned to.
struct FootSpec {
  std::string name;                  ///< Column prefix, e.g. "r".
  std::string body;                  ///< Model body the load is applied to; "" to assign plates only.
  std::vector<std::string> markers;  ///< Markers over the foot (heel, toe) the plates are matched with.
  SourceLocation where;
};

/// How the plates are read.
struct PlateLoadOptions {
  double threshold_n = 20.0;     ///< A plate is unloaded while its normal force is below this (N).
  double cutoff_hz = 30.0;       ///< Low-pass of the plate outputs (OpenSim's Butterworth), negative for none.
  /// Lab frame to model ground: body-fixed X-Y-Z angles in degrees (as IK's marker_rotation).
  Eigen::Vector3d rotation_deg = Eigen::Vector3d::Zero();
  std::vector<FootSpec> feet;    ///< At least one.
};

/// A loaded stretch of one plate and the foot it went to.
struct PlateAssignment {
  int plate = 0;                 ///< 0-based.
  double start = 0, end = 0;     ///< s
  std::string foot;              ///< FootSpec::name.
  double distance_m = 0;         ///< Mean horizontal distance from the centre of pressure to that foot's markers.
};

/// Ground reactions of a trial.
struct GroundReactions {
  io::Storage grf;               ///< OpenSim's GRF table (see the file comment), at the analog rate.
  ExternalLoadsSpec loads;       ///< One ExternalForce per foot with a body; datafile empty until written.
  std::vector<PlateAssignment> assignments;
};

/// Computes the ground reactions of @p c3d. Throws InputError naming the file and plate for a
/// plate whose type is not 2 or 4, a type-4 plate without CAL_MATRIX, NaN in a plate's channels,
/// a foot marker missing from the file, or a loaded stretch no foot marker can be matched with.
GroundReactions calcGroundReactions(const io::C3dFile& c3d, const PlateLoadOptions& options);

/// Writes @p grf's table to @p mot_path and its ExternalLoads to @p xml_path (the datafile named
/// relative to the XML's folder), both staged in @p out.
void stageGroundReactions(const GroundReactions& grf, const std::string& mot_path, const std::string& xml_path,
                          AtomicFileSet& out);

}  // namespace kneesim::dynamics
