#include "contact/condyle.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>

#include "contact/mesh_distance.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"

namespace kneesim::contact {

namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

double meshExtent(const io::TriangleMesh& mesh) {
  const auto [lo, hi] = mesh.calcBounds();
  return (hi - lo).maxCoeff();
}

bool onSide(CondyleSide side, const Vector3d& p, const Vector3d& ref, const Vector3d& medial) {
  if (side == CondyleSide::both) return true;
  const double s = medial.dot(p - ref);
  return side == CondyleSide::medial ? s >= 0 : s < 0;
}

// Exposed: the ray from the vertex along its normal meets the mesh nowhere else.
bool isExposed(const MeshDistance& md, const Vector3d& p, const Vector3d& n, double t_min) {
  return !std::isfinite(md.calcRayHit(p, n, t_min, std::numeric_limits<double>::infinity()));
}

std::vector<int> farthestPointSample(const std::vector<SurfacePoint>& pts, int count) {
  const int m = int(pts.size());
  std::vector<int> chosen;
  if (count <= 0 || m <= count) {
    for (int i = 0; i < m; ++i) chosen.push_back(i);
    return chosen;
  }
  Vector3d c = Vector3d::Zero();
  for (const auto& s : pts) c += s.p;
  c /= m;
  int next = 0;
  double far = -1;
  for (int i = 0; i < m; ++i) {
    const double d = (pts[i].p - c).squaredNorm();
    if (d > far) {
      far = d;
      next = i;
    }
  }
  std::vector<double> d2(m, std::numeric_limits<double>::infinity());
  chosen.reserve(count);
  for (int k = 0; k < count; ++k) {
    chosen.push_back(next);
    int arg = 0;
    double best = -1;
    for (int i = 0; i < m; ++i) {
      d2[i] = std::min(d2[i], (pts[i].p - pts[next].p).squaredNorm());
      if (d2[i] > best) {
        best = d2[i];
        arg = i;
      }
    }
    next = arg;
  }
  std::sort(chosen.begin(), chosen.end());  // mesh order, independent of the sampling order
  return chosen;
}

}  // namespace

Eigen::Matrix3d ComponentDirections::calcOrthonormalBasis() const {
  const Vector3d s = superior.normalized();
  const Vector3d p = (posterior - posterior.dot(s) * s).normalized();
  Vector3d m = p.cross(s);
  if (m.dot(medial) < 0) m = -m;
  Eigen::Matrix3d B;
  B << p, s, m;
  return B;
}

Eigen::Matrix3d ComponentDirections::calcRotationTo(const ComponentDirections& other) const {
  const Eigen::Matrix3d R = other.calcOrthonormalBasis() * calcOrthonormalBasis().transpose();
  if (!(R.determinant() > 0))
    throw InputError({"", 0, "component directions"},
                     "expected two components of the same knee (left or right), got directions that a rotation "
                     "cannot align (medial on opposite sides of posterior x superior)");
  return R;
}

void ComponentDirections::validate(const std::string& source) const {
  const Vector3d* v[3] = {&posterior, &superior, &medial};
  const char* names[3] = {"posterior", "superior", "medial"};
  for (int i = 0; i < 3; ++i)
    if (!v[i]->allFinite() || v[i]->norm() == 0)
      throw InputError({source, 0, "component directions"},
                       std::string("expected a finite non-zero ") + names[i] + " direction");
  const double limit = std::sin(10.0 * kDegree);
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) {
      const double c = std::abs(v[i]->normalized().dot(v[j]->normalized()));
      if (c > limit)
        throw InputError({source, 0, "component directions"},
                         std::string("expected ") + names[i] + " and " + names[j] +
                             " directions within 10 deg of perpendicular, got " +
                             std::to_string(std::acos(std::min(1.0, c)) / kDegree) + " deg");
    }
}

const char* toString(CondyleSide side) {
  switch (side) {
    case CondyleSide::medial: return "medial";
    case CondyleSide::lateral: return "lateral";
    default: return "both";
  }
}

SagittalFrame SagittalFrame::fromHinge(const Cylinder& hinge, const ComponentDirections& directions) {
  SagittalFrame f;
  f.origin = hinge.point;
  f.axis = hinge.axis.normalized();
  if (f.axis.dot(directions.calcFlexionAxis()) < 0) f.axis = -f.axis;
  const Vector3d down = -directions.superior.normalized();
  f.distal = (down - down.dot(f.axis) * f.axis).normalized();
  f.posterior = f.distal.cross(f.axis);
  return f;
}

