// Reads wrap objects, muscles with their geometry paths and coordinate actuators of an OpenSim
// model file or actuator set file into the model description.
#include "model/osim_forces.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>

#include "core/strings.hpp"
#include "model/osim_reader_internal.hpp"

namespace kneesim::model {

namespace {

using xml::Node;

FunctionPtr parseFunctionIfAny(const Node& el) {
  return osim::isFunctionTag(el.name()) ? osim::parseFunction(el) : nullptr;
}

const std::set<std::string>& muscleTypes() {
  static const std::set<std::string> types = {"Schutte1993Muscle_Deprecated", "Thelen2003Muscle",
                                              "Thelen2003Muscle_Deprecated", "Millard2012EquilibriumMuscle"};
  return types;
}

std::string lastPathPart(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

/// The text naming a connected component: a 3.x child <tag3>, a 4.x <socket_name> (30508-30516:
/// <socket_name_connectee_name>), or a 3.3 <connectors> entry named @p name.
std::pair<Node, std::string> findReference(const Node& el, const char* tag3, const std::string& name) {
  if (Node n = el.child(tag3); n && !n.text().empty()) return {n, n.text()};
  for (const std::string& socket : {"socket_" + name, "socket_" + name + "_connectee_name"})
    if (Node n = el.child(socket.c_str()); n && !n.text().empty()) return {n, n.text()};
  for (const Node& c : el.child("connectors").children())
    if (c.nameAttr() == name)
      for (const char* tag : {"connectee_name", "connected_to_name"})  // 30500-30502: connected_to_name
        if (Node n = c.child(tag); n && !n.text().empty()) return {n, n.text()};
  return {Node(), ""};
}

double requireFinite(const Node& el, const char* tag, double fallback, bool non_negative) {
  Node n = el.child(tag);
  if (!n || n.text().empty()) return fallback;
  const double v = n.toDouble();
  if (!std::isfinite(v) || (non_negative && v < 0))
    n.fail(std::string("expected a finite") + (non_negative ? " non-negative" : "") + " number, got " + n.text());
  return v;
}

/// A control bound: OpenSim writes an unbounded one as "Inf" or "-Inf" (an Actuator's default),
/// kept here as +-1e30, kneesim's "no bound"; NaN is an error.
double readControlBound(const Node& el, const char* tag, double fallback) {
  Node n = el.child(tag);
  if (!n || n.text().empty()) return fallback;
  const double v = n.toDouble();
  if (std::isnan(v)) n.fail("expected a number or +-Inf, got " + n.text());
  return std::clamp(v, -1e30, 1e30);
}

class ForceReader {
 public:
  ForceReader(const OsimForceContext& ctx, Model& m) : ctx_(ctx), m_(m) {}

  void readSet(const Node& set) {
    for (const Node& f : set.child("objects").children()) {
      const std::string type = f.name();
      if (muscleTypes().count(type)) {
        readMuscle(f);
      } else if (type == "CoordinateActuator") {
        readCoordinateActuator(f);
      } else {
        IgnoredComponent ic = osim::classifyIgnored(f, "ForceSet");
        if (isDisabled(f)) {
          ic.type += " (disabled)";
          ic.affects_kinematics = false;
        }
        m_.ignored.push_back(std::move(ic));
      }
    }
  }

 private:
  static bool isDisabled(const Node& f) {
    return f.childBool("isDisabled", false) || !f.childBool("appliesForce", true);
  }

  int requireBody(const Node& where, const std::string& ref, const std::string& owner_path) {
    if (ctx_.v4 && ctx_.resolve_frame) {
      const auto r = ctx_.resolve_frame(ref, owner_path, where);
      if (!r.second.isApprox(Pose::Identity(), 0.0))
        offset_pose_ = r.second;
      else
        offset_pose_.reset();
      return r.first;
    }
    offset_pose_.reset();
    const std::string name = lastPathPart(ref);
    for (size_t b = 0; b < m_.bodies.size(); ++b)
      if (m_.bodies[b].name == name) return int(b);
    where.fail("unknown body '" + ref + "' (expected one of the model's bodies)");
  }

  int requireCoordinate(const Node& where, const std::string& ref) {
    const std::string name = lastPathPart(ref);
    for (size_t i = 0; i < m_.coordinates.size(); ++i)
      if (m_.coordinates[i].name == name) return int(i);
    where.fail("unknown coordinate '" + ref + "'");
  }

  PathPoint readPathPoint(const Node& p, const std::string& owner_path) {
    PathPoint pt;
    pt.name = p.nameAttr();
    // OpenSim 1.x names (MusclePoint, MuscleViaPoint, MovingMusclePoint) read as their 2.x successors.
    std::string type = p.name();
    if (type == "MusclePoint") type = "PathPoint";
    if (type == "MuscleViaPoint") type = "ConditionalPathPoint";
    if (type == "MovingMusclePoint") type = "MovingPathPoint";
    auto [body_node, body_ref] = findReference(p, "body", "parent_frame");
    if (!body_node) p.fail("expected the body of the path point (<body> or <socket_parent_frame>), got none");
    pt.body = requireBody(body_node, body_ref, owner_path + "/" + pt.name);
    pt.p_BP = p.childVec3("location", Eigen::Vector3d::Zero());
    if (!pt.p_BP.allFinite()) p.child("location").fail("expected a finite location, got " + p.childText("location"));
    if (offset_pose_) pt.p_BP = *offset_pose_ * pt.p_BP;
    if (type == "PathPoint") return pt;
    if (type == "ConditionalPathPoint") {
      pt.type = PathPointType::Conditional;
      auto [cn, cref] = findReference(p, "coordinate", "coordinate");
      if (!cn) p.fail("expected the coordinate of the conditional path point, got none");
      pt.coordinate = requireCoordinate(cn, cref);
      Node r = p.requireChild("range");
      const std::vector<double> range = r.toDoubles();
      if (range.size() != 2 || !std::isfinite(range[0]) || !std::isfinite(range[1]))
        r.fail("expected two finite numbers (min max), got '" + r.text() + "'");
      pt.range_min = range[0];
      pt.range_max = range[1];
      return pt;
    }
    if (type == "MovingPathPoint") {
      if (offset_pose_) p.fail("expected a moving path point on a body frame, got one on an offset frame");
      pt.type = PathPointType::Moving;
      static const char* const axes[3] = {"x", "y", "z"};
      for (int k = 0; k < 3; ++k) {
        const std::string loc = std::string(axes[k]) + "_location";
        const std::string coord = std::string(axes[k]) + "_coordinate";
        pt.location_functions[k] = findFunction(p, loc);
        auto [cn, cref] = findReference(p, coord.c_str(), coord);
        if (cn) pt.location_coordinates[k] = requireCoordinate(cn, cref);
      }
      return pt;
    }
    p.fail("unknown path point type '" + type + "' (expected PathPoint, ConditionalPathPoint or MovingPathPoint)");
  }

  /// The function of property @p property: a wrapper <property><Type/></property> or a child
  /// <Type name="property"/>.
  FunctionPtr findFunction(const Node& owner, const std::string& property) {
    if (Node w = owner.child(property.c_str())) {
      for (const Node& c : w.children())
        if (FunctionPtr f = ctx_.parse_function(c)) return f;
      return nullptr;
    }
    for (const Node& c : owner.children())
      if (c.nameAttr() == property)
        if (FunctionPtr f = ctx_.parse_function(c)) return f;
    return nullptr;
  }

  GeometryPath readPath(const Node& muscle, const std::string& owner_path) {
    // OpenSim 1.x files keep the points and wraps in the muscle (MusclePointSet, MuscleWrapSet).
    const bool v1 = !muscle.child("GeometryPath") && muscle.child("MusclePointSet");
    Node gp = v1 ? muscle : muscle.child("GeometryPath");
    if (!gp) muscle.fail("expected a <GeometryPath>, got none");
    GeometryPath path;
    const std::string path_owner = owner_path + "/" + (v1 || gp.nameAttr().empty() ? "path" : gp.nameAttr());
    Node set = gp.child(v1 ? "MusclePointSet" : "PathPointSet");
    for (const Node& p : set.child("objects").children()) path.points.push_back(readPathPoint(p, path_owner));
    int fixed = 0;
    for (const PathPoint& p : path.points) fixed += p.type != PathPointType::Conditional;
    if (fixed < 2)
      (set ? set : gp).fail("expected at least two path points that are always active, got " + std::to_string(fixed));
    for (const Node& w : gp.child(v1 ? "MuscleWrapSet" : "PathWrapSet").child("objects").children()) {
      if (w.name() != (v1 ? "MuscleWrap" : "PathWrap"))
        w.fail(std::string("expected <") + (v1 ? "MuscleWrap" : "PathWrap") + ">, got <" + w.name() + ">");
      PathWrap pw;
      Node on = w.requireChild("wrap_object");
      for (size_t i = 0; i < m_.wrap_objects.size() && pw.wrap_object < 0; ++i)
        if (m_.wrap_objects[i].name == on.text()) pw.wrap_object = int(i);
      if (pw.wrap_object < 0)
        on.fail("unknown wrap object '" + on.text() + "' (expected one in a body's WrapObjectSet)");
      const std::string method = toLower(w.childText("method", "hybrid"));
      if (method == "hybrid" || method == "unassigned")
        pw.method = WrapMethod::Hybrid;
      else if (method == "midpoint")
        pw.method = WrapMethod::Midpoint;
      else if (method == "axial")
        pw.method = WrapMethod::Axial;
      else
        w.child("method").fail("expected hybrid, midpoint or axial, got '" + w.childText("method") + "'");
      if (Node r = w.child("range"); r && !r.text().empty()) {
        const std::vector<double> v = r.toDoubles();
        // Point numbers an int holds (converting 1e10 or inf to one is undefined behaviour).
        if (v.size() != 2 || !truncatesToInt(v[0]) || !truncatesToInt(v[1]))
          r.fail("expected two point numbers (first last), got '" + r.text() + "'");
        pw.range_begin = int(v[0]);
        pw.range_end = int(v[1]);
      }
      path.wraps.push_back(pw);
    }
    return path;
  }

  /// Numeric, boolean and function-valued properties of @p el, nested objects prefixed.
  void collectParameters(const Node& el, const std::string& prefix, Muscle& mu) {
    static const std::set<std::string> skip = {"GeometryPath", "isDisabled", "appliesForce", "min_control",
                                               "max_control", "max_isometric_force", "optimal_fiber_length",
                                               "tendon_slack_length", "pennation_angle_at_optimal",
                                               "max_contraction_velocity"};
    for (const Node& c : el.children()) {
      const std::string tag = c.name();
      if (prefix.empty() && skip.count(tag)) continue;
      if (FunctionPtr f = ctx_.parse_function(c)) {
        mu.functions[c.nameAttr().empty() ? tag : c.nameAttr()] = f;
        continue;
      }
      const std::vector<Node> kids = c.children();
      if (kids.size() == 1)
        if (FunctionPtr f = ctx_.parse_function(kids[0])) {
          mu.functions[tag] = f;
          continue;
        }
      if (!kids.empty()) {
        if (tag != "VisibleObject" && tag != "Appearance" && tag != "GeometryPath" && tag != "MusclePointSet" &&
            tag != "MuscleWrapSet")
          collectParameters(c, prefix + tag + ".", mu);
        continue;
      }
      const std::string text = toLower(c.text());
      double v;
      if (text == "true" || text == "false")
        mu.parameters[prefix + tag] = text == "true" ? 1.0 : 0.0;
      else if (tryParseDouble(c.text(), v)) {
        if (!std::isfinite(v)) c.fail("expected a finite number, got " + c.text());
        mu.parameters[prefix + tag] = v;
      }
    }
  }

  void readMuscle(const Node& f) {
    Muscle mu;
    mu.name = f.nameAttr();
    if (mu.name.empty()) f.fail("expected a name attribute on <" + f.name() + ">, got none");
    mu.type = f.name();
    mu.enabled = !isDisabled(f);
    mu.where = f.where();
    mu.path = readPath(f, "/forceset/" + mu.name);
    mu.max_isometric_force = requireFinite(f, "max_isometric_force", 1000.0, true);
    mu.optimal_fiber_length = requireFinite(f, "optimal_fiber_length", 0.1, true);
    mu.tendon_slack_length = requireFinite(f, "tendon_slack_length", 0.2, true);
    mu.pennation_angle_at_optimal = requireFinite(f, "pennation_angle_at_optimal", 0.0, false);
    mu.max_contraction_velocity = requireFinite(f, "max_contraction_velocity", 10.0, true);
    mu.min_control = readControlBound(f, "min_control", 0.0);
    mu.max_control = readControlBound(f, "max_control", 1.0);
    if (!(mu.optimal_fiber_length > 0)) f.child("optimal_fiber_length").fail("expected a positive length, got 0");
    if (std::abs(mu.pennation_angle_at_optimal) >= M_PI / 2)
      f.child("pennation_angle_at_optimal").fail("expected an angle below pi/2, got " +
                                                  f.childText("pennation_angle_at_optimal"));
    collectParameters(f, "", mu);
    for (const Muscle& other : m_.muscles)
      if (other.name == mu.name) f.fail("duplicate muscle name '" + mu.name + "'");
    m_.muscles.push_back(std::move(mu));
  }

  void readCoordinateActuator(const Node& f) {
    CoordinateActuator a;
    a.name = f.nameAttr();
    a.enabled = !isDisabled(f);
    Node c = f.requireChild("coordinate");
    a.coordinate = requireCoordinate(c, c.text());
    a.optimal_force = requireFinite(f, "optimal_force", 1.0, false);
    a.min_control = readControlBound(f, "min_control", -1e30);
    a.max_control = readControlBound(f, "max_control", 1e30);
    if (a.optimal_force == 0) f.child("optimal_force").fail("expected a non-zero optimal force, got 0");
    if (a.min_control > a.max_control)
      f.fail("expected min_control <= max_control, got " + std::to_string(a.min_control) + " > " +
             std::to_string(a.max_control));
    m_.actuators.push_back(std::move(a));
  }

  const OsimForceContext& ctx_;
  Model& m_;
  std::optional<Pose> offset_pose_;
};

}  // namespace

void readOsimWrapObjects(const xml::Node& frame_element, int body, Model& m) {
  for (const Node& w : frame_element.child("WrapObjectSet").child("objects").children()) {
    const std::string type = w.name();
    WrapObject wo;
    wo.name = w.nameAttr();
    wo.body = body;
    if (type == "WrapSphere") {
      wo.shape = WrapShape::Sphere;
      wo.dimensions.x() = requireFinite(w, "radius", -1.0, false);
      if (!(wo.dimensions.x() > 0)) w.fail("expected a positive <radius>, got " + w.childText("radius", "none"));
    } else if (type == "WrapCylinder") {
      wo.shape = WrapShape::Cylinder;
      wo.dimensions.x() = requireFinite(w, "radius", -1.0, false);
      wo.dimensions.y() = requireFinite(w, "length", 1.0, true);
      if (!(wo.dimensions.x() > 0)) w.fail("expected a positive <radius>, got " + w.childText("radius", "none"));
    } else if (type == "WrapEllipsoid") {
      wo.shape = WrapShape::Ellipsoid;
      Node d = w.requireChild("dimensions");
      wo.dimensions = d.toVec3();
      if (!(wo.dimensions.minCoeff() > 0) || !wo.dimensions.allFinite())
        d.fail("expected three positive radii, got '" + d.text() + "'");
    } else if (type == "WrapTorus") {
      wo.shape = WrapShape::Torus;
      wo.dimensions.x() = requireFinite(w, "inner_radius", -1.0, false);
      wo.dimensions.y() = requireFinite(w, "outer_radius", -1.0, false);
      if (!(wo.dimensions.x() > 0) || !(wo.dimensions.y() > wo.dimensions.x()))
        w.fail("expected 0 < inner_radius < outer_radius, got " + w.childText("inner_radius", "none") + " and " +
               w.childText("outer_radius", "none"));
    } else {
      m.ignored.push_back({type, wo.name});
      continue;
    }
    if (wo.name.empty()) w.fail("expected a name attribute on <" + type + ">, got none");
    const Eigen::Vector3d r = w.childVec3("xyz_body_rotation", Eigen::Vector3d::Zero());
    const Eigen::Vector3d p = w.childVec3("translation", Eigen::Vector3d::Zero());
    if (!r.allFinite() || !p.allFinite()) w.fail("expected a finite xyz_body_rotation and translation");
    wo.X_BW = poseFromXYZ(r, p);
    wo.active = w.childBool("active", true);
    const std::string q = w.childText("quadrant", "all");
    const std::string ql = toLower(q);
    if (ql == "all" || ql == "unassigned" || ql.empty()) {
      wo.quadrant_sign = 0;
    } else if ((ql.size() == 1 || ql.size() == 2) && (ql.back() == 'x' || ql.back() == 'y' || ql.back() == 'z') &&
               (ql.size() == 1 || ql[0] == '+' || ql[0] == '-')) {
      wo.quadrant_axis = ql.back() - 'x';
      wo.quadrant_sign = ql[0] == '-' ? -1 : 1;
    } else {
      w.child("quadrant").fail("expected all, x, -x, y, -y, z or -z, got '" + q + "'");
    }
    m.wrap_objects.push_back(std::move(wo));
  }
}

void readOsimForceSet(const xml::Node& model_element, const OsimForceContext& ctx, Model& m) {
  ForceReader reader(ctx, m);
  if (Node set = model_element.child("ForceSet")) reader.readSet(set);
}

ModelPtr readOsimActuatorSet(const std::string& path, const ModelPtr& model, bool replace) {
  const auto doc = xml::Document::load(path);
  Node root = doc->root();
  Node set = root.name() == "ForceSet" ? root : root.child("ForceSet");
  if (!set) root.fail("expected an actuator set (<ForceSet>), got <" + root.name() + ">");
  auto out = std::make_shared<Model>(*model);
  if (replace) {
    out->muscles.clear();
    out->actuators.clear();
  }
  OsimForceContext ctx;
  ctx.v4 = false;
  ctx.parse_function = parseFunctionIfAny;
  ForceReader reader(ctx, *out);
  reader.readSet(set);
  try {
    out->finalize();
  } catch (const std::invalid_argument& e) {
    throw InputError({path, 0, ""}, e.what());
  }
  return out;
}

namespace osim {

void OsimReader::readWrapObjects(const Node& b, int body) { readOsimWrapObjects(b, body, *m_); }

void OsimReader::readForces(const Node& model_el, bool v4) {
  OsimForceContext ctx;
  ctx.v4 = v4;
  ctx.parse_function = parseFunctionIfAny;
  ctx.resolve_frame = [this](const std::string& path, const std::string& owner, const Node& where) {
    return resolveFrame(path, owner, where);
  };
  readOsimForceSet(model_el, ctx, *m_);
}

}  // namespace osim

}  // namespace kneesim::model
