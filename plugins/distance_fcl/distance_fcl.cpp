// The "fcl" distance provider: signed distances from a fixed set of query points to a closed
// triangle mesh, over FCL 0.7's bounding-volume tree of the mesh.
//
// FCL's own point (radius-0 sphere) to mesh distance is unsigned, and on a knee implant it costs
// 10-15 us per point whether or not DistanceResult::min_distance is preset to a bound: it turns the
// point into an RSS and runs ~75 rectangle-to-rectangle RSS tests (~150 ns each) per query even
// when the bound is the exact answer (measured on JW's femoral component, 80,774 triangles). A map
// of a few thousand points a frame needs less, so this provider:
//
//  - Tree. FCL builds and fits its OBBRSS hierarchy over the mesh (median split). The provider
//    copies each node's RSS (rectangle swept sphere) into a compact single-precision array in
//    depth-first order and traverses it with a point-to-rectangle test (a few flops; the bound is
//    made conservative by a margin that covers the rounding to float).
//  - Sign. The closest point on the closest triangle and its Voronoi feature (vertex, edge or face)
//    are computed exactly in double precision, and the distance is signed by that feature's
//    angle-weighted pseudonormal (Baerentzen & Aanaes 2005): negative inside. Exact for a closed,
//    consistently oriented mesh, which create() checks.
//  - Pruning. A query searches only within a bound: the search band (max_distance plus a margin)
//    or, tighter, the distance to the point's closest triangle of the previous call, and walks the
//    tree bottom-up from that triangle's leaf, so most subtrees are rejected by one test.
//  - Culling. Query points are grouped into small spatial clusters. A cluster whose centre is
//    farther than max_distance + its radius + margin from the surface (one bounded query) is
//    skipped whole; its points are all on the side of the centre, since the ball around the centre
//    contains no surface.
//  - Temporal coherence. Each point keeps a lower bound on |distance| at the position where it was
//    last computed. The distance is 1-Lipschitz, so while the point has moved less than
//    (bound - max_distance) it is still beyond max_distance, on the same side: no query at all.
//  - Inside test. A point beyond the search radius whose side is not known from the above gets
//    one unbounded query: the pseudonormal of the true closest feature gives its side.
//
// Every distance within max_distance is exact (to rounding); coherence only saves work. A context
// holds the per-point state, so it is used by one thread at a time.
//
// Two more providers share this code for comparison (tools/benchmarks/contact_area_bench.cpp):
//  - "fcl_pruned": the same culling, coherence and sign, but every query is FCL's own
//    fcl::distance with DistanceResult preset to the bound;
//  - "fcl_naive": one unbounded fcl::distance per point, no culling, bound or coherence.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <numeric>
#include <string>
#include <unordered_map>
#include <vector>

#include <fcl/fcl.h>

#include "plugin/kneesim_plugin.h"

namespace {

using Vec3 = Eigen::Vector3d;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Largest number of points per culling cluster, and fewest pending points worth a cluster query.
constexpr int kClusterSize = 24;
constexpr int kMinClusterQuery = 6;
// The search band is max_distance plus this fraction of it (at least kMinMargin metres): wider
// bands let far points stay culled longer but make every point in the band cost a query.
constexpr double kMarginFraction = 0.25;
constexpr double kMinMargin = 0.5e-3;

enum Feature { kVertexA, kVertexB, kVertexC, kEdgeAB, kEdgeBC, kEdgeCA, kFace };

// Closest point of triangle abc to p and the Voronoi feature it lies on (Ericson, Real-Time
// Collision Detection, 5.1.5).
Vec3 closestOnTriangle(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, Feature& feature) {
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) {
    feature = kVertexA;
    return a;
  }
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) {
    feature = kVertexB;
    return b;
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    feature = kEdgeAB;
    return a + (d1 / (d1 - d3)) * ab;
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) {
    feature = kVertexC;
    return c;
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    feature = kEdgeCA;
    return a + (d2 / (d2 - d6)) * ac;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    feature = kEdgeBC;
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  }
  const double denom = 1.0 / (va + vb + vc);
  feature = kFace;
  return a + ab * (vb * denom) + ac * (vc * denom);
}

