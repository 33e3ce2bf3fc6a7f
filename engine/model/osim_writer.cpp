#include "model/osim_writer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"

namespace kneesim::model {

std::string formatExact(double value) {
  if (std::isnan(value)) return "NaN";
  if (std::isinf(value)) return value > 0 ? "Inf" : "-Inf";
  if (value == 0.0) return "0";  // also -0, which reads back as 0 anyway
  char buf[40];
  for (int precision = 15; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, value);
    double back = 0;
    if (tryParseDouble(buf, back) && back == value) break;
  }
  return buf;
}

Vec3 calcXYZFromRotation(const Mat3& R) {
  // R = Rx(a) Ry(b) Rz(c): R(0,2) = sin b, R(1,2) = -sin a cos b, R(2,2) = cos a cos b,
  // R(0,1) = -cos b sin c, R(0,0) = cos b cos c.
  // b from atan2 rather than asin: asin loses half the digits near +-90 deg.
  const double cb = std::hypot(R(0, 0), R(0, 1));
  const double b = std::atan2(R(0, 2), cb);
  if (cb < 1e-12) {
    // Gimbal lock: only a + c (or a - c) is defined; put it all in a.
    return Vec3(std::atan2(R(2, 1), R(1, 1)), b, 0.0);
  }
  return Vec3(std::atan2(-R(1, 2), R(2, 2)), b, std::atan2(-R(0, 1), R(0, 0)));
}

namespace {

std::string numbers(const std::vector<double>& v) {
  std::string out;
  for (size_t i = 0; i < v.size(); ++i) out += (i ? " " : "") + formatExact(v[i]);
  return out;
}

std::string vec3(const Vec3& v) { return numbers({v.x(), v.y(), v.z()}); }

bool isIdentity(const Pose& X) {
  return X.translation().isZero(0.0) && (X.linear() - Mat3::Identity()).isZero(0.0);
}

class Writer {
 public:
  Writer(const Model& m, const OsimWriteOptions& o) : m_(m), o_(o) {}

  std::string run() {
    checkWritable();
    line(0, "<?xml version=\"1.0\" encoding=\"UTF-8\" ?>");
    if (!o_.comment.empty()) {
      line(0, "<!--");
      for (const std::string& c : o_.comment) {
        std::string safe = c;  // "--" may not appear inside an XML comment
        for (size_t p; (p = safe.find("--")) != std::string::npos;) safe.replace(p, 2, "- -");
        line(1, safe);
      }
      line(0, "-->");
    }
    line(0, "<OpenSimDocument Version=\"40000\">");
    line(1, "<Model name=\"" + xml::escape(m_.name.empty() ? std::string("model") : m_.name) + "\">");
    if (!o_.credits.empty()) element(2, "credits", xml::escape(o_.credits));
    if (!o_.publications.empty()) element(2, "publications", xml::escape(o_.publications));
    element(2, "length_units", "meters");
    element(2, "force_units", "N");
    element(2, "gravity", vec3(m_.gravity));
    writeGround();
    writeBodies();
    writeJoints();
    writeConstraints();
    writeMarkers();
    line(1, "</Model>");
    line(0, "</OpenSimDocument>");
    return out_.str();
  }

 private:
  void line(int indent, const std::string& text) { out_ << std::string(indent, '\t') << text << '\n'; }
  void element(int indent, const std::string& tag, const std::string& text) {
    line(indent, "<" + tag + ">" + text + "</" + tag + ">");
  }

  void checkWritable() {
    for (const Joint& j : m_.joints)
      if (j.reverse && m_.format_version > 0 && m_.format_version < 40000)
        throw InputError({m_.source_file, 0, "joint[" + j.name + "]"},
                         "expected a forward joint, got one reversed in the OpenSim 3 sense (reverse = true in a "
                         "format-" + std::to_string(m_.format_version) +
                             " model): format 40000 keeps every joint transform parent-to-child, so rebuild the "
                             "joint forward before writing");
  }

  std::string bodyPath(int b) const { return b == 0 ? "/ground" : "/bodyset/" + m_.bodies[b].name; }

  static std::string meshStem(const MeshRef& mesh) {
    std::string stem = std::filesystem::path(mesh.file).stem().string();
    for (char& c : stem)
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-')) c = '_';
    return stem.empty() ? std::string("mesh") : stem;
  }

  void writeMesh(int indent, const MeshRef& mesh, const std::string& name) {
    line(indent, "<Mesh name=\"" + xml::escape(name) + "\">");
    element(indent + 1, "socket_frame", "..");
    element(indent + 1, "scale_factors", vec3(mesh.scale));
    element(indent + 1, "mesh_file", xml::escape(mesh.file));
    line(indent, "</Mesh>");
  }