SagittalFrame SagittalFrame::fromDirections(const ComponentDirections& directions, const Vector3d& origin) {
  Cylinder c;
  c.axis = directions.calcFlexionAxis();
  c.point = origin;
  return fromHinge(c, directions);
}

double SagittalFrame::calcFacingAngle(const Vector3d& n) const { return std::atan2(n.dot(posterior), n.dot(distal)); }

double SagittalFrame::calcNormalTilt(const Vector3d& n) const {
  const double len = n.norm();
  return len > 0 ? std::asin(std::min(1.0, std::abs(n.dot(axis)) / len)) : 90.0 * kDegree;
}

double SagittalFrame::calcRadialAngle(const Vector3d& p, const Vector3d& n) const {
  const Vector2d r = calcProfileCoordinates(p);
  const Vector2d m(n.dot(posterior), n.dot(distal));
  if (r.norm() == 0 || m.norm() == 0) return 90.0 * kDegree;
  return std::acos(std::clamp(r.dot(m) / (r.norm() * m.norm()), -1.0, 1.0));
}

Vector2d SagittalFrame::calcProfileCoordinates(const Vector3d& p) const {
  const Vector3d d = p - origin;
  return Vector2d(d.dot(posterior), d.dot(distal));
}

std::vector<SurfacePoint> selectArticularPoints(const io::TriangleMesh& mesh, const ArticularSelection& sel) {
  const std::string& src = mesh.source_file;
  sel.directions.validate(src);
  if (mesh.getNumTriangles() == 0)
    throw InputError({src, 0, "articular surface"}, "expected a triangle mesh, got no triangles");
  const auto [lo, hi] = mesh.calcBounds();
  const Vector3d ref = sel.reference_point ? *sel.reference_point : Vector3d(0.5 * (lo + hi));
  const SagittalFrame frame = sel.frame ? *sel.frame : SagittalFrame::fromDirections(sel.directions, ref);
  const Vector3d medial = sel.directions.medial.normalized();
  const std::vector<Vector3d> normals = mesh.calcVertexNormals();
  const MeshDistance md(mesh);
  const double t_min = 1e-6 * meshExtent(mesh);

  struct Candidate {
    SurfacePoint s;
    int bin;       // facing angle bin, one per degree, per condyle (medial bins first)
    double support;
  };
  const int bins = int(std::ceil((sel.max_facing_angle - sel.min_facing_angle) / kDegree)) + 1;
  std::vector<Candidate> found;
  for (int v = 0; v < mesh.getNumVertices(); ++v) {
    const Vector3d& p = mesh.vertices[v];
    const Vector3d& n = normals[v];
    if (n.norm() == 0) continue;
    const double facing = frame.calcFacingAngle(n);
    if (facing < sel.min_facing_angle || facing > sel.max_facing_angle) continue;
    if (frame.calcNormalTilt(n) > sel.max_normal_tilt) continue;
    if (frame.calcRadialAngle(p, n) > sel.max_radial_angle) continue;
    if (!onSide(sel.side, p, ref, medial)) continue;
    if (!isExposed(md, p, n, t_min)) continue;
    const Vector3d u = std::cos(facing) * frame.distal + std::sin(facing) * frame.posterior;
    const int bin = int((facing - sel.min_facing_angle) / kDegree) + (medial.dot(p - ref) >= 0 ? 0 : bins);
    found.push_back({{p, n}, bin, u.dot(p - frame.origin)});
  }
  // Sagittal support function per condyle and facing bin, taken over the bin and its neighbours.
  std::vector<double> support(2 * bins, -std::numeric_limits<double>::infinity());
  for (const auto& c : found) support[c.bin] = std::max(support[c.bin], c.support);
  std::vector<SurfacePoint> candidates;
  for (const auto& c : found) {
    const int side_first = c.bin < bins ? 0 : bins;
    double outer = support[c.bin];
    if (c.bin > side_first) outer = std::max(outer, support[c.bin - 1]);
    if (c.bin + 1 < side_first + bins) outer = std::max(outer, support[c.bin + 1]);
    if (c.support >= outer - sel.max_recess) candidates.push_back(c.s);
  }
  if (candidates.empty())
    throw InputError({src, 0, "articular surface"},
                     std::string("expected exposed vertices facing ") + std::to_string(sel.min_facing_angle / kDegree) +
                         ".." + std::to_string(sel.max_facing_angle / kDegree) + " deg on side '" + toString(sel.side) +
                         "', got none (are the component directions right?)");
  std::vector<SurfacePoint> out;
  for (int i : farthestPointSample(candidates, sel.max_points)) out.push_back(candidates[i]);
  return out;
}