void writeError(char* err, int err_len, const std::string& msg) {
  if (!err || err_len <= 0) return;
  std::snprintf(err, size_t(err_len), "%s", msg.c_str());
}

// The target mesh with its FCL tree and pseudonormals.
struct Target {
  std::vector<Vec3> vertices;
  std::vector<Eigen::Vector3i> triangles;
  std::vector<Vec3> face_normal, vertex_normal, edge_normal;
  std::vector<Eigen::Vector3i> tri_edges;  // (v0v1, v1v2, v2v0) edge indices
  std::shared_ptr<fcl::BVHModel<fcl::OBBRSSd>> bvh;
  fcl::Sphered point{0.0};  // the query point: a sphere of radius 0

  // Returns an empty string or the reason the mesh is unusable.
  // The compact tree is built for the fast path only (median split); the FCL-query modes keep
  // FCL's default tree (mean split), which its generic distance traverses fastest.
  std::string build(const kneesim_mesh_view& view, bool compact) {
    const int nv = view.n_vertices, nt = view.n_triangles;
    if (nv <= 0 || nt <= 0 || !view.vertices || !view.triangles)
      return "expected a target mesh with vertices and triangles, got " + std::to_string(std::max(nv, 0)) +
             " vertices and " + std::to_string(std::max(nt, 0)) + " triangles";
    vertices.resize(size_t(nv));
    for (int i = 0; i < nv; ++i) {
      vertices[size_t(i)] = Vec3(view.vertices[3 * i], view.vertices[3 * i + 1], view.vertices[3 * i + 2]);
      if (!vertices[size_t(i)].allFinite())
        return "expected finite target vertex coordinates, got a non-finite one at vertex " + std::to_string(i);
    }
    triangles.resize(size_t(nt));
    for (int t = 0; t < nt; ++t) {
      for (int k = 0; k < 3; ++k) {
        const int v = view.triangles[3 * t + k];
        if (v < 0 || v >= nv)
          return "expected target vertex indices in 0.." + std::to_string(nv - 1) + ", got " + std::to_string(v) +
                 " in triangle " + std::to_string(t);
        triangles[size_t(t)][k] = v;
      }
    }
    face_normal.resize(size_t(nt));
    vertex_normal.assign(size_t(nv), Vec3::Zero());
    tri_edges.resize(size_t(nt));
    std::unordered_map<uint64_t, int> edge_index;
    edge_index.reserve(size_t(nt) * 2);
    std::vector<int> edge_balance;  // +1 per use as (i<j), -1 per use as (i>j): 0 on a closed, oriented mesh
    for (int t = 0; t < nt; ++t) {
      const Eigen::Vector3i& tri = triangles[size_t(t)];
      const Vec3* v[3] = {&vertices[size_t(tri[0])], &vertices[size_t(tri[1])], &vertices[size_t(tri[2])]};
      const Vec3 n = (*v[1] - *v[0]).cross(*v[2] - *v[0]);
      const double len = n.norm();
      face_normal[size_t(t)] = len > 0 ? Vec3(n / len) : Vec3::Zero();
      for (int k = 0; k < 3; ++k) {
        const Vec3 e1 = *v[(k + 1) % 3] - *v[k], e2 = *v[(k + 2) % 3] - *v[k];
        const double l1 = e1.norm(), l2 = e2.norm();
        if (l1 == 0 || l2 == 0) continue;
        const double angle = std::acos(std::clamp(e1.dot(e2) / (l1 * l2), -1.0, 1.0));
        vertex_normal[size_t(tri[k])] += angle * face_normal[size_t(t)];
      }
      for (int k = 0; k < 3; ++k) {
        const uint32_t i = uint32_t(tri[k]), j = uint32_t(tri[(k + 1) % 3]);
        const uint64_t key = (uint64_t(std::min(i, j)) << 32) | std::max(i, j);
        auto [it, inserted] = edge_index.emplace(key, int(edge_normal.size()));
        if (inserted) {
          edge_normal.push_back(Vec3::Zero());
          edge_balance.push_back(0);
        }
        edge_normal[size_t(it->second)] += face_normal[size_t(t)];
        edge_balance[size_t(it->second)] += i < j ? 1 : -1;
        tri_edges[size_t(t)][k] = it->second;
      }
    }
    const long open = std::count_if(edge_balance.begin(), edge_balance.end(), [](int b) { return b != 0; });
    if (open > 0)
      return "expected a closed, consistently oriented target mesh (signs need an inside), got " +
             std::to_string(open) + " open or flipped edges";
    for (Vec3& n : vertex_normal)
      if (n.norm() > 0) n.normalize();
    for (Vec3& n : edge_normal)
      if (n.norm() > 0) n.normalize();

    std::vector<fcl::Vector3d> fv(vertices.begin(), vertices.end());
    std::vector<fcl::Triangle> ft(static_cast<size_t>(nt));
    for (int t = 0; t < nt; ++t)
      ft[size_t(t)] = fcl::Triangle(size_t(triangles[size_t(t)][0]), size_t(triangles[size_t(t)][1]),
                                    size_t(triangles[size_t(t)][2]));
    bvh = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
    // Median splits give a balanced tree (depth 17 for JW's 80,774 triangles, 21 with FCL's
    // default mean split), which the point traversal visits faster.
    if (compact) bvh->bv_splitter.reset(new fcl::detail::BVSplitter<fcl::OBBRSSd>(fcl::detail::SPLIT_METHOD_MEDIAN));
    if (bvh->beginModel(nt, nv) != fcl::BVH_OK || bvh->addSubModel(fv, ft) != fcl::BVH_OK ||
        bvh->endModel() != fcl::BVH_OK)
      return "FCL could not build its bounding-volume tree over the target mesh";
    if (compact) buildCompactTree();
    return "";
  }

