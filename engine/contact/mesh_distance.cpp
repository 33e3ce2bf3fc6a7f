#include "contact/mesh_distance.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "contact/closest_point.hpp"
#include "core/error.hpp"

namespace kneesim::contact {

namespace {

using Eigen::Vector3d;

using Feature = TriangleFeature;

double boxDistanceSquared(const Eigen::AlignedBox3d& box, const Vector3d& p) {
  double s = 0;
  for (int k = 0; k < 3; ++k) {
    const double e = std::max({0.0, box.min()[k] - p[k], p[k] - box.max()[k]});
    s += e * e;
  }
  return s;
}

// Slab test: does the ray o + t d, t in [t0, t1], meet the box?
bool rayHitsBox(const Eigen::AlignedBox3d& box, const Vector3d& o, const Vector3d& inv_d, double t0, double t1) {
  for (int k = 0; k < 3; ++k) {
    double a = (box.min()[k] - o[k]) * inv_d[k];
    double b = (box.max()[k] - o[k]) * inv_d[k];
    if (a > b) std::swap(a, b);
    // NaN (0 * inf when the ray runs inside a slab face) must not reject the box.
    if (a > t0) t0 = a;
    if (b < t1) t1 = b;
    if (t0 > t1) return false;
  }
  return true;
}

// Moller-Trumbore, two-sided. Returns t or +inf.
double rayTriangle(const Vector3d& o, const Vector3d& d, const Vector3d& a, const Vector3d& b, const Vector3d& c) {
  const Vector3d e1 = b - a, e2 = c - a;
  const Vector3d h = d.cross(e2);
  const double det = e1.dot(h);
  const double scale = e1.norm() * e2.norm() * d.norm();
  if (std::abs(det) <= 1e-14 * scale) return std::numeric_limits<double>::infinity();
  const double inv = 1.0 / det;
  const Vector3d s = o - a;
  const double u = inv * s.dot(h);
  if (u < 0 || u > 1) return std::numeric_limits<double>::infinity();
  const Vector3d q = s.cross(e1);
  const double v = inv * d.dot(q);
  if (v < 0 || u + v > 1) return std::numeric_limits<double>::infinity();
  return inv * e2.dot(q);
}

constexpr int kLeafSize = 4;
constexpr int kStackSize = 128;

}  // namespace

MeshDistance::MeshDistance(const io::TriangleMesh& mesh) : mesh_(mesh) {
  const int nt = mesh_.getNumTriangles(), nv = mesh_.getNumVertices();
  if (nt == 0) throw InputError({mesh_.source_file, 0, ""}, "expected a triangle mesh, got no triangles");
  face_normal_.resize(nt);
  vertex_pseudonormal_.assign(nv, Vector3d::Zero());
  tri_edges_.resize(nt);
  std::unordered_map<uint64_t, int> edge_index;
  edge_index.reserve(size_t(nt) * 2);
  for (int t = 0; t < nt; ++t) {
    const Eigen::Vector3i& tri = mesh_.triangles[t];
    for (int k = 0; k < 3; ++k)
      if (tri[k] < 0 || tri[k] >= nv)
        throw InputError({mesh_.source_file, 0, "triangle " + std::to_string(t)},
                         "expected vertex indices below " + std::to_string(nv) + ", got " + std::to_string(tri[k]));
    const Vector3d& a = mesh_.vertices[tri[0]];
    const Vector3d& b = mesh_.vertices[tri[1]];
    const Vector3d& c = mesh_.vertices[tri[2]];
    const Vector3d n = (b - a).cross(c - a);
    const double len = n.norm();
    face_normal_[t] = len > 0 ? Vector3d(n / len) : Vector3d::Zero();
    // Angle-weighted vertex pseudonormals.
    const Vector3d* v[3] = {&a, &b, &c};
    for (int k = 0; k < 3; ++k) {
      const Vector3d e1 = *v[(k + 1) % 3] - *v[k], e2 = *v[(k + 2) % 3] - *v[k];
      const double l1 = e1.norm(), l2 = e2.norm();
      if (l1 == 0 || l2 == 0) continue;
      const double angle = std::acos(std::clamp(e1.dot(e2) / (l1 * l2), -1.0, 1.0));
      vertex_pseudonormal_[tri[k]] += angle * face_normal_[t];
    }
    for (int k = 0; k < 3; ++k) {
      const uint32_t i = uint32_t(tri[k]), j = uint32_t(tri[(k + 1) % 3]);
      const uint64_t key = (uint64_t(std::min(i, j)) << 32) | std::max(i, j);
      auto [it, inserted] = edge_index.emplace(key, int(edge_pseudonormal_.size()));
      if (inserted) edge_pseudonormal_.push_back(Vector3d::Zero());
      edge_pseudonormal_[it->second] += face_normal_[t];
      tri_edges_[t][k] = it->second;
    }
  }
  for (auto& n : vertex_pseudonormal_)
    if (n.norm() > 0) n.normalize();
  for (auto& n : edge_pseudonormal_)
    if (n.norm() > 0) n.normalize();

  order_.resize(nt);
  std::vector<Vector3d> centroids(nt);
  for (int t = 0; t < nt; ++t) {
    order_[t] = t;
    const Eigen::Vector3i& tri = mesh_.triangles[t];
    centroids[t] = (mesh_.vertices[tri[0]] + mesh_.vertices[tri[1]] + mesh_.vertices[tri[2]]) / 3.0;
  }
  nodes_.reserve(size_t(2 * nt / kLeafSize + 2));
  build(0, nt, centroids);
}

int MeshDistance::build(int begin, int end, std::vector<Vector3d>& centroids) {
  const int id = int(nodes_.size());
  nodes_.emplace_back();
  Eigen::AlignedBox3d box, cbox;
  for (int i = begin; i < end; ++i) {
    const Eigen::Vector3i& tri = mesh_.triangles[order_[i]];
    for (int k = 0; k < 3; ++k) box.extend(mesh_.vertices[tri[k]]);
    cbox.extend(centroids[order_[i]]);
  }
  nodes_[id].box = box;
  if (end - begin <= kLeafSize) {
    nodes_[id].first = begin;
    nodes_[id].count = end - begin;
    return id;
  }
  int axis;
  cbox.sizes().maxCoeff(&axis);
  const int mid = (begin + end) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](int a, int b) { return centroids[a][axis] < centroids[b][axis]; });
  const int left = build(begin, mid, centroids);
  const int right = build(mid, end, centroids);
  nodes_[id].first = left;
  nodes_[id].right = right;
  nodes_[id].count = 0;
  return id;
}

