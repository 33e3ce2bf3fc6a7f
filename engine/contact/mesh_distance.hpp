#pragma once
// Exact point-to-mesh signed distance and ray casting over an axis-aligned bounding-box tree.
//
// This is the engine's own reference for distances to a closed triangle mesh: exact (closest point
// over every triangle, pruned by the tree), signed by angle-weighted pseudonormals (Baerentzen &
// Aanaes 2005), with no dependency on a distance plugin. The FCL provider (plugins/distance_fcl)
// is the fast path; this one is for tests, for geometry preparation (implant seating, articular
// point selection) and as the fallback when no provider is loaded.

#include <limits>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "io/stl.hpp"

namespace kneesim::contact {

/// Closest-point result of MeshDistance::calcSignedDistance.
struct MeshDistanceQuery {
  /// Signed distance (m), negative inside the mesh; +infinity when no surface lies within the
  /// query's max_distance.
  double distance = std::numeric_limits<double>::infinity();
  Eigen::Vector3d closest = Eigen::Vector3d::Zero();  ///< Closest surface point (mesh frame).
  /// Unit pseudonormal of the closest feature (face, edge or vertex), pointing out of the mesh.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  int triangle = -1;  ///< Triangle holding the closest point.
};

/// Signed distances and ray hits against one triangle mesh, in the mesh's own frame.
/// Immutable after construction and safe to query from several threads.
class MeshDistance {
 public:
  /// Builds the tree over @p mesh (copied). The sign is meaningful only for a closed,
  /// consistently outward-oriented mesh (io::readStl with require_closed checks that).
  explicit MeshDistance(const io::TriangleMesh& mesh);

  /// Signed distance from @p p to the surface. Only surface points within @p max_distance are
  /// searched (the tree prunes everything farther), so a point farther than that from the
  /// surface, outside or inside, gets +infinity and no closest point. Returns true if found.
  bool calcSignedDistance(const Eigen::Vector3d& p, double max_distance, MeshDistanceQuery& out) const;
  /// Signed distance from @p p, searching without limit.
  double calcSignedDistance(const Eigen::Vector3d& p) const;

  /// Parameter t of the first intersection of the ray o + t d (d need not be unit) with the
  /// surface for t in (t_min, t_max), or +infinity when there is none.
  double calcRayHit(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min, double t_max) const;

  /// The mesh the tree was built over (a copy).
  const io::TriangleMesh& getMesh() const { return mesh_; }
  /// Unit outward normal of each triangle (zero for degenerate triangles).
  const std::vector<Eigen::Vector3d>& getTriangleNormals() const { return face_normal_; }

 private:
  struct Node {
    Eigen::AlignedBox3d box;
    int first = 0;   // leaf: first entry in order_; inner node: index of the left child
    int count = 0;   // leaf: number of triangles; inner node: 0
    int right = -1;  // inner node: index of the right child
  };
  int build(int begin, int end, std::vector<Eigen::Vector3d>& centroids);

  io::TriangleMesh mesh_;
  std::vector<Eigen::Vector3d> face_normal_;
  std::vector<Eigen::Vector3d> vertex_pseudonormal_;
  std::vector<Eigen::Vector3d> edge_pseudonormal_;  // per undirected edge
  std::vector<Eigen::Vector3i> tri_edges_;          // edge indices of each triangle: (v0v1, v1v2, v2v0)
  std::vector<int> order_;                          // triangle indices, leaves index ranges of it
  std::vector<Node> nodes_;
};

}  // namespace kneesim::contact