std::vector<Vector3d> getPositions(const std::vector<SurfacePoint>& points) {
  std::vector<Vector3d> out;
  out.reserve(points.size());
  for (const auto& s : points) out.push_back(s.p);
  return out;
}

std::vector<Vector3d> getNormals(const std::vector<SurfacePoint>& points) {
  std::vector<Vector3d> out;
  out.reserve(points.size());
  for (const auto& s : points) out.push_back(s.n);
  return out;
}

CondyleFits fitCondyles(const io::TriangleMesh& mesh, const ArticularSelection& selection) {
  CondyleFits out;
  ArticularSelection s = selection;
  s.max_points = selection.max_points > 0 ? std::max(1, selection.max_points / 2) : 0;
  s.side = CondyleSide::medial;
  out.medial_points = selectArticularPoints(mesh, s);
  s.side = CondyleSide::lateral;
  out.lateral_points = selectArticularPoints(mesh, s);
  std::vector<SurfacePoint> both = out.medial_points;
  both.insert(both.end(), out.lateral_points.begin(), out.lateral_points.end());

  const Vector3d flex = selection.directions.calcFlexionAxis();
  auto fit = [&](const std::vector<SurfacePoint>& pts, const char* what) {
    CylinderFitOptions o;
    o.source = mesh.source_file + " (" + what + " condyle points)";
    CylinderFit f = fitCylinder(getPositions(pts), getNormals(pts), o);
    if (f.cylinder.axis.dot(flex) < 0) f.cylinder.axis = -f.cylinder.axis;
    return f;
  };
  out.medial = fit(out.medial_points, "medial");
  out.lateral = fit(out.lateral_points, "lateral");
  out.both = fit(both, "medial and lateral");
  return out;
}

SagittalRadiusTable calcSagittalRadii(const io::TriangleMesh& mesh, const SagittalFrame& frame,
                                      const Vector3d& medial_direction, CondyleSide side,
                                      const SagittalRadiusOptions& options) {
  const std::string& src = mesh.source_file;
  if (mesh.getNumTriangles() == 0)
    throw InputError({src, 0, "sagittal profile"}, "expected a triangle mesh, got no triangles");
  if (!(options.step > 0) || !(options.window > 0) || !(options.last >= options.first))
    throw InputError({src, 0, "sagittal profile"}, "expected step > 0, window > 0 and last >= first");
  const std::vector<Vector3d> normals = mesh.calcVertexNormals();
  const MeshDistance md(mesh);
  const double t_min = 1e-6 * meshExtent(mesh);
  const double lo = options.first - options.window / 2, hi = options.last + options.window / 2;
  const Vector3d medial = medial_direction.normalized();

  struct Candidate {
    Vector3d p;
    double facing, axial, tilt;
  };
  std::vector<Candidate> cand;
  for (int v = 0; v < mesh.getNumVertices(); ++v) {
    const Vector3d& p = mesh.vertices[v];
    const Vector3d& n = normals[v];
    if (n.norm() == 0 || !onSide(side, p, frame.origin, medial)) continue;
    const double facing = frame.calcFacingAngle(n), tilt = frame.calcNormalTilt(n);
    if (facing < lo || facing > hi || tilt > 45 * kDegree) continue;
    if (frame.calcRadialAngle(p, n) > 60 * kDegree) continue;
    if (!isExposed(md, p, n, t_min)) continue;
    cand.push_back({p, facing, frame.calcAxialCoordinate(p), tilt});
  }
  SagittalRadiusTable table;
  table.side = side;
  if (options.profile_axial) {
    table.profile_axial = *options.profile_axial;
  } else {
    double sum = 0;
    int count = 0;
    for (const auto& c : cand)
      if (c.tilt <= 20 * kDegree && c.facing >= options.first && c.facing <= options.last) {
        sum += c.axial;
        ++count;
      }
    if (count == 0)
      throw InputError({src, 0, "sagittal profile"},
                       std::string("expected exposed condyle vertices on side '") + toString(side) + "', got none");
    table.profile_axial = sum / count;
  }
  struct ProfilePoint {
    Vector2d q;
    double facing;
  };
  std::vector<ProfilePoint> profile;
  for (const auto& c : cand)
    if (std::abs(c.axial - table.profile_axial) <= options.slab_half_width)
      profile.push_back({frame.calcProfileCoordinates(c.p), c.facing});
  if (profile.empty())
    throw InputError({src, 0, "sagittal profile"},
                     std::string("expected profile vertices within ") + std::to_string(options.slab_half_width) +
                         " m of the sagittal plane at axial coordinate " + std::to_string(table.profile_axial) +
                         " m on side '" + toString(side) + "', got none");

  const int rows = int(std::floor((options.last - options.first) / options.step + 1e-9)) + 1;
  std::vector<Vector2d> window_pts;
  for (int i = 0; i < rows; ++i) {
    SagittalRadiusSample s;
    s.flexion = options.first + i * options.step;
    window_pts.clear();
    for (const auto& pp : profile)
      if (std::abs(pp.facing - s.flexion) <= options.window / 2) window_pts.push_back(pp.q);
    s.errors.num_points = int(window_pts.size());
    if (int(window_pts.size()) >= std::max(3, options.min_points)) {
      try {
        const CircleFit fit = fitCircle(window_pts, src);
        s.radius = fit.circle.radius;
        s.center = fit.circle.center;
        s.errors = fit.errors;
      } catch (const InputError&) {
        // Collinear window: a flat stretch of the profile has no finite radius.
        s.radius = std::numeric_limits<double>::infinity();
      }
    }
    table.samples.push_back(s);
  }
  return table;
}