  // Signed distance from p to triangle t, with the closest point.
  double signedDistance(const Vec3& p, int t, Vec3& closest) const {
    const Eigen::Vector3i& tri = triangles[size_t(t)];
    Feature f;
    closest = closestOnTriangle(p, vertices[size_t(tri[0])], vertices[size_t(tri[1])], vertices[size_t(tri[2])], f);
    const Vec3* n;
    switch (f) {
      case kVertexA: n = &vertex_normal[size_t(tri[0])]; break;
      case kVertexB: n = &vertex_normal[size_t(tri[1])]; break;
      case kVertexC: n = &vertex_normal[size_t(tri[2])]; break;
      case kEdgeAB: n = &edge_normal[size_t(tri_edges[size_t(t)][0])]; break;
      case kEdgeBC: n = &edge_normal[size_t(tri_edges[size_t(t)][1])]; break;
      case kEdgeCA: n = &edge_normal[size_t(tri_edges[size_t(t)][2])]; break;
      default: n = &face_normal[size_t(t)]; break;
    }
    const Vec3 r = p - closest;
    const double d = r.norm();
    return r.dot(*n) < 0 ? -d : d;
  }

  // Unsigned distance from p to triangle t.
  double unsignedDistance(const Vec3& p, int t) const {
    const Eigen::Vector3i& tri = triangles[size_t(t)];
    Feature f;
    return (p - closestOnTriangle(p, vertices[size_t(tri[0])], vertices[size_t(tri[1])],
                                  vertices[size_t(tri[2])], f))
        .norm();
  }

  // The triangle FCL's generic distance finds closest to p among those nearer than bound
  // (DistanceResult preset: FCL prunes everything farther), or -1 when there is none.
  int findClosestFcl(const Vec3& p, double bound) const {
    static const fcl::Transform3d identity = fcl::Transform3d::Identity();
    fcl::Transform3d tf = identity;
    tf.translation() = p;
    fcl::DistanceRequestd request;
    fcl::DistanceResultd result(bound);
    fcl::distance(bvh.get(), identity, &point, tf, request, result);
    if (result.b1 == fcl::DistanceResultd::NONE || result.o1 == nullptr || !(result.min_distance < bound)) return -1;
    return int(result.b1);
  }

  // FCL's tree as compact nodes: the RSS of each node in float, depth-first order.
  struct Node {
    float To[3];   // rectangle corner
    float ax[9];   // rows: the rectangle's two edge directions and its normal
    float l0, l1;  // edge lengths
    float r;       // sphere radius, enlarged by the float-rounding margin
    int left;      // first child, -1 for a leaf
    int other;     // second child, or the triangle of a leaf
  };
  std::vector<Node> nodes;
  std::vector<int> parent;   // per node, -1 for the root
  std::vector<int> leaf_of;  // per triangle, its leaf node

