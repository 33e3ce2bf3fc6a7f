#include "target.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

namespace kneesim_distance_fcl {

std::string Target::build(const kneesim_mesh_view& view, bool compact) {
  const int nv = view.n_vertices, nt = view.n_triangles;
  if (nv <= 0 || nt <= 0 || !view.vertices || !view.triangles)
    return "expected a target mesh with vertices and triangles, got " + std::to_string(std::max(nv, 0)) +
           " vertices and " + std::to_string(std::max(nt, 0)) + " triangles";
  vertices_.resize(size_t(nv));
  box_.setEmpty();
  for (int i = 0; i < nv; ++i) {
    vertices_[size_t(i)] = Vec3(view.vertices[3 * i], view.vertices[3 * i + 1], view.vertices[3 * i + 2]);
    if (!vertices_[size_t(i)].allFinite())
      return "expected finite target vertex coordinates, got a non-finite one at vertex " + std::to_string(i);
    box_.extend(vertices_[size_t(i)]);
  }
  triangles_.resize(size_t(nt));
  for (int t = 0; t < nt; ++t) {
    for (int k = 0; k < 3; ++k) {
      const int v = view.triangles[3 * t + k];
      if (v < 0 || v >= nv)
        return "expected target vertex indices in 0.." + std::to_string(nv - 1) + ", got " + std::to_string(v) +
               " in triangle " + std::to_string(t);
      triangles_[size_t(t)][k] = v;
    }
  }
  face_normal_.resize(size_t(nt));
  vertex_normal_.assign(size_t(nv), Vec3::Zero());
  tri_edges_.resize(size_t(nt));
  std::unordered_map<uint64_t, int> edge_index;
  edge_index.reserve(size_t(nt) * 2);
  std::vector<int> edge_balance;  // +1 per use as (i<j), -1 per use as (i>j): 0 on a closed, oriented mesh
  for (int t = 0; t < nt; ++t) {
    const Eigen::Vector3i& tri = triangles_[size_t(t)];
    const Vec3* v[3] = {&vertices_[size_t(tri[0])], &vertices_[size_t(tri[1])], &vertices_[size_t(tri[2])]};
    const Vec3 n = (*v[1] - *v[0]).cross(*v[2] - *v[0]);
    const double len = n.norm();
    face_normal_[size_t(t)] = len > 0 ? Vec3(n / len) : Vec3::Zero();
    for (int k = 0; k < 3; ++k) {
      const Vec3 e1 = *v[(k + 1) % 3] - *v[k], e2 = *v[(k + 2) % 3] - *v[k];
      const double l1 = e1.norm(), l2 = e2.norm();
      if (l1 == 0 || l2 == 0) continue;
      const double angle = std::acos(std::clamp(e1.dot(e2) / (l1 * l2), -1.0, 1.0));
      vertex_normal_[size_t(tri[k])] += angle * face_normal_[size_t(t)];
    }
    for (int k = 0; k < 3; ++k) {
      const uint32_t i = uint32_t(tri[k]), j = uint32_t(tri[(k + 1) % 3]);
      const uint64_t key = (uint64_t(std::min(i, j)) << 32) | std::max(i, j);
      auto [it, inserted] = edge_index.emplace(key, int(edge_normal_.size()));
      if (inserted) {
        edge_normal_.push_back(Vec3::Zero());
        edge_balance.push_back(0);
      }
      edge_normal_[size_t(it->second)] += face_normal_[size_t(t)];
      edge_balance[size_t(it->second)] += i < j ? 1 : -1;
      tri_edges_[size_t(t)][k] = it->second;
    }
  }
  const long open = std::count_if(edge_balance.begin(), edge_balance.end(), [](int b) { return b != 0; });
  if (open > 0)
    return "expected a closed, consistently oriented target mesh (signs need an inside), got " +
           std::to_string(open) + " open or flipped edges";
  for (Vec3& n : vertex_normal_)
    if (n.norm() > 0) n.normalize();
  for (Vec3& n : edge_normal_)
    if (n.norm() > 0) n.normalize();

  std::vector<fcl::Vector3d> fv(vertices_.begin(), vertices_.end());
  std::vector<fcl::Triangle> ft(static_cast<size_t>(nt));
  for (int t = 0; t < nt; ++t)
    ft[size_t(t)] = fcl::Triangle(size_t(triangles_[size_t(t)][0]), size_t(triangles_[size_t(t)][1]),
                                  size_t(triangles_[size_t(t)][2]));
  bvh_ = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
  // Median splits give a balanced tree (depth 17 for JW's 80,774 triangles, 21 with FCL's
  // default mean split), which the point traversal visits faster.
  if (compact) bvh_->bv_splitter.reset(new fcl::detail::BVSplitter<fcl::OBBRSSd>(fcl::detail::SPLIT_METHOD_MEDIAN));
  if (bvh_->beginModel(nt, nv) != fcl::BVH_OK || bvh_->addSubModel(fv, ft) != fcl::BVH_OK ||
      bvh_->endModel() != fcl::BVH_OK)
    return "FCL could not build its bounding-volume tree over the target mesh";
  if (compact) {
    buildCompactTree();
    packets_ = cpuHasPacketSearch();
  }
  return "";
}

void Target::setUsePackets(bool on) { packets_ = on && !nodes_.empty() && cpuHasPacketSearch(); }

void Target::buildCompactTree() {
  // Number FCL's nodes: the root 0, then each internal node's two children as the next free pair,
  // depth first (left subtree before right), so a subtree's pairs lie close together.
  const int n = bvh_->getNumBVs();
  std::vector<int> old_id(size_t(n), -1);
  std::vector<int> first_child(size_t(n), -1);  // by new id
  old_id[0] = 0;
  int next = 1;
  std::vector<int> stack = {0};  // new ids
  while (!stack.empty()) {
    const int k = stack.back();
    stack.pop_back();
    const auto& b = bvh_->getBV(old_id[size_t(k)]);
    if (b.isLeaf()) continue;
    first_child[size_t(k)] = next;
    old_id[size_t(next)] = b.leftChild();
    old_id[size_t(next + 1)] = b.rightChild();
    next += 2;
    stack.push_back(first_child[size_t(k)] + 1);
    stack.push_back(first_child[size_t(k)]);
  }
  // Float coordinates relative to the box centre. Rounding the RSS and the query point to float
  // moves the bound by about 1e-7 of the coordinates' magnitude; enlarging every radius by 1e-6
  // of the mesh's extent keeps each bound below the truth (for points within a few extents).
  origin_ = box_.center();
  const double extent = box_.sizes().maxCoeff();
  const double margin = 1e-6 * extent + 1e-12;
  nodes_.resize(size_t(n));
  parent_.assign(size_t(n), -1);
  leaf_of_.assign(triangles_.size(), -1);
  for (int k = 0; k < n; ++k) {
    const auto& b = bvh_->getBV(old_id[size_t(k)]);
    const fcl::RSSd& rss = b.bv.rss;
    Node& nd = nodes_[size_t(k)];
    const Vec3 corner = rss.To - origin_;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) nd.ax[3 * r + c] = float(rss.axis(c, r));
      nd.c[r] = float(rss.axis.col(r).dot(corner));
    }
    nd.l0 = float(rss.l[0]);
    nd.l1 = float(rss.l[1]);
    nd.r = float(rss.r + margin);
    if (b.isLeaf()) {
      nd.child = -(b.primitiveId() + 1);
      leaf_of_[size_t(b.primitiveId())] = k;
    } else {
      nd.child = first_child[size_t(k)];
      parent_[size_t(nd.child)] = k;
      parent_[size_t(nd.child + 1)] = k;
    }
  }
}

