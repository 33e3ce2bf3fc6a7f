#pragma once
// Output files of the contact-area computation: the per-trial storage (.sto) and per-frame
// distance maps as VTK PolyData (.vtp, ASCII XML) with a ParaView collection (.pvd).

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "contact/contact_area.hpp"
#include "io/storage.hpp"

namespace kneesim::contact {

/// The storage of a contact series: getContactChannels(series) then @p extra_columns (e.g. the
/// flexion angle of each frame, in SI units), named @p name, with header lines stating the units
/// of every column, the threshold(s), the area rule and the distance method, then @p header.
io::Storage makeContactStorage(const ContactSeries& series, const ContactAreaCalculator& calculator,
                               const std::string& name,
                               const std::vector<std::pair<std::string, std::vector<double>>>& extra_columns = {},
                               const std::vector<std::pair<std::string, std::string>>& header = {});

/// One frame of a distance map for writeDistanceMapVtp.
struct DistanceMapFrame {
  double time = 0;                                     ///< s (for the .pvd collection).
  Eigen::Isometry3d X_IF = Eigen::Isometry3d::Identity();  ///< Pose of the femoral component in I.
  /// Signed distance of each articular vertex (ContactAreaWorkspace::getDistances).
  std::vector<double> articular_distance;
};

/// Writes the insert as PolyData in its frame I with point data "distance" (signed distance to
/// the femoral component in m, negative inside; articular vertices from @p frame, the others
/// computed with @p femur_distance when given, else the search radius; all clamped to +- the
/// calculator's search radius, so a value at the clamp means "at least that far"), "articular"
/// (1 on the articular surface) and "contact" (1 where the distance is below the threshold).
/// Atomic. Throws InputError naming the path if it cannot be written.
void writeInsertVtp(const std::string& path, const ContactAreaCalculator& calculator, const DistanceMapFrame& frame,
                    const MeshDistance* femur_distance = nullptr);

/// Writes @p mesh transformed by @p X (points X * p) as PolyData without point data (atomic).
void writeMeshVtp(const std::string& path, const io::TriangleMesh& mesh, const Eigen::Isometry3d& X);

/// A dataset of a ParaView collection: time, part number and file (relative to the .pvd).
struct PvdEntry {
  double time = 0;
  int part = 0;
  std::string file;
};
/// Writes a ParaView collection (.pvd) listing @p entries (atomic).
void writePvd(const std::string& path, const std::vector<PvdEntry>& entries);

}  // namespace kneesim::contact