  void writeOffsetFrame(int indent, const std::string& name, const std::string& parent, const Pose& X) {
    line(indent, "<PhysicalOffsetFrame name=\"" + xml::escape(name) + "\">");
    element(indent + 1, "socket_parent", xml::escape(parent));
    element(indent + 1, "translation", vec3(X.translation()));
    element(indent + 1, "orientation", vec3(calcXYZFromRotation(X.linear())));
    line(indent, "</PhysicalOffsetFrame>");
  }

  // A frame's meshes: those at the identity in attached_geometry, the others on offset frames
  // in <components>.
  void writeFrameContents(int indent, int body) {
    const std::vector<MeshRef>& meshes = m_.bodies[body].meshes;
    std::vector<std::string> names;
    std::set<std::string> used;
    for (const MeshRef& mesh : meshes) {
      std::string n = meshStem(mesh);
      for (int k = 2; used.count(n); ++k) n = meshStem(mesh) + "_" + std::to_string(k);
      used.insert(n);
      names.push_back(n);
    }
    bool any_offset = false, any_direct = false;
    for (const MeshRef& mesh : meshes) (isIdentity(mesh.X_BG) ? any_direct : any_offset) = true;
    if (any_offset) {
      line(indent, "<components>");
      for (size_t k = 0; k < meshes.size(); ++k) {
        if (isIdentity(meshes[k].X_BG)) continue;
        const std::string frame = names[k] + "_frame";
        line(indent + 1, "<PhysicalOffsetFrame name=\"" + xml::escape(frame) + "\">");
        line(indent + 2, "<attached_geometry>");
        writeMesh(indent + 3, meshes[k], names[k]);
        line(indent + 2, "</attached_geometry>");
        element(indent + 2, "socket_parent", xml::escape(bodyPath(body)));
        element(indent + 2, "translation", vec3(meshes[k].X_BG.translation()));
        element(indent + 2, "orientation", vec3(calcXYZFromRotation(meshes[k].X_BG.linear())));
        line(indent + 1, "</PhysicalOffsetFrame>");
      }
      line(indent, "</components>");
    }
    if (any_direct) {
      line(indent, "<attached_geometry>");
      for (size_t k = 0; k < meshes.size(); ++k)
        if (isIdentity(meshes[k].X_BG)) writeMesh(indent + 1, meshes[k], names[k]);
      line(indent, "</attached_geometry>");
    }
  }

  void writeGround() {
    line(2, "<Ground name=\"ground\">");
    writeFrameContents(3, 0);
    line(2, "</Ground>");
  }

  void writeBodies() {
    line(2, "<BodySet name=\"bodyset\">");
    line(3, "<objects>");
    for (size_t b = 1; b < m_.bodies.size(); ++b) {
      const Body& body = m_.bodies[b];
      line(4, "<Body name=\"" + xml::escape(body.name) + "\">");
      writeFrameContents(5, int(b));
      element(5, "mass", formatExact(body.mass));
      element(5, "mass_center", vec3(body.mass_center));
      const Mat3& I = body.inertia;
      element(5, "inertia", numbers({I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2)}));
      line(4, "</Body>");
    }
    line(3, "</objects>");
    line(3, "<groups />");
    line(2, "</BodySet>");
  }

  void writeFunction(int indent, const Function& f, const std::string& property) {
    const std::string open = "<" + f.getTypeName() + " name=\"" + property + "\">";
    const std::string close = "</" + f.getTypeName() + ">";
    if (const auto* c = dynamic_cast<const Constant*>(&f)) {
      line(indent, open);
      element(indent + 1, "value", formatExact(c->getValue()));
      line(indent, close);
    } else if (const auto* l = dynamic_cast<const LinearFunction*>(&f)) {
      line(indent, open);
      element(indent + 1, "coefficients", numbers({l->getSlope(), l->getIntercept()}));
      line(indent, close);
    } else if (const auto* p = dynamic_cast<const PolynomialFunction*>(&f)) {
      line(indent, open);
      element(indent + 1, "coefficients", numbers(p->getCoefficients()));
      line(indent, close);
    } else if (const auto* s = dynamic_cast<const SimmSpline*>(&f)) {
      line(indent, open);
      element(indent + 1, "x", numbers(s->getX()));
      element(indent + 1, "y", numbers(s->getY()));
      line(indent, close);
    } else if (const auto* pw = dynamic_cast<const PiecewiseLinearFunction*>(&f)) {
      line(indent, open);
      element(indent + 1, "x", numbers(pw->getX()));
      element(indent + 1, "y", numbers(pw->getY()));
      line(indent, close);
    } else if (const auto* mf = dynamic_cast<const MultiplierFunction*>(&f)) {
      line(indent, open);
      writeFunction(indent + 1, *mf->getFunction(), "function");
      element(indent + 1, "scale", formatExact(mf->getScale()));
      line(indent, close);
    } else {
      throw InputError({m_.source_file, 0, ""}, "expected a function type OpenSim knows, got '" + f.getTypeName() + "'");
    }
  }

