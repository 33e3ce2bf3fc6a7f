#include "contact/contact_output.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/atomic_file.hpp"
#include "core/error.hpp"

namespace kneesim::contact {

namespace {

std::string formatNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string formatList(const std::vector<double>& v, double scale) {
  std::string s;
  for (double x : v) s += (s.empty() ? "" : " ") + formatNumber(x * scale);
  return s;
}

// Unit of a contact channel by its name.
const char* unitOf(const std::string& name) {
  if (name == "time") return "s";
  if (name.rfind("dS", 0) == 0) return "m^2/s";
  if (name.rfind("S", 0) == 0) return "m^2";
  return "m";  // dmin*, c*_medial, c*_lateral
}

void appendDataArray(std::string& out, const char* type, const char* name, int components) {
  out += "        <DataArray type=\"";
  out += type;
  out += "\"";
  if (name) out += std::string(" Name=\"") + name + "\"";
  if (components > 1) out += " NumberOfComponents=\"" + std::to_string(components) + "\"";
  out += " format=\"ascii\">\n";
}

// The Points and Polys sections of a triangle mesh whose points are X * vertices.
void appendGeometry(std::string& out, const io::TriangleMesh& mesh, const Eigen::Isometry3d& X) {
  char buf[96];
  out += "      <Points>\n";
  appendDataArray(out, "Float64", "Points", 3);
  for (const Eigen::Vector3d& v : mesh.vertices) {
    const Eigen::Vector3d p = X * v;
    const int n = std::snprintf(buf, sizeof buf, "          %.10g %.10g %.10g\n", p.x(), p.y(), p.z());
    out.append(buf, size_t(n));
  }
  out += "        </DataArray>\n      </Points>\n      <Polys>\n";
  appendDataArray(out, "Int32", "connectivity", 1);
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const int n = std::snprintf(buf, sizeof buf, "          %d %d %d\n", t[0], t[1], t[2]);
    out.append(buf, size_t(n));
  }
  out += "        </DataArray>\n";
  appendDataArray(out, "Int32", "offsets", 1);
  for (int i = 1; i <= mesh.getNumTriangles(); ++i) {
    const int n = std::snprintf(buf, sizeof buf, "%s%d", (i - 1) % 16 == 0 ? "          " : " ", 3 * i);
    out.append(buf, size_t(n));
    if (i % 16 == 0 || i == mesh.getNumTriangles()) out += '\n';
  }
  out += "        </DataArray>\n      </Polys>\n";
}

std::string pieceHeader(const io::TriangleMesh& mesh) {
  return "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
         "  <PolyData>\n    <Piece NumberOfPoints=\"" +
         std::to_string(mesh.getNumVertices()) +
         "\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"" +
         std::to_string(mesh.getNumTriangles()) + "\">\n";
}

const char* kPieceFooter = "    </Piece>\n  </PolyData>\n</VTKFile>\n";

}  // namespace

io::Storage makeContactStorage(const ContactSeries& series, const ContactAreaCalculator& calculator,
                               const std::string& name,
                               const std::vector<std::pair<std::string, std::vector<double>>>& extra_columns,
                               const std::vector<std::pair<std::string, std::string>>& header) {
  auto columns = getContactChannels(series);
  for (const auto& c : extra_columns) {
    KNEESIM_CHECK(c.second.size() == series.frames.size(), "contact storage: column '" + c.first + "' has a wrong length");
    columns.push_back(c);
  }
  io::Storage s;
  s.name = name;
  s.in_degrees = false;
  s.data.resize(Eigen::Index(series.frames.size()), Eigen::Index(columns.size()));
  std::string units;
  for (size_t c = 0; c < columns.size(); ++c) {
    s.labels.push_back(columns[c].first);
    for (size_t r = 0; r < columns[c].second.size(); ++r) s.data(Eigen::Index(r), Eigen::Index(c)) = columns[c].second[r];
    if (c < columns.size() - extra_columns.size())
      units += (units.empty() ? "" : " ") + columns[c].first + ":" + unitOf(columns[c].first);
  }
  const ContactAreaOptions& o = calculator.getOptions();
  s.header.emplace_back("#", "kneesim contact area: insert " + calculator.getInsert().source_file + ", femoral component " +
                                 calculator.getFemur().source_file);
  s.header.emplace_back("units", units);
  s.header.emplace_back("threshold_m", formatNumber(o.threshold));
  s.header.emplace_back("extra_thresholds_m", formatList(o.extra_thresholds, 1.0));
  s.header.emplace_back("area_rule", toString(o.rule));
  s.header.emplace_back("distance_method", calculator.getDistanceMethod());
  s.header.emplace_back("search_radius_m", formatNumber(calculator.getSearchRadius()) + " (" +
                                               formatNumber(calculator.getLongEdgeSearchRadius()) + " for " +
                                               std::to_string(calculator.getNumLongEdgeVertices()) +
                                               " vertices with longer edges)");
  s.header.emplace_back("articular_area_m2", formatNumber(calculator.getArticularArea()) + " (medial " +
                                                 formatNumber(calculator.getArticularArea(CondyleSide::medial)) +
                                                 ", lateral " +
                                                 formatNumber(calculator.getArticularArea(CondyleSide::lateral)) + ")");
  s.header.emplace_back("#", "centroids (cx, cy, cz) and areas are in the insert frame; dmin is the smallest signed "
                             "distance over the articular vertices (negative: penetration)");
  for (const auto& h : header) s.header.push_back(h);
  return s;
}