  void buildCompactTree() {
    const int n = bvh->getNumBVs();
    std::vector<int> new_id(size_t(n), -1), old_id;
    old_id.reserve(size_t(n));
    std::vector<int> stack = {0};
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      new_id[size_t(i)] = int(old_id.size());
      old_id.push_back(i);
      const auto& b = bvh->getBV(i);
      if (!b.isLeaf()) {
        stack.push_back(b.rightChild());
        stack.push_back(b.leftChild());
      }
    }
    // Rounding the RSS to float moves its surface by about 1e-7 of the coordinates' magnitude;
    // enlarging every radius by 1e-6 of the mesh's extent keeps each bound below the truth.
    Eigen::AlignedBox3d box;
    for (const Vec3& v : vertices) box.extend(v);
    const double margin = 1e-6 * (box.max().cwiseAbs().maxCoeff() + box.sizes().maxCoeff()) + 1e-12;
    nodes.resize(size_t(n));
    parent.assign(size_t(n), -1);
    leaf_of.assign(triangles.size(), -1);
    for (int k = 0; k < n; ++k) {
      const auto& b = bvh->getBV(old_id[size_t(k)]);
      const fcl::RSSd& rss = b.bv.rss;
      Node& nd = nodes[size_t(k)];
      for (int j = 0; j < 3; ++j) nd.To[j] = float(rss.To[j]);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) nd.ax[3 * r + c] = float(rss.axis(c, r));
      nd.l0 = float(rss.l[0]);
      nd.l1 = float(rss.l[1]);
      nd.r = float(rss.r + margin);
      if (b.isLeaf()) {
        nd.left = -1;
        nd.other = b.primitiveId();
        leaf_of[size_t(nd.other)] = k;
      } else {
        nd.left = new_id[size_t(b.leftChild())];
        nd.other = new_id[size_t(b.rightChild())];
      }
    }
    for (int k = 0; k < n; ++k)
      if (nodes[size_t(k)].left >= 0) {
        parent[size_t(nodes[size_t(k)].left)] = k;
        parent[size_t(nodes[size_t(k)].other)] = k;
      }
  }

  // Lower bound on the distance from p to anything inside node nd.
  static float lowerBound(const Node& nd, const Eigen::Vector3f& p) {
    const float x0 = p[0] - nd.To[0], x1 = p[1] - nd.To[1], x2 = p[2] - nd.To[2];
    const float q0 = nd.ax[0] * x0 + nd.ax[1] * x1 + nd.ax[2] * x2;
    const float q1 = nd.ax[3] * x0 + nd.ax[4] * x1 + nd.ax[5] * x2;
    const float q2 = nd.ax[6] * x0 + nd.ax[7] * x1 + nd.ax[8] * x2;
    const float a = q0 < 0 ? q0 : (q0 > nd.l0 ? q0 - nd.l0 : 0.0f);
    const float b = q1 < 0 ? q1 : (q1 > nd.l1 ? q1 - nd.l1 : 0.0f);
    return std::sqrt(a * a + b * b + q2 * q2) - nd.r;
  }

  // Closest triangle to p in the subtree of `root` if nearer than best; updates best/best_tri.
  void searchSubtree(int root, const Vec3& p, const Eigen::Vector3f& pf, double& best, int& best_tri) const {
    int stack[128];
    int top = 0;
    stack[top++] = root;
    while (top > 0) {
      const Node& nd = nodes[size_t(stack[--top])];
      if (nd.left < 0) {
        const double d = unsignedDistance(p, nd.other);
        if (d < best) {
          best = d;
          best_tri = nd.other;
        }
        continue;
      }
      const float da = lowerBound(nodes[size_t(nd.left)], pf), db = lowerBound(nodes[size_t(nd.other)], pf);
      // Visit the nearer child first (pushed last) so the bound tightens early.
      if (da <= db) {
        if (db < best) stack[top++] = nd.other;
        if (da < best) stack[top++] = nd.left;
      } else {
        if (da < best) stack[top++] = nd.left;
        if (db < best) stack[top++] = nd.other;
      }
    }
  }

  // The triangle closest to p among those nearer than bound, or -1. With a hint (any triangle),
  // the search starts at the hint's leaf and walks up, testing each ancestor's other child: near
  // the previous answer the bound is tight from the start.
  int findClosestTree(const Vec3& p, double bound, int hint) const {
    const Eigen::Vector3f pf = p.cast<float>();
    double best = bound;
    int best_tri = -1;
    if (hint >= 0) {
      const double u = unsignedDistance(p, hint);
      if (u < best) {
        best = u;
        best_tri = hint;
      }
      for (int node = leaf_of[size_t(hint)]; parent[size_t(node)] >= 0; node = parent[size_t(node)]) {
        const Node& up = nodes[size_t(parent[size_t(node)])];
        const int sibling = up.left == node ? up.other : up.left;
        if (lowerBound(nodes[size_t(sibling)], pf) < best) searchSubtree(sibling, p, pf, best, best_tri);
      }
    } else if (lowerBound(nodes[0], pf) < best) {
      searchSubtree(0, p, pf, best, best_tri);
    }
    return best_tri;
  }

  // The closest triangle to p nearer than bound, or -1, by the chosen engine; hint may be -1.
  int findClosest(const Vec3& p, double bound, int hint, bool use_fcl_query) const {
    if (!use_fcl_query) return findClosestTree(p, bound, hint);
    if (hint >= 0) {
      const double u = unsignedDistance(p, hint);
      if (u < bound) {
        // FCL keeps a triangle only if strictly closer than the preset bound: allow for rounding.
        const int t = findClosestFcl(p, u * (1 + 1e-9) + 1e-15);
        return t >= 0 ? t : hint;
      }
    }
    return findClosestFcl(p, bound);
  }
};