  void writeCoordinate(int indent, const Coordinate& c) {
    line(indent, "<Coordinate name=\"" + xml::escape(c.name) + "\">");
    element(indent + 1, "default_value", formatExact(c.default_value));
    element(indent + 1, "default_speed_value", "0");
    element(indent + 1, "range", numbers({c.range_min, c.range_max}));
    element(indent + 1, "clamped", c.clamped ? "true" : "false");
    element(indent + 1, "locked", c.locked ? "true" : "false");
    line(indent, "</Coordinate>");
  }

  // readOsim numbers coordinates in the order their joints appear in the file and orders the
  // joints parent-first, siblings in file order. Write the joints in an order that gives back
  // both the model's coordinate indices and its joint order: a topological order of "lower
  // coordinate index first" and "earlier sibling first", ties broken by joint index.
  std::vector<int> calcFileOrder() const {
    const int n = int(m_.joints.size());
    auto first_coordinate = [&](int j) {
      return m_.joints[j].coordinates.empty() ? -1
                                              : *std::min_element(m_.joints[j].coordinates.begin(),
                                                                  m_.joints[j].coordinates.end());
    };
    auto must_precede = [&](int a, int b) {  // a before b in the file
      const int ca = first_coordinate(a), cb = first_coordinate(b);
      if (ca >= 0 && cb >= 0 && ca < cb) return true;
      return m_.joints[a].parent_body == m_.joints[b].parent_body && a < b;
    };
    std::vector<int> order;
    std::vector<char> placed(n, 0);
    for (int step = 0; step < n; ++step) {
      int pick = -1;
      for (int j = 0; j < n && pick < 0; ++j) {
        if (placed[j]) continue;
        bool ready = true;
        for (int i = 0; i < n && ready; ++i) ready = placed[i] || i == j || !must_precede(i, j);
        if (ready) pick = j;
      }
      if (pick < 0) {  // the two orders conflict: keep the model's joint order
        order.clear();
        for (int j = 0; j < n; ++j) order.push_back(j);
        return order;
      }
      placed[pick] = 1;
      order.push_back(pick);
    }
    return order;
  }

  void writeJoints() {
    static const char* const axis_names[6] = {"rotation1",    "rotation2",    "rotation3",
                                              "translation1", "translation2", "translation3"};
    line(2, "<JointSet name=\"jointset\">");
    line(3, "<objects>");
    for (int ji : calcFileOrder()) {
      const Joint& j = m_.joints[ji];
      const std::string tag = getJointTypeName(j.type);
      // A joint the tree uses from its child is written as the file had it, parent first.
      const bool swap = j.reversed_in_tree;
      const int parent_body = swap ? j.child_body : j.parent_body, child_body = swap ? j.parent_body : j.child_body;
      const std::string parent_frame = m_.bodies[parent_body].name + "_offset";
      const std::string child_frame = m_.bodies[child_body].name + "_offset";
      line(4, "<" + tag + " name=\"" + xml::escape(j.name) + "\">");
      element(5, "socket_parent_frame", xml::escape(parent_frame));
      element(5, "socket_child_frame", xml::escape(child_frame));
      if (j.coordinates.empty()) {
        line(5, "<coordinates />");
      } else {
        line(5, "<coordinates>");
        for (int c : j.coordinates) writeCoordinate(6, m_.coordinates[c]);
        line(5, "</coordinates>");
      }
      if (j.reverse) element(5, "reverse", "true");
      line(5, "<frames>");
      writeOffsetFrame(6, parent_frame, bodyPath(parent_body), swap ? j.X_BM : j.X_PF);
      writeOffsetFrame(6, child_frame, bodyPath(child_body), swap ? j.X_PF : j.X_BM);
      line(5, "</frames>");
      if (j.type == JointType::Custom) {
        line(5, "<SpatialTransform>");
        for (int a = 0; a < 6; ++a) {
          const TransformAxis& ax = j.spatial[a];
          line(6, std::string("<TransformAxis name=\"") + axis_names[a] + "\">");
          std::string names;
          for (int c : ax.coordinates) names += (names.empty() ? "" : " ") + m_.coordinates[c].name;
          element(7, "coordinates", xml::escape(names));
          element(7, "axis", vec3(ax.axis));
          if (ax.function) writeFunction(7, *ax.function, "function");
          line(6, "</TransformAxis>");
        }
        line(5, "</SpatialTransform>");
      }
      if (j.type == JointType::Ellipsoid) element(5, "radii_x_y_z", vec3(j.radii));
      if (j.type == JointType::Scapulothoracic) {
        element(5, "thoracic_ellipsoid_radii_x_y_z", vec3(j.radii));
        element(5, "scapula_winging_axis_origin", numbers({j.winging_origin.x(), j.winging_origin.y()}));
        element(5, "scapula_winging_axis_direction", formatExact(j.winging_direction));
      }
      line(4, "</" + tag + ">");
    }
    line(3, "</objects>");
    line(3, "<groups />");
    line(2, "</JointSet>");
  }