double Target::signedDistance(const Vec3& p, int t, Vec3& closest) const {
  const Eigen::Vector3i& tri = triangles_[size_t(t)];
  Feature f;
  closest = calcClosestOnTriangle(p, vertices_[size_t(tri[0])], vertices_[size_t(tri[1])], vertices_[size_t(tri[2])], f);
  const Vec3* n;
  switch (f) {
    case Feature::kVertexA: n = &vertex_normal_[size_t(tri[0])]; break;
    case Feature::kVertexB: n = &vertex_normal_[size_t(tri[1])]; break;
    case Feature::kVertexC: n = &vertex_normal_[size_t(tri[2])]; break;
    case Feature::kEdgeAB: n = &edge_normal_[size_t(tri_edges_[size_t(t)][0])]; break;
    case Feature::kEdgeBC: n = &edge_normal_[size_t(tri_edges_[size_t(t)][1])]; break;
    case Feature::kEdgeCA: n = &edge_normal_[size_t(tri_edges_[size_t(t)][2])]; break;
    default: n = &face_normal_[size_t(t)]; break;
  }
  const Vec3 r = p - closest;
  const double d = r.norm();
  return r.dot(*n) < 0 ? -d : d;
}

double Target::unsignedDistance(const Vec3& p, int t) const {
  const Eigen::Vector3i& tri = triangles_[size_t(t)];
  Feature f;
  return (p - calcClosestOnTriangle(p, vertices_[size_t(tri[0])], vertices_[size_t(tri[1])], vertices_[size_t(tri[2])], f))
      .norm();
}