// Per-point memory across calls (temporal coherence).
struct PointState {
  Vec3 p_ref = Vec3::Zero();  // position (T) where `lower` was established
  double lower = 0;           // |distance| at p_ref is at least this
  int triangle = -1;          // closest triangle when last computed (a hint, any triangle is valid)
  signed char side = 0;       // +1 outside, -1 inside, 0 unknown
};

struct Cluster {
  int begin = 0, end = 0;  // range in Context::order
  Vec3 centre_Q = Vec3::Zero();
};

// How a context computes: the fast path over the compact tree, the same with FCL's own queries,
// or one unbounded FCL query per point.
enum class Mode { fast, fcl_pruned, fcl_naive };

struct Context {
  Target target;
  Mode mode = Mode::fast;
  std::vector<Vec3> points_Q;  // as given
  std::vector<int> order;      // point indices grouped by cluster
  std::vector<Cluster> clusters;
  std::vector<PointState> state;
  std::vector<Vec3> p_T;       // buffer: points in T this call
  std::vector<int> pending;    // buffer: points of the current cluster still to be computed
  // Counters for diagnostics (kneesim_distance_fcl_get_stats).
  long long calls = 0, points = 0, coherent_skips = 0, cluster_queries = 0, cluster_culled = 0, point_queries = 0,
            unbounded_queries = 0;
};

// Splits order[begin, end) into clusters of at most kClusterSize points (median split on the
// longest axis of the points' bounding box).
void buildClusters(Context& c, int begin, int end) {
  if (end - begin <= kClusterSize) {
    Cluster k;
    k.begin = begin;
    k.end = end;
    for (int i = begin; i < end; ++i) k.centre_Q += c.points_Q[size_t(c.order[size_t(i)])];
    k.centre_Q /= double(end - begin);
    c.clusters.push_back(k);
    return;
  }
  Eigen::AlignedBox3d box;
  for (int i = begin; i < end; ++i) box.extend(c.points_Q[size_t(c.order[size_t(i)])]);
  int axis;
  box.sizes().maxCoeff(&axis);
  const int mid = (begin + end) / 2;
  std::nth_element(c.order.begin() + begin, c.order.begin() + mid, c.order.begin() + end,
                   [&](int a, int b) { return c.points_Q[size_t(a)][axis] < c.points_Q[size_t(b)][axis]; });
  buildClusters(c, begin, mid);
  buildClusters(c, mid, end);
}

