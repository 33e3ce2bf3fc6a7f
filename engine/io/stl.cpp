#include "io/stl.hpp"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <unordered_map>

#include <Eigen/Geometry>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/strings.hpp"

namespace kneesim::io {

namespace {

struct KeyHash {
  size_t operator()(const std::array<float, 3>& k) const {
    uint32_t h[3];
    std::memcpy(h, k.data(), sizeof h);
    return (size_t(h[0]) * 73856093u) ^ (size_t(h[1]) * 19349663u) ^ (size_t(h[2]) * 83492791u);
  }
};

class Welder {
 public:
  explicit Welder(TriangleMesh& m) : m_(m) {}
  int add(double x, double y, double z) {
    // Welding on the stored float values: binary STL stores floats, so equal vertices are
    // bit-identical; ASCII values are rounded to float first for the same reason.
    const std::array<float, 3> key{float(x), float(y), float(z)};
    auto [it, inserted] = index_.emplace(key, int(m_.vertices.size()));
    if (inserted) m_.vertices.emplace_back(x, y, z);
    return it->second;
  }

 private:
  TriangleMesh& m_;
  std::unordered_map<std::array<float, 3>, int, KeyHash> index_;
};

float readFloatLE(const unsigned char* p) {
  uint32_t u = uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}

void parseBinary(const std::string& path, const std::string& bytes, TriangleMesh& mesh) {
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  const uint32_t n = uint32_t(b[80]) | (uint32_t(b[81]) << 8) | (uint32_t(b[82]) << 16) | (uint32_t(b[83]) << 24);
  const size_t expected = 84 + size_t(n) * 50;
  if (bytes.size() < expected)
    throw InputError({path, 0, ""}, "truncated binary STL: header promises " + std::to_string(n) +
                                        " triangles (" + std::to_string(expected) + " bytes), file has " +
                                        std::to_string(bytes.size()) + " bytes");
  Welder weld(mesh);
  mesh.triangles.reserve(n);
  for (uint32_t t = 0; t < n; ++t) {
    const unsigned char* rec = b + 84 + size_t(t) * 50 + 12;  // skip the stored normal
    int idx[3];
    for (int v = 0; v < 3; ++v) {
      const float x = readFloatLE(rec + 12 * v), y = readFloatLE(rec + 12 * v + 4), z = readFloatLE(rec + 12 * v + 8);
      if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
        throw InputError({path, 0, "triangle " + std::to_string(t)}, "vertex is not a finite number");
      idx[v] = weld.add(x, y, z);
    }
    mesh.triangles.emplace_back(idx[0], idx[1], idx[2]);
  }
}

void parseAscii(const std::string& path, const std::string& text, TriangleMesh& mesh) {
  Welder weld(mesh);
  int line_no = 0;
  std::vector<int> pending;
  for (auto line : splitLines(text)) {
    ++line_no;
    auto w = splitWhitespace(line);
    if (w.empty() || w[0] != "vertex") {
      if (!w.empty() && w[0] == "endloop" && !pending.empty())
        throw InputError({path, line_no, ""}, "facet has " + std::to_string(pending.size()) + " vertices, expected 3");
      continue;
    }
    if (w.size() != 4) throw InputError({path, line_no, ""}, "expected 'vertex x y z'");
    const SourceLocation at{path, line_no, ""};
    const double x = parseDouble(w[1], at), y = parseDouble(w[2], at), z = parseDouble(w[3], at);
    // As in binary files: a NaN or infinite vertex would pass the size check (NaN compares false).
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      throw InputError(at, "expected a vertex of finite numbers, got '" + std::string(trim(line)) + "'");
    pending.push_back(weld.add(x, y, z));
    if (pending.size() == 3) {
      mesh.triangles.emplace_back(pending[0], pending[1], pending[2]);
      pending.clear();
    }
  }
  if (!pending.empty()) throw InputError({path, line_no, ""}, "file ends inside a facet (truncated)");
}

}  // namespace

TriangleMesh readStl(const std::string& path, const StlOptions& options) {
  const std::string bytes = readFileText(path);
  TriangleMesh mesh;
  mesh.source_file = path;
  if (bytes.empty()) throw InputError({path, 0, ""}, "empty STL file");
  // "solid" starts ASCII files, but some binary exporters write it into the header too: a file
  // whose size matches the binary layout is binary.
  bool binary = true;
  if (bytes.size() >= 84) {
    const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
    const uint32_t n = uint32_t(b[80]) | (uint32_t(b[81]) << 8) | (uint32_t(b[82]) << 16) | (uint32_t(b[83]) << 24);
    if (bytes.compare(0, 5, "solid") == 0 && 84 + size_t(n) * 50 != bytes.size()) binary = false;
  } else {
    binary = bytes.compare(0, 5, "solid") != 0;
    if (binary) throw InputError({path, 0, ""}, "truncated STL: " + std::to_string(bytes.size()) + " bytes, expected at least 84");
  }
  if (binary)
    parseBinary(path, bytes, mesh);
  else
    parseAscii(path, bytes, mesh);
  if (mesh.triangles.empty()) throw InputError({path, 0, ""}, "STL file has no triangles");
  if (options.scale != 1.0)
    for (auto& v : mesh.vertices) v *= options.scale;

  const auto [lo, hi] = mesh.calcBounds();
  const double extent = (hi - lo).maxCoeff();
  if (extent < options.min_extent || extent > options.max_extent) {
    std::string hint;
    if (extent > options.max_extent && extent / 1000 <= options.max_extent) hint = ": is the file in millimetres?";
    if (extent < options.min_extent && extent * 1000 >= options.min_extent) hint = ": is the file in metres while millimetres were expected?";
    char buf[256];
    std::snprintf(buf, sizeof buf, "implausible size: largest extent %.4g m, expected %.3g..%.3g m%s", extent,
                  options.min_extent, options.max_extent, hint.c_str());
    throw InputError({path, 0, ""}, buf);
  }
  if (options.require_closed) {
    const auto edges = mesh.calcEdgeReport();
    if (edges.open > 0)
      throw InputError({path, 0, ""}, "mesh is not closed: " + std::to_string(edges.open) +
                                          " edges are open or inconsistently oriented (expected a watertight surface)");
  }
  return mesh;
}

std::pair<Eigen::Vector3d, Eigen::Vector3d> TriangleMesh::calcBounds() const {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = Eigen::Vector3d::Constant(-1e300);
  for (const auto& v : vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  return {lo, hi};
}

std::vector<Eigen::Vector3d> TriangleMesh::calcTriangleNormals() const {
  std::vector<Eigen::Vector3d> n(triangles.size());
  for (size_t t = 0; t < triangles.size(); ++t) {
    const auto& tr = triangles[t];
    const Eigen::Vector3d c = (vertices[tr[1]] - vertices[tr[0]]).cross(vertices[tr[2]] - vertices[tr[0]]);
    const double len = c.norm();
    n[t] = len > 0 ? Eigen::Vector3d(c / len) : Eigen::Vector3d::Zero();
  }
  return n;
}

std::vector<double> TriangleMesh::calcTriangleAreas() const {
  std::vector<double> a(triangles.size());
  for (size_t t = 0; t < triangles.size(); ++t) {
    const auto& tr = triangles[t];
    a[t] = 0.5 * (vertices[tr[1]] - vertices[tr[0]]).cross(vertices[tr[2]] - vertices[tr[0]]).norm();
  }
  return a;
}

std::vector<Eigen::Vector3d> TriangleMesh::calcVertexNormals() const {
  std::vector<Eigen::Vector3d> n(vertices.size(), Eigen::Vector3d::Zero());
  for (const auto& tr : triangles) {
    const Eigen::Vector3d c = (vertices[tr[1]] - vertices[tr[0]]).cross(vertices[tr[2]] - vertices[tr[0]]);
    for (int k = 0; k < 3; ++k) n[tr[k]] += c;
  }
  for (auto& v : n)
    if (v.norm() > 0) v.normalize();
  return n;
}

std::vector<double> TriangleMesh::calcVertexAreas() const {
  std::vector<double> a(vertices.size(), 0.0);
  const auto ta = calcTriangleAreas();
  for (size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) a[triangles[t][k]] += ta[t] / 3.0;
  return a;
}

TriangleMesh::EdgeReport TriangleMesh::calcEdgeReport() const {
  // Per undirected edge: uses in direction low->high and high->low.
  std::unordered_map<uint64_t, std::pair<int, int>> count;
  count.reserve(triangles.size() * 2);
  for (const auto& tr : triangles)
    for (int k = 0; k < 3; ++k) {
      uint64_t a = uint32_t(tr[k]), b = uint32_t(tr[(k + 1) % 3]);
      if (a < b)
        ++count[(a << 32) | b].first;
      else
        ++count[(b << 32) | a].second;
    }
  EdgeReport r;
  for (const auto& [e, c] : count) {
    if (c.first != c.second)
      ++r.open;
    else if (c.first > 1)
      ++r.pinched;
  }
  return r;
}

double TriangleMesh::calcVolume() const {
  double v = 0;
  for (const auto& tr : triangles) v += vertices[tr[0]].dot(vertices[tr[1]].cross(vertices[tr[2]])) / 6.0;
  return v;
}

void writeStl(const std::string& path, const TriangleMesh& mesh) {
  writeFileAtomically(
      path,
      [&](std::ostream& os) {
        char header[80] = {0};
        std::snprintf(header, sizeof header, "kneesim binary STL");
        os.write(header, 80);
        const uint32_t n = uint32_t(mesh.triangles.size());
        os.write(reinterpret_cast<const char*>(&n), 4);  // little-endian hosts only (x86_64, arm64)
        const auto normals = mesh.calcTriangleNormals();
        for (size_t t = 0; t < mesh.triangles.size(); ++t) {
          float rec[12];
          for (int k = 0; k < 3; ++k) rec[k] = float(normals[t][k]);
          for (int v = 0; v < 3; ++v)
            for (int k = 0; k < 3; ++k) rec[3 + 3 * v + k] = float(mesh.vertices[mesh.triangles[t][v]][k]);
          os.write(reinterpret_cast<const char*>(rec), sizeof rec);
          const uint16_t attr = 0;
          os.write(reinterpret_cast<const char*>(&attr), 2);
        }
      },
      true);
}

}  // namespace kneesim::io