void writeInsertVtp(const std::string& path, const ContactAreaCalculator& calculator, const DistanceMapFrame& frame,
                    const MeshDistance* femur_distance) {
  const io::TriangleMesh& insert = calculator.getInsert();
  const std::vector<int>& articular = calculator.getArticularVertices();
  KNEESIM_CHECK(frame.articular_distance.size() == articular.size(),
                "distance map: one distance per articular vertex expected");
  const double clamp = calculator.getSearchRadius();
  std::vector<double> distance(insert.vertices.size(), clamp);
  std::vector<unsigned char> is_articular(insert.vertices.size(), 0);
  if (femur_distance) {
    const Eigen::Isometry3d X_FI = frame.X_IF.inverse(Eigen::Isometry);
    MeshDistanceQuery q;
    for (size_t v = 0; v < insert.vertices.size(); ++v) {
      const Eigen::Vector3d p = X_FI * insert.vertices[v];
      distance[v] = femur_distance->calcSignedDistance(p, clamp, q) ? q.distance : femur_distance->calcSignedDistance(p);
    }
  }
  for (size_t i = 0; i < articular.size(); ++i) {
    distance[size_t(articular[i])] = frame.articular_distance[i];
    is_articular[size_t(articular[i])] = 1;
  }
  std::string out = pieceHeader(insert);
  out += "      <PointData Scalars=\"distance\">\n";
  appendDataArray(out, "Float64", "distance", 1);
  char buf[48];
  for (double d : distance) {
    const int n = std::snprintf(buf, sizeof buf, "          %.9g\n", std::clamp(d, -clamp, clamp));
    out.append(buf, size_t(n));
  }
  out += "        </DataArray>\n";
  for (const char* name : {"articular", "contact"}) {
    appendDataArray(out, "UInt8", name, 1);
    for (size_t v = 0; v < distance.size(); ++v) {
      const bool on = name[0] == 'a' ? is_articular[v] != 0
                                     : is_articular[v] != 0 && distance[v] < calculator.getOptions().threshold;
      out += on ? "1" : "0";
      out += (v % 32 == 31 || v + 1 == distance.size()) ? "\n" : " ";
    }
    out += "        </DataArray>\n";
  }
  out += "      </PointData>\n";
  appendGeometry(out, insert, Eigen::Isometry3d::Identity());
  out += kPieceFooter;
  writeFileAtomically(path, [&](std::ostream& os) { os.write(out.data(), std::streamsize(out.size())); });
}

void writeMeshVtp(const std::string& path, const io::TriangleMesh& mesh, const Eigen::Isometry3d& X) {
  std::string out = pieceHeader(mesh);
  appendGeometry(out, mesh, X);
  out += kPieceFooter;
  writeFileAtomically(path, [&](std::ostream& os) { os.write(out.data(), std::streamsize(out.size())); });
}

void writePvd(const std::string& path, const std::vector<PvdEntry>& entries) {
  std::string out =
      "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
      "  <Collection>\n";
  for (const PvdEntry& e : entries)
    out += "    <DataSet timestep=\"" + formatNumber(e.time) + "\" group=\"\" part=\"" + std::to_string(e.part) +
           "\" file=\"" + e.file + "\"/>\n";
  out += "  </Collection>\n</VTKFile>\n";
  writeFileAtomically(path, [&](std::ostream& os) { os << out; });
}

}  // namespace kneesim::contact