void* createImpl(const kneesim_mesh_view* target, int n_points, const double* points_Q, char* err, int err_len,
                 Mode mode) {
  try {
    if (!target) {
      writeError(err, err_len, "expected a target mesh, got none");
      return nullptr;
    }
    if (n_points < 0 || (n_points > 0 && !points_Q)) {
      writeError(err, err_len, "expected query points, got " + std::to_string(n_points));
      return nullptr;
    }
    auto c = std::make_unique<Context>();
    c->mode = mode;
    const std::string problem = c->target.build(*target, mode == Mode::fast);
    if (!problem.empty()) {
      writeError(err, err_len, problem);
      return nullptr;
    }
    c->points_Q.resize(size_t(n_points));
    for (int i = 0; i < n_points; ++i) {
      c->points_Q[size_t(i)] = Vec3(points_Q[3 * i], points_Q[3 * i + 1], points_Q[3 * i + 2]);
      if (!c->points_Q[size_t(i)].allFinite()) {
        writeError(err, err_len, "expected finite query points, got a non-finite one at point " + std::to_string(i));
        return nullptr;
      }
    }
    c->order.resize(size_t(n_points));
    std::iota(c->order.begin(), c->order.end(), 0);
    if (n_points > 0) buildClusters(*c, 0, n_points);
    c->state.resize(size_t(n_points));
    c->p_T.resize(size_t(n_points));
    c->pending.reserve(size_t(kClusterSize));
    return c.release();
  } catch (const std::bad_alloc&) {
    writeError(err, err_len, "out of memory preparing the distance queries");
  } catch (const std::exception& e) {
    writeError(err, err_len, std::string("FCL failed preparing the distance queries: ") + e.what());
  }
  return nullptr;
}

void* createFast(const kneesim_mesh_view* target, int n_points, const double* points_Q, char* err, int err_len) {
  return createImpl(target, n_points, points_Q, err, err_len, Mode::fast);
}
void* createPruned(const kneesim_mesh_view* target, int n_points, const double* points_Q, char* err, int err_len) {
  return createImpl(target, n_points, points_Q, err, err_len, Mode::fcl_pruned);
}
void* createNaive(const kneesim_mesh_view* target, int n_points, const double* points_Q, char* err, int err_len) {
  return createImpl(target, n_points, points_Q, err, err_len, Mode::fcl_naive);
}

// Records a computed distance d (closest point q on triangle t) for point i.
inline void store(Context& c, int i, const Vec3& p, double d, int t, const Vec3& q, double max_distance,
                  double* distance, double* closest_T) {
  distance[i] = d;
  if (closest_T) {
    const bool near = std::abs(d) <= max_distance;
    for (int k = 0; k < 3; ++k) closest_T[3 * i + k] = near ? q[k] : kNaN;
  }
  PointState& s = c.state[size_t(i)];
  s.p_ref = p;
  s.lower = std::abs(d);
  s.triangle = t;
  s.side = d < 0 ? -1 : 1;
}

// Records a point known to be farther than `lower` from the surface, on side `side`.
inline void storeFar(Context& c, int i, const Vec3& p, double lower, signed char side, double* distance,
                     double* closest_T) {
  distance[i] = side < 0 ? -kInf : kInf;
  if (closest_T)
    for (int k = 0; k < 3; ++k) closest_T[3 * i + k] = kNaN;
  PointState& s = c.state[size_t(i)];
  s.p_ref = p;
  s.lower = lower;
  s.side = side;
}

// Exact signed distance of p by an unbounded query (the inside test of last resort).
double unboundedDistance(Context& c, const Vec3& p, int& t, Vec3& q) {
  ++c.unbounded_queries;
  t = c.target.findClosest(p, kInf, -1, c.mode != Mode::fast);
  if (t < 0) return kInf;  // cannot happen for a non-empty mesh
  return c.target.signedDistance(p, t, q);
}

int computeNaive(Context& c, const Eigen::Matrix3d& R, const Vec3& t, double max_distance, double* distance,
                 double* closest_T) {
  const int n = int(c.points_Q.size());
  for (int i = 0; i < n; ++i) {
    const Vec3 p = R * c.points_Q[size_t(i)] + t;
    int tri;
    Vec3 q;
    const double d = unboundedDistance(c, p, tri, q);
    distance[i] = d;
    if (closest_T) {
      const bool near = std::abs(d) <= max_distance;
      for (int k = 0; k < 3; ++k) closest_T[3 * i + k] = near ? q[k] : kNaN;
    }
  }
  return 0;
}

