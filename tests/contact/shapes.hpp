#pragma once
// Closed analytic test meshes for the contact tests, built in memory (double precision).

#include <cmath>
#include <algorithm>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "io/stl.hpp"

namespace kneesim::test {

/// Axis-aligned box [lo, hi], outward-oriented, 12 triangles.
inline io::TriangleMesh makeBox(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  io::TriangleMesh m;
  m.source_file = "box";
  for (int i = 0; i < 8; ++i)
    m.vertices.emplace_back((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(), (i & 4) ? hi.z() : lo.z());
  const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (auto& t : f) m.triangles.emplace_back(t[0], t[1], t[2]);
  return m;
}

/// UV sphere of radius r around c with poles along y; nlat rings, nlon meridians. Vertices lie
/// exactly on the sphere; facets are inside it.
inline io::TriangleMesh makeSphere(const Eigen::Vector3d& c, double r, int nlat, int nlon) {
  io::TriangleMesh m;
  m.source_file = "sphere";
  m.vertices.push_back(c + Eigen::Vector3d(0, -r, 0));  // south pole
  for (int i = 1; i < nlat; ++i) {
    const double t = -M_PI / 2 + M_PI * i / nlat;
    for (int j = 0; j < nlon; ++j) {
      const double p = 2 * M_PI * j / nlon;
      m.vertices.push_back(c + r * Eigen::Vector3d(std::cos(t) * std::cos(p), std::sin(t), std::cos(t) * std::sin(p)));
    }
  }
  m.vertices.push_back(c + Eigen::Vector3d(0, r, 0));  // north pole
  const int north = int(m.vertices.size()) - 1;
  auto ring = [&](int i, int j) { return 1 + (i - 1) * nlon + (j % nlon); };
  for (int j = 0; j < nlon; ++j) m.triangles.emplace_back(0, ring(1, j), ring(1, j + 1));
  for (int i = 1; i < nlat - 1; ++i)
    for (int j = 0; j < nlon; ++j) {
      m.triangles.emplace_back(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1));
      m.triangles.emplace_back(ring(i, j), ring(i + 1, j + 1), ring(i, j + 1));
    }
  for (int j = 0; j < nlon; ++j) m.triangles.emplace_back(north, ring(nlat - 1, j + 1), ring(nlat - 1, j));
  return m;
}

/// Appends @p b's triangles to @p a (disjoint closed parts stay closed).
inline void appendMesh(io::TriangleMesh& a, const io::TriangleMesh& b) {
  const int off = a.getNumVertices();
  a.vertices.insert(a.vertices.end(), b.vertices.begin(), b.vertices.end());
  for (const auto& t : b.triangles) a.triangles.emplace_back(t + Eigen::Vector3i::Constant(off));
}

/// A closed block whose top is the height field y = top(x, z) on the rectilinear grid of nodes
/// @p xs by @p zs (increasing), vertical sides, and a flat bottom at y = bottom on the same grid.
inline io::TriangleMesh makeHeightField(const std::vector<double>& xs, const std::vector<double>& zs, double bottom,
                                        const std::function<double(double, double)>& top) {
  io::TriangleMesh m;
  m.source_file = "heightfield";
  const int nx = int(xs.size()) - 1, nz = int(zs.size()) - 1;
  auto T = [&](int i, int k) { return i * (nz + 1) + k; };
  for (int i = 0; i <= nx; ++i)
    for (int k = 0; k <= nz; ++k) m.vertices.emplace_back(xs[i], top(xs[i], zs[k]), zs[k]);
  const int nb = int(m.vertices.size());
  auto B = [&](int i, int k) { return nb + i * (nz + 1) + k; };
  for (int i = 0; i <= nx; ++i)
    for (int k = 0; k <= nz; ++k) m.vertices.emplace_back(xs[i], bottom, zs[k]);
  // Top faces up (+y), bottom down.
  for (int i = 0; i < nx; ++i)
    for (int k = 0; k < nz; ++k) {
      m.triangles.emplace_back(T(i, k), T(i, k + 1), T(i + 1, k + 1));
      m.triangles.emplace_back(T(i, k), T(i + 1, k + 1), T(i + 1, k));
      m.triangles.emplace_back(B(i, k), B(i + 1, k + 1), B(i, k + 1));
      m.triangles.emplace_back(B(i, k), B(i + 1, k), B(i + 1, k + 1));
    }
  // Sides.
  for (int i = 0; i < nx; ++i) {
    m.triangles.emplace_back(T(i, 0), T(i + 1, 0), B(i + 1, 0));  // z = z0 face, normal -z
    m.triangles.emplace_back(T(i, 0), B(i + 1, 0), B(i, 0));
    m.triangles.emplace_back(T(i, nz), B(i + 1, nz), T(i + 1, nz));  // z = z1 face, normal +z
    m.triangles.emplace_back(T(i, nz), B(i, nz), B(i + 1, nz));
  }
  for (int k = 0; k < nz; ++k) {
    m.triangles.emplace_back(T(0, k), B(0, k + 1), T(0, k + 1));  // x = x0 face, normal -x
    m.triangles.emplace_back(T(0, k), B(0, k), B(0, k + 1));
    m.triangles.emplace_back(T(nx, k), T(nx, k + 1), B(nx, k + 1));  // x = x1 face, normal +x
    m.triangles.emplace_back(T(nx, k), B(nx, k + 1), B(nx, k));
  }
  return m;
}

/// Grid nodes from @p a to @p b in steps of at most @p h (both ends included), appended to
/// @p nodes without repeating a shared end.
inline void appendNodes(std::vector<double>& nodes, double a, double b, double h) {
  const int n = std::max(1, int(std::ceil((b - a) / h - 1e-9)));
  for (int i = nodes.empty() || nodes.back() != a ? 0 : 1; i <= n; ++i) nodes.push_back(a + (b - a) * i / n);
}

}  // namespace kneesim::test