bool MeshDistance::calcSignedDistance(const Vector3d& p, double max_distance, MeshDistanceQuery& out) const {
  double best2 = std::isfinite(max_distance) ? max_distance * max_distance : std::numeric_limits<double>::infinity();
  int best_tri = -1;
  Feature best_feature = Feature::kFace;
  Vector3d best_point = Vector3d::Zero();
  int stack[kStackSize];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (boxDistanceSquared(node.box, p) >= best2) continue;
    if (node.count > 0) {
      for (int i = node.first; i < node.first + node.count; ++i) {
        const int t = order_[i];
        const Eigen::Vector3i& tri = mesh_.triangles[t];
        Feature f;
        const Vector3d c = calcClosestOnTriangle(p, mesh_.vertices[tri[0]], mesh_.vertices[tri[1]], mesh_.vertices[tri[2]], f);
        const double d2 = (p - c).squaredNorm();
        if (d2 < best2) {
          best2 = d2;
          best_tri = t;
          best_feature = f;
          best_point = c;
        }
      }
      continue;
    }
    const int l = node.first, r = node.right;
    const double dl = boxDistanceSquared(nodes_[l].box, p), dr = boxDistanceSquared(nodes_[r].box, p);
    KNEESIM_CHECK(top + 2 <= kStackSize, "mesh distance tree deeper than its traversal stack");
    pushNearerLast(stack, top, l, dl, r, dr, best2);
  }
  if (best_tri < 0) {
    out = MeshDistanceQuery{};
    return false;
  }
  const Eigen::Vector3i& tri = mesh_.triangles[best_tri];
  Vector3d n;
  switch (best_feature) {
    case Feature::kVertexA: n = vertex_pseudonormal_[tri[0]]; break;
    case Feature::kVertexB: n = vertex_pseudonormal_[tri[1]]; break;
    case Feature::kVertexC: n = vertex_pseudonormal_[tri[2]]; break;
    case Feature::kEdgeAB: n = edge_pseudonormal_[tri_edges_[best_tri][0]]; break;
    case Feature::kEdgeBC: n = edge_pseudonormal_[tri_edges_[best_tri][1]]; break;
    case Feature::kEdgeCA: n = edge_pseudonormal_[tri_edges_[best_tri][2]]; break;
    default: n = face_normal_[best_tri]; break;
  }
  const double d = std::sqrt(best2);
  out.distance = (p - best_point).dot(n) < 0 ? -d : d;
  out.closest = best_point;
  out.normal = n;
  out.triangle = best_tri;
  return true;
}

double MeshDistance::calcSignedDistance(const Vector3d& p) const {
  MeshDistanceQuery q;
  calcSignedDistance(p, std::numeric_limits<double>::infinity(), q);
  return q.distance;
}

double MeshDistance::calcRayHit(const Vector3d& o, const Vector3d& d, double t_min, double t_max) const {
  const Vector3d inv_d = d.cwiseInverse();
  double best = t_max;
  bool found = false;
  int stack[kStackSize];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (!rayHitsBox(node.box, o, inv_d, t_min, best)) continue;
    if (node.count > 0) {
      for (int i = node.first; i < node.first + node.count; ++i) {
        const Eigen::Vector3i& tri = mesh_.triangles[order_[i]];
        const double t = rayTriangle(o, d, mesh_.vertices[tri[0]], mesh_.vertices[tri[1]], mesh_.vertices[tri[2]]);
        if (t > t_min && t < best) {
          best = t;
          found = true;
        }
      }
      continue;
    }
    KNEESIM_CHECK(top + 2 <= kStackSize, "mesh distance tree deeper than its traversal stack");
    stack[top++] = node.right;
    stack[top++] = node.first;
  }
  return found ? best : std::numeric_limits<double>::infinity();
}

}  // namespace kneesim::contact