int computeFast(Context& c, const Eigen::Matrix3d& R, const Vec3& t, double max_distance, double* distance,
                double* closest_T) {
  // The margin widens the band a query searches so that a point or cluster found beyond it stays
  // provably far for the next few frames of a slow motion without any query.
  const double margin = std::isfinite(max_distance) ? std::max(kMarginFraction * max_distance, kMinMargin) : 0.0;
  const double search = max_distance + margin;
  for (const Cluster& k : c.clusters) {
    c.pending.clear();
    for (int j = k.begin; j < k.end; ++j) {
      const int i = c.order[size_t(j)];
      const Vec3 p = R * c.points_Q[size_t(i)] + t;
      c.p_T[size_t(i)] = p;
      const PointState& s = c.state[size_t(i)];
      if (s.side != 0 && s.lower - (p - s.p_ref).norm() > max_distance) {
        // Still beyond max_distance, on the same side (the distance is 1-Lipschitz).
        ++c.coherent_skips;
        distance[i] = s.side < 0 ? -kInf : kInf;
        if (closest_T)
          for (int m = 0; m < 3; ++m) closest_T[3 * i + m] = kNaN;
        continue;
      }
      c.pending.push_back(i);
    }
    if (c.pending.empty()) continue;

    // Cluster test: one query at the centre bounds every pending point's distance from below.
    const Vec3 centre = R * k.centre_Q + t;
    double centre_lower = 0;  // |distance| of the centre is at least this
    signed char centre_side = 0;
    // Worth it only when no pending point was near last time (a cold start, or a cluster that
    // has just come back into reach): in contact, a cluster query would be wasted.
    bool maybe_far = int(c.pending.size()) >= kMinClusterQuery && std::isfinite(max_distance);
    for (size_t j = 0; maybe_far && j < c.pending.size(); ++j) {
      const PointState& s = c.state[size_t(c.pending[j])];
      if (s.side != 0 && s.lower <= search) maybe_far = false;
    }
    if (maybe_far) {
      double reach = 0;
      for (int i : c.pending) reach = std::max(reach, (c.p_T[size_t(i)] - centre).norm());
      const double bound = search + reach;
      ++c.cluster_queries;
      const int tri = c.target.findClosest(centre, bound, -1, c.mode != Mode::fast);
      Vec3 q;
      if (tri >= 0) {
        const double dc = c.target.signedDistance(centre, tri, q);
        centre_lower = std::abs(dc);
        centre_side = dc < 0 ? -1 : 1;
      } else {
        centre_lower = bound;
      }
      if (centre_lower - reach > max_distance) {
        // No surface within centre_lower of the centre: every pending point is far and on the
        // centre's side. Find the side from a point that kept its own, else by an inside test.
        if (centre_side == 0)
          for (int i : c.pending) {
            const PointState& s = c.state[size_t(i)];
            if (s.side != 0 && (c.p_T[size_t(i)] - s.p_ref).norm() < s.lower) {
              centre_side = s.side;
              break;
            }
          }
        if (centre_side == 0) {
          int t2;
          const double dc = unboundedDistance(c, centre, t2, q);
          centre_side = dc < 0 ? -1 : 1;
        }
        ++c.cluster_culled;
        for (int i : c.pending) {
          const Vec3& p = c.p_T[size_t(i)];
          storeFar(c, i, p, centre_lower - (p - centre).norm(), centre_side, distance, closest_T);
        }
        continue;
      }
    }

    // Point queries, pruned by the previous closest triangle or the search band.
    for (int i : c.pending) {
      const Vec3& p = c.p_T[size_t(i)];
      PointState& s = c.state[size_t(i)];
      ++c.point_queries;
      int tri = c.target.findClosest(p, search, s.triangle, c.mode != Mode::fast);
      Vec3 q;
      if (tri >= 0) {
        const double d = c.target.signedDistance(p, tri, q);
        store(c, i, p, d, tri, q, max_distance, distance, closest_T);
        continue;
      }
      // Beyond the search band: which side?
      signed char side = 0;
      if (s.side != 0 && (p - s.p_ref).norm() < s.lower) side = s.side;
      if (side == 0 && centre_side != 0 && (p - centre).norm() < centre_lower) side = centre_side;
      if (side == 0) {
        const double d = unboundedDistance(c, p, tri, q);
        store(c, i, p, d, tri, q, max_distance, distance, closest_T);
        continue;
      }
      storeFar(c, i, p, search, side, distance, closest_T);
    }
  }
  return 0;
}