void writeSagittalRadiusTable(const std::string& path, const std::vector<SagittalRadiusTable>& tables) {
  KNEESIM_CHECK(!tables.empty(), "no sagittal radius table to write");
  for (const auto& t : tables)
    KNEESIM_CHECK(t.samples.size() == tables[0].samples.size(), "sagittal radius tables differ in length");
  writeFileAtomically(path, [&](std::ostream& os) {
    os << "flexion_deg";
    for (const auto& t : tables) {
      const std::string s = toString(t.side);
      os << ",R_" << s << "_m,cx_" << s << "_m,cy_" << s << "_m,rms_" << s << "_m,n_" << s;
    }
    os << "\n" << std::setprecision(10);
    for (size_t i = 0; i < tables[0].samples.size(); ++i) {
      os << tables[0].samples[i].flexion / kDegree;
      for (const auto& t : tables) {
        const auto& s = t.samples[i];
        os << "," << s.radius << "," << s.center.x() << "," << s.center.y() << "," << s.errors.rms << ","
           << s.errors.num_points;
      }
      os << "\n";
    }
  });
}

InsertArticularVertices selectInsertArticularVertices(const io::TriangleMesh& insert,
                                                      const ComponentDirections& directions, double max_normal_angle,
                                                      const std::optional<Vector3d>& split_point) {
  directions.validate(insert.source_file);
  if (insert.getNumTriangles() == 0)
    throw InputError({insert.source_file, 0, "articular surface"}, "expected a triangle mesh, got no triangles");
  InsertArticularVertices out;
  const std::vector<Vector3d> normals = insert.calcVertexNormals();
  const MeshDistance md(insert);
  const auto [lo, hi] = insert.calcBounds();
  out.split_point = split_point ? *split_point : Vector3d(0.5 * (lo + hi));
  out.medial_direction = directions.medial.normalized();
  const Vector3d up = directions.superior.normalized();
  const double t_min = 1e-6 * (hi - lo).maxCoeff();
  const double min_cos = std::cos(max_normal_angle);
  for (int v = 0; v < insert.getNumVertices(); ++v) {
    const Vector3d& p = insert.vertices[size_t(v)];
    const Vector3d& n = normals[size_t(v)];
    if (n.dot(up) < min_cos) continue;
    if (!isExposed(md, p, n, t_min)) continue;
    (out.medial_direction.dot(p - out.split_point) >= 0 ? out.medial : out.lateral).push_back(v);
  }
  if (out.medial.empty() || out.lateral.empty())
    throw InputError({insert.source_file, 0, "articular surface"},
                     "expected upward-facing exposed vertices on both sides of the insert, got none on one side "
                     "(are the component directions right?)");
  return out;
}

}  // namespace kneesim::contact
