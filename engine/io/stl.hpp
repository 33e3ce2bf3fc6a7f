#pragma once
// STL triangle meshes (binary and ASCII).

#include <string>
#include <vector>

#include <Eigen/Core>

namespace kneesim::io {

/// An indexed triangle mesh. Vertices shared by several triangles are welded (exactly equal
/// coordinates become one vertex), so edges can be checked for manifoldness.
struct TriangleMesh {
  std::string source_file;
  std::vector<Eigen::Vector3d> vertices;  ///< In metres once read with a length scale.
  std::vector<Eigen::Vector3i> triangles; ///< Counter-clockwise seen from outside.

  int getNumVertices() const { return int(vertices.size()); }
  int getNumTriangles() const { return int(triangles.size()); }
  /// Axis-aligned bounds (min, max).
  std::pair<Eigen::Vector3d, Eigen::Vector3d> calcBounds() const;
  /// Area-weighted unit normal of each triangle.
  std::vector<Eigen::Vector3d> calcTriangleNormals() const;
  /// Area of each triangle.
  std::vector<double> calcTriangleAreas() const;
  /// Area-weighted (angle-free) vertex normals.
  std::vector<Eigen::Vector3d> calcVertexNormals() const;
  /// One third of the area of each incident triangle, summed per vertex (sums to the surface area).
  std::vector<double> calcVertexAreas() const;
  /// Edge defects of the surface.
  struct EdgeReport {
    int open = 0;        ///< Edges whose two directions are not used equally often (holes, flipped triangles).
    int pinched = 0;     ///< Edges shared by 4, 6, ... triangles with consistent orientation (still watertight).
  };
  /// Counts edges that make the surface open or non-manifold. A closed, consistently oriented
  /// surface has open == 0; pinched edges (two sheets touching along an edge) still bound a solid.
  EdgeReport calcEdgeReport() const;
  /// Signed volume (positive for an outward-oriented closed mesh).
  double calcVolume() const;
};

/// What readStl expects of a mesh.
struct StlOptions {
  double scale = 1.0;           ///< Multiplies the file's coordinates (1 for files in metres, 1e-3 for mm).
  bool require_closed = false;  ///< Reject meshes that are not closed and consistently oriented.
  /// Plausible size range of the mesh's largest extent, in metres after scaling. A knee implant
  /// read as metres must be 1 cm..50 cm; a file in millimetres read as metres is 1000x too big.
  double min_extent = 0.0;
  double max_extent = 1e30;
};

/// Reads a binary or ASCII STL file. Throws InputError naming the file for a missing, empty,
/// truncated or malformed file, a non-manifold mesh (if required), or an implausible size
/// ("largest extent 62.3 m, expected 0.01..0.5 m: is the file in millimetres?").
TriangleMesh readStl(const std::string& path, const StlOptions& options = {});

/// Writes a binary STL (atomic).
void writeStl(const std::string& path, const TriangleMesh& mesh);

}  // namespace kneesim::io