int compute(void* ctx, const double* X_TQ, double max_distance, double* distance, double* closest_T, char* err,
            int err_len) {
  if (!ctx || !X_TQ || (!distance && ctx && !static_cast<Context*>(ctx)->points_Q.empty())) {
    writeError(err, err_len, "expected a context, a pose and an output array, got a null pointer");
    return 1;
  }
  if (!(max_distance > 0)) {  // also rejects NaN
    writeError(err, err_len, "expected a positive max_distance, got " + std::to_string(max_distance));
    return 1;
  }
  Eigen::Matrix3d R;
  Vec3 t;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) R(r, k) = X_TQ[4 * r + k];
    t[r] = X_TQ[4 * r + 3];
  }
  if (!R.allFinite() || !t.allFinite()) {
    writeError(err, err_len, "expected a finite pose X_TQ, got a non-finite entry");
    return 1;
  }
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 || R.determinant() < 0) {
    writeError(err, err_len, "expected a rotation in X_TQ, got a matrix that is not orthonormal");
    return 1;
  }
  Context& c = *static_cast<Context*>(ctx);
  ++c.calls;
  c.points += long(c.points_Q.size());
  try {
    return c.mode == Mode::fcl_naive ? computeNaive(c, R, t, max_distance, distance, closest_T)
                                     : computeFast(c, R, t, max_distance, distance, closest_T);
  } catch (const std::exception& e) {
    writeError(err, err_len, std::string("FCL distance query failed: ") + e.what());
    return 1;
  }
}

void destroy(void* ctx) { delete static_cast<Context*>(ctx); }

const kneesim_distance_provider kFcl = {
    int(sizeof(kneesim_distance_provider)),
    "fcl",
    "signed point-to-mesh distance over FCL 0.7's OBBRSS tree with point-specialised traversal; pruned, "
    "culled and coherent across calls; sign from the closest feature's pseudonormal",
    createFast,
    compute,
    destroy};

const kneesim_distance_provider kFclPruned = {
    int(sizeof(kneesim_distance_provider)),
    "fcl_pruned",
    "as fcl, but every query is FCL's own fcl::distance with DistanceResult preset to the bound",
    createPruned,
    compute,
    destroy};

const kneesim_distance_provider kFclNaive = {
    int(sizeof(kneesim_distance_provider)),
    "fcl_naive",
    "one unbounded FCL query per point (no pruning, culling or coherence): the benchmark's reference",
    createNaive,
    compute,
    destroy};

}  // namespace

extern "C" {

/// Diagnostic counters of a context created by this plugin (not part of the plugin ABI; the
/// benchmark finds it with dlsym): calls, points, coherent skips, cluster queries, clusters
/// culled, point queries, unbounded queries. Writes at most n values; returns how many it has.
KNEESIM_PLUGIN_EXPORT int kneesim_distance_fcl_get_stats(void* ctx, long long* out, int n) {
  const Context& c = *static_cast<const Context*>(ctx);
  const long long v[] = {c.calls,          c.points,        c.coherent_skips,   c.cluster_queries,
                         c.cluster_culled, c.point_queries, c.unbounded_queries};
  const int m = int(sizeof(v) / sizeof(v[0]));
  for (int i = 0; i < std::min(n, m); ++i) out[i] = v[i];
  return m;
}

KNEESIM_PLUGIN_EXPORT int kneesim_plugin_register(const kneesim_registrar* r) {
  if (!r || r->abi_version != KNEESIM_PLUGIN_ABI_VERSION) return 1;
  if (r->add_distance_provider(r->host, &kFcl) != 0) return 1;
  if (r->add_distance_provider(r->host, &kFclPruned) != 0) return 1;
  if (r->add_distance_provider(r->host, &kFclNaive) != 0) return 1;
  return 0;
}

}  // extern "C"
