#pragma once
// Closest point of a triangle to a point, and the nearer-child-first step of a tree search for it:
// header-only so the engine's MeshDistance and the distance_fcl plugin (built as its own shared
// library) inline the same routines in their hot loops.

#include <utility>

#include <Eigen/Core>

namespace kneesim::contact {

/// The Voronoi feature of a triangle abc that holds the closest point: a vertex, an edge or the
/// face. It picks the pseudonormal that signs a point's distance to a mesh.
enum class TriangleFeature { kVertexA, kVertexB, kVertexC, kEdgeAB, kEdgeBC, kEdgeCA, kFace };

/// Returns the point of triangle abc closest to p and sets `feature` to the Voronoi region it lies
/// in (Ericson, Real-Time Collision Detection, 5.1.5). Allocation-free.
inline Eigen::Vector3d calcClosestOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                             const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                             TriangleFeature& feature) {
  using Eigen::Vector3d;
  const Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) {
    feature = TriangleFeature::kVertexA;
    return a;
  }
  const Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) {
    feature = TriangleFeature::kVertexB;
    return b;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    feature = TriangleFeature::kEdgeAB;
    return a + (d1 / (d1 - d3)) * ab;
  }
  const Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) {
    feature = TriangleFeature::kVertexC;
    return c;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    feature = TriangleFeature::kEdgeCA;
    return a + (d2 / (d2 - d6)) * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    feature = TriangleFeature::kEdgeBC;
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  }
  const double denom = 1.0 / (va + vb + vc);
  feature = TriangleFeature::kFace;
  return a + ab * (vb * denom) + ac * (vc * denom);
}

/// One step of a depth-first search for the nearest triangle in a bounding-volume tree: pushes the
/// children @p a and @p b of a node, whose lower bounds on the distance are @p da and @p db, when
/// they can still beat @p best, the nearer one last so that it is visited first and the bound
/// tightens early (on a tie, @p a). The stack must have room for two more entries.
template <class Bound>
inline void pushNearerLast(int* stack, int& top, int a, Bound da, int b, Bound db, double best) {
  if (da > db) {
    std::swap(a, b);
    std::swap(da, db);
  }
  if (db < best) stack[top++] = b;
  if (da < best) stack[top++] = a;
}

}  // namespace kneesim::contact