  // A WeldConstraint links two frames it owns; the other constraints name bodies and points.
  void writeBodyConstraint(int indent, const Constraint& k) {
    const std::string tag = getConstraintTypeName(k.type);
    line(indent, "<" + tag + " name=\"" + xml::escape(k.name) + "\">");
    element(indent + 1, "isEnforced", "true");
    switch (k.type) {
      case ConstraintType::Point:
      case ConstraintType::ConstantDistance:
        element(indent + 1, "socket_body_1", xml::escape(bodyPath(k.body1)));
        element(indent + 1, "socket_body_2", xml::escape(bodyPath(k.body2)));
        element(indent + 1, "location_body_1", vec3(k.X_B1F1.translation()));
        element(indent + 1, "location_body_2", vec3(k.X_B2F2.translation()));
        if (k.type == ConstraintType::ConstantDistance) element(indent + 1, "constant_distance", formatExact(k.distance));
        break;
      case ConstraintType::PointOnLine:
        element(indent + 1, "socket_line_body", xml::escape(bodyPath(k.body1)));
        element(indent + 1, "socket_follower_body", xml::escape(bodyPath(k.body2)));
        element(indent + 1, "line_direction_vec", vec3(k.X_B1F1.linear().col(0)));
        element(indent + 1, "point_on_line", vec3(k.X_B1F1.translation()));
        element(indent + 1, "point_on_follower", vec3(k.X_B2F2.translation()));
        break;
      case ConstraintType::Weld:
        element(indent + 1, "socket_frame1", "frame1");
        element(indent + 1, "socket_frame2", "frame2");
        line(indent + 1, "<frames>");
        writeOffsetFrame(indent + 2, "frame1", bodyPath(k.body1), k.X_B1F1);
        writeOffsetFrame(indent + 2, "frame2", bodyPath(k.body2), k.X_B2F2);
        line(indent + 1, "</frames>");
        break;
    }
    line(indent, "</" + tag + ">");
  }

  void writeConstraints() {
    if (m_.couplers.empty() && m_.constraints.empty()) return;
    line(2, "<ConstraintSet name=\"constraintset\">");
    line(3, "<objects>");
    for (const CoordinateCoupler& cc : m_.couplers) {
      line(4, "<CoordinateCouplerConstraint name=\"" + xml::escape(cc.name) + "\">");
      element(5, "isEnforced", "true");
      writeFunction(5, *cc.function, "coupled_coordinates_function");
      std::string names;
      for (int c : cc.independents) names += (names.empty() ? "" : " ") + m_.coordinates[c].name;
      element(5, "independent_coordinate_names", xml::escape(names));
      element(5, "dependent_coordinate_name", xml::escape(m_.coordinates[cc.dependent].name));
      element(5, "scale_factor", formatExact(cc.scale_factor));
      line(4, "</CoordinateCouplerConstraint>");
    }
    for (const Constraint& k : m_.constraints) writeBodyConstraint(4, k);
    line(3, "</objects>");
    line(3, "<groups />");
    line(2, "</ConstraintSet>");
  }

  void writeMarkers() {
    if (m_.markers.empty()) return;
    line(2, "<MarkerSet name=\"markerset\">");
    line(3, "<objects>");
    for (const Marker& mk : m_.markers) {
      line(4, "<Marker name=\"" + xml::escape(mk.name) + "\">");
      element(5, "socket_parent_frame", xml::escape(bodyPath(mk.body)));
      element(5, "location", vec3(mk.p_BM));
      element(5, "fixed", mk.fixed ? "true" : "false");
      line(4, "</Marker>");
    }
    line(3, "</objects>");
    line(3, "<groups />");
    line(2, "</MarkerSet>");
  }

  const Model& m_;
  const OsimWriteOptions& o_;
  std::ostringstream out_;
};

}  // namespace

std::string formatOsim(const Model& model, const OsimWriteOptions& options) { return Writer(model, options).run(); }

void writeOsim(const std::string& path, const Model& model, const OsimWriteOptions& options) {
  const std::string text = formatOsim(model, options);  // everything computed before the file is touched
  writeFileAtomically(path, [&](std::ostream& os) { os << text; });
}

}  // namespace kneesim::model