int Target::findClosestFcl(const Vec3& p, double bound) const {
  static const fcl::Transform3d identity = fcl::Transform3d::Identity();
  fcl::Transform3d tf = identity;
  tf.translation() = p;
  fcl::DistanceRequestd request;
  fcl::DistanceResultd result(bound);
  fcl::distance(bvh_.get(), identity, &point_, tf, request, result);
  if (result.b1 == fcl::DistanceResultd::NONE || result.o1 == nullptr || !(result.min_distance < bound)) return -1;
  return int(result.b1);
}

namespace {

// Lower bound on the distance from p (relative to the tree's origin) to anything inside node nd.
inline float lowerBound(const Target::Node& nd, const Eigen::Vector3f& p) {
  const float q0 = nd.ax[0] * p[0] + nd.ax[1] * p[1] + nd.ax[2] * p[2] - nd.c[0];
  const float q1 = nd.ax[3] * p[0] + nd.ax[4] * p[1] + nd.ax[5] * p[2] - nd.c[1];
  const float q2 = nd.ax[6] * p[0] + nd.ax[7] * p[1] + nd.ax[8] * p[2] - nd.c[2];
  const float a = q0 < 0 ? q0 : (q0 > nd.l0 ? q0 - nd.l0 : 0.0f);
  const float b = q1 < 0 ? q1 : (q1 > nd.l1 ? q1 - nd.l1 : 0.0f);
  return std::sqrt(a * a + b * b + q2 * q2) - nd.r;
}

}  // namespace

void Target::searchSubtree(int root, const Vec3& p, const Eigen::Vector3f& pf, double& best, int& best_tri) const {
  int stack[128];
  int top = 0;
  stack[top++] = root;
  while (top > 0) {
    const int k = stack[--top];
    const Node& nd = nodes_[size_t(k)];
    if (nd.child < 0) {
      const int t = -nd.child - 1;
      const double d = unsignedDistance(p, t);
      if (d < best) {
        best = d;
        best_tri = t;
      }
      continue;
    }
    const int a = nd.child, b = nd.child + 1;
    const float da = lowerBound(nodes_[size_t(a)], pf), db = lowerBound(nodes_[size_t(b)], pf);
    kneesim::contact::pushNearerLast(stack, top, a, da, b, db, best);
  }
}

int Target::findClosestTree(const Vec3& p, double bound, int hint) const {
  const Eigen::Vector3f pf = (p - origin_).cast<float>();
  double best = bound;
  int best_tri = -1;
  if (hint >= 0) {
    const double u = unsignedDistance(p, hint);
    if (u < best) {
      best = u;
      best_tri = hint;
    }
    for (int node = leaf_of_[size_t(hint)]; parent_[size_t(node)] >= 0; node = parent_[size_t(node)]) {
      const int up = parent_[size_t(node)];
      const int sibling = node == nodes_[size_t(up)].child ? node + 1 : node - 1;
      if (lowerBound(nodes_[size_t(sibling)], pf) < best) searchSubtree(sibling, p, pf, best, best_tri);
    }
  } else if (lowerBound(nodes_[0], pf) < best) {
    searchSubtree(0, p, pf, best, best_tri);
  }
  return best_tri;
}

void Target::findClosestBatch(const Vec3* p, int n, const int* hints, double bound, int* out) const {
  if (!packets_) {
    for (int i = 0; i < n; ++i) out[i] = findClosestTree(p[i], bound, hints ? hints[i] : -1);
    return;
  }
  Packet pk;
  for (int i0 = 0; i0 < n; i0 += 8) {
    const int m = std::min(8, n - i0);
    for (int k = 0; k < 8; ++k) {
      const Vec3& q = p[i0 + std::min(k, m - 1)];
      pk.x[k] = q[0];
      pk.y[k] = q[1];
      pk.z[k] = q[2];
      pk.tri[k] = -1;
      pk.best2[k] = k < m ? bound * bound : -1.0;
      const int hint = k < m && hints ? hints[i0 + k] : -1;
      if (hint >= 0) {
        const double u = unsignedDistance(q, hint);
        if (u < bound) {
          pk.best2[k] = u * u;
          pk.tri[k] = hint;
        }
      }
    }
    searchPacket(pk);
    for (int k = 0; k < m; ++k) out[i0 + k] = pk.tri[k];
  }
}

}  // namespace kneesim_distance_fcl
