#pragma once
// The target mesh of the distance_fcl providers: vertices, triangles, angle-weighted
// pseudonormals (for signs), FCL 0.7's OBBRSS tree over it, and exact closest-triangle searches
// over that tree: one point at a time, or eight at a time with AVX2 (packet search).

#include <memory>
#include <string>
#include <vector>

#include <fcl/fcl.h>

#include "contact/closest_point.hpp"
#include "plugin/kneesim_plugin.h"

namespace kneesim_distance_fcl {

using Vec3 = Eigen::Vector3d;

// The engine's closest-point routine (header-only: inlined into the searches here).
using Feature = kneesim::contact::TriangleFeature;
using kneesim::contact::calcClosestOnTriangle;

// Up to eight query points searched together, one AVX2 lane each (struct of arrays). Unused
// lanes have best2 < 0: they never need a node.
struct Packet {
  alignas(32) double x[8], y[8], z[8];  // the points, in the target's frame
  alignas(32) double best2[8];          // squared distance of the best triangle so far, or the squared bound
  int tri[8];                           // best triangle so far, -1 for none
};

// The target mesh with its FCL tree, pseudonormals and searches. Immutable after build().
class Target {
 public:
  // Returns an empty string or the reason the mesh is unusable. `compact` builds the compact
  // tree the searches below walk (median split); without it only FCL's own queries
  // (findClosestFcl) work, over FCL's default tree (mean split), which they traverse fastest.
  std::string build(const kneesim_mesh_view& view, bool compact);

  // Signed distance from p to triangle t (negative inside), with the closest point.
  double signedDistance(const Vec3& p, int t, Vec3& closest) const;
  // Unsigned distance from p to triangle t.
  double unsignedDistance(const Vec3& p, int t) const;

  // The triangle closest to p among those nearer than bound, or -1, over the compact tree. With
  // a hint (any triangle, or -1) the search starts at the hint's leaf and walks up.
  int findClosestTree(const Vec3& p, double bound, int hint) const;
  // The same by FCL's generic fcl::distance (a radius-0 sphere against the mesh) with
  // DistanceResult preset to the bound.
  int findClosestFcl(const Vec3& p, double bound) const;

  // For n points p[i] (in the target's frame), the closest triangle nearer than bound, or -1,
  // into out[i]; hints[i] (or -1; hints may be null) seed each search. Uses the packet search
  // when the CPU has AVX2 and FMA (and usePackets() was not switched off), else findClosestTree.
  void findClosestBatch(const Vec3* p, int n, const int* hints, double bound, int* out) const;
  // Whether findClosestBatch uses the AVX2 packet search.
  bool usesPackets() const { return packets_; }
  // Forces the scalar search (tests compare both).
  void setUsePackets(bool on);

  int getNumTriangles() const { return int(triangles_.size()); }
  int getNumVertices() const { return int(vertices_.size()); }
  const Vec3& getVertex(int v) const { return vertices_[size_t(v)]; }
  const Eigen::Vector3i& getTriangle(int t) const { return triangles_[size_t(t)]; }
  // Unit normal of triangle t (zero for a degenerate triangle).
  const Vec3& getFaceNormal(int t) const { return face_normal_[size_t(t)]; }
  // Axis-aligned bounding box of the vertices.
  const Eigen::AlignedBox3d& getBox() const { return box_; }

  // A node of the compact tree: FCL's RSS (rectangle swept sphere) of the node in float. The two
  // children of a node are adjacent (one 128-byte fetch), pairs in depth-first order; the root is
  // node 0. The rectangle is in the coordinates of its own axes ax (rows: the two edge directions
  // and the normal), at offset c = ax * corner.
  struct alignas(64) Node {
    float ax[9];
    float c[3];
    float l0, l1;  // edge lengths
    float r;       // sphere radius, enlarged by the float-rounding margin
    int child;     // the first of the two children, or -(triangle + 1) for a leaf
  };
  // The compact tree (empty unless built with `compact`) and the origin of its coordinates.
  const std::vector<Node>& getNodes() const { return nodes_; }
  const Vec3& getOrigin() const { return origin_; }

 private:
  void buildCompactTree();
  void searchSubtree(int root, const Vec3& p, const Eigen::Vector3f& pf, double& best, int& best_tri) const;
  void searchPacket(Packet& pk) const;  // in packet.cpp

  std::vector<Vec3> vertices_;
  std::vector<Eigen::Vector3i> triangles_;
  std::vector<Vec3> face_normal_, vertex_normal_, edge_normal_;
  std::vector<Eigen::Vector3i> tri_edges_;  // (v0v1, v1v2, v2v0) edge indices
  Eigen::AlignedBox3d box_;
  std::shared_ptr<fcl::BVHModel<fcl::OBBRSSd>> bvh_;
  fcl::Sphered point_{0.0};  // FCL's query point: a sphere of radius 0

  Vec3 origin_ = Vec3::Zero();  // the compact tree's coordinates are relative to this (the box centre)
  std::vector<Node> nodes_;
  std::vector<int> parent_;   // per node, -1 for the root
  std::vector<int> leaf_of_;  // per triangle, its leaf node
  bool packets_ = false;

};

// Whether this CPU runs the AVX2 packet search (x86-64 with AVX2 and FMA).
bool cpuHasPacketSearch();

}  // namespace kneesim_distance_fcl
