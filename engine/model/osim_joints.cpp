// The .osim reader's joints and their coordinates: native joint types, PlanarJoint, EllipsoidJoint,
// ScapulothoracicJoint, CustomJoint's SpatialTransform in its forms since format 10500, and the
// check that the joints form a tree.
#include "model/osim_reader_internal.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "core/error.hpp"
#include "core/strings.hpp"

namespace kneesim::model::osim {

namespace {

const char* const kJointTypes =
    "WeldJoint, PinJoint, SliderJoint, BallJoint, FreeJoint, UniversalJoint, GimbalJoint, PlanarJoint, EllipsoidJoint, "
    "ScapulothoracicJoint or CustomJoint";

/// OpenSim 3.x and the 4.0 pre-releases place a joint in its child with location/orientation
/// (renamed location_in_child/orientation_in_child in 30500) and in its parent with
/// location_in_parent/orientation_in_parent.
Pose legacyParentOffset(const Node& j) {
  return poseFromXYZ(j.childVec3("orientation_in_parent", Vec3::Zero()), j.childVec3("location_in_parent", Vec3::Zero()));
}
Pose legacyChildOffset(const Node& j) {
  const Vec3 r = j.child("orientation_in_child") ? j.childVec3("orientation_in_child", Vec3::Zero())
                                                  : j.childVec3("orientation", Vec3::Zero());
  const Vec3 p = j.child("location_in_child") ? j.childVec3("location_in_child", Vec3::Zero())
                                               : j.childVec3("location", Vec3::Zero());
  return poseFromXYZ(r, p);
}

/// Unit axes for the TransformAxis slots a file leaves out, independent of the given ones (as
/// OpenSim's SpatialTransform::constructIndependentAxes does); their functions are zero.
void fillMissingAxes(std::array<AxisInfo, 6>& axes, const std::array<bool, 6>& seen) {
  for (int s = 0; s <= 3; s += 3) {
    std::array<bool, 3> defined{seen[s], seen[s + 1], seen[s + 2]};
    for (int k = 0; k < 3; ++k) {
      if (defined[k]) continue;
      for (int cand = 0; cand < 3 && !defined[k]; ++cand) {
        const Vec3 u = Vec3::Unit((k + cand) % 3);
        bool independent = true;
        for (int o = 0; o < 3; ++o)
          if (o != k && defined[o] && axes[s + o].axis.normalized().cross(u).norm() < 1e-5) independent = false;
        if (independent) {
          axes[s + k].axis = u;
          defined[k] = true;
        }
      }
    }
  }
}

/// A TransformAxis's element, axis and function (its coordinates are read by the caller: their
/// element differs between formats).
void readAxis(const Node& an, AxisInfo& info) {
  info.node = an;
  Node ax = an.requireChild("axis");
  info.axis = ax.toVec3();
  if (!(info.axis.norm() > 1e-12)) ax.fail("expected a non-zero axis, got '" + ax.text() + "'");
  if (Node fn = findObjectProperty(an, "function", {"coordinates", "axis", "is_rotation", "coordinate"}))
    info.function = parseFunction(fn);
}

}  // namespace

void OsimReader::readJointSet(const Node& /*model_el*/) {
  for (const JointElement& je : joint_elements_) {
    const Node& j = je.node;
    Node pf = findSocket(j, {"parent_frame", "parent_body"}), cf = findSocket(j, {"child_frame", "child_body"});
    if (!pf) j.fail("expected <socket_parent_frame> naming the joint's parent frame, got none");
    if (!cf) j.fail("expected <socket_child_frame> naming the joint's child frame, got none");
    const auto parent = resolveFrame(pf.text(), je.path, pf);
    const auto child = resolveFrame(cf.text(), je.path, cf);
    if (child.first == 0) cf.fail("expected a child frame on a body, got ground ('" + cf.text() + "')");
    if (child.first == parent.first)
      cf.fail("expected parent and child frames on different bodies, both are on '" + m_->bodies[child.first].name +
              "'");
    const int ji = readJoint(j, child.first, /*v4=*/true);
    m_->joints[ji].parent_body = parent.first;
    // Formats 30500-30516 still offset the joint frames from the connected frames.
    m_->joints[ji].X_PF = parent.second * legacyParentOffset(j);
    m_->joints[ji].X_BM = child.second * legacyChildOffset(j);
  }
}

std::string OsimReader::nameUnnamedJoint(const Node& j, int child) {
  std::string base = toLower(j.name());
  std::string name = base;
  if (joint_names_.count(name)) name = m_->bodies[child].name + "_" + base;
  for (int k = 2; joint_names_.count(name); ++k) name = m_->bodies[child].name + "_" + base + "_" + std::to_string(k);
  m_->warnings.push_back(formatLocated(j.where(), "<" + j.name() + "> of body '" + m_->bodies[child].name +
                                                      "' has no name; it is called '" + name + "'"));
  return name;
}

std::string OsimReader::claimJointName(const Node& j, int child) {
  std::string name = j.nameAttr().empty() ? nameUnnamedJoint(j, child) : j.nameAttr();
  if (joint_names_.count(name)) {
    // OpenSim 4 renames a component whose name a sibling already has to <name>_0, <name>_1, ...
    // with a warning (Component::finalizeFromProperties); so does kneesim.
    const std::string taken = name;
    for (int k = 0; joint_names_.count(name); ++k) name = taken + "_" + std::to_string(k);
    m_->warnings.push_back(formatLocated(j.where(), "joint name '" + taken + "' is taken by another joint; this <" +
                                                        j.name() + "> is called '" + name + "'"));
  }
  joint_names_.insert(name);
  return name;
}

std::vector<ParsedCoordinate> OsimReader::readJointCoordinates(const Node& j) {
  std::vector<ParsedCoordinate> out;
  std::vector<Node> nodes;
  for (const char* holder : {"CoordinateSet", "coordinates"}) {
    Node h = j.child(holder);
    if (!h) continue;
    for (const Node& c : h.children("Coordinate")) nodes.push_back(c);
    for (const Node& c : h.child("objects").children("Coordinate")) nodes.push_back(c);
  }
  for (const Node& c : nodes) {
    ParsedCoordinate pc;
    pc.node = c;
    Coordinate& co = pc.coord;
    co.name = c.nameAttr();
    if (co.name.empty()) c.fail("expected a name attribute on <Coordinate>, got none");
    co.default_value = c.childDouble("default_value", 0.0);
    co.range_min = -10.0;  // OpenSim's Coordinate default range
    co.range_max = 10.0;
    if (Node r = c.child("range"); r && !r.text().empty()) {
      const std::vector<double> v = r.toDoubles();
      if (v.size() != 2) r.fail("expected 2 numbers (min max), got " + std::to_string(v.size()));
      if (v[0] > v[1]) r.fail("expected min <= max, got " + r.text());
      co.range_min = v[0];
      co.range_max = v[1];
    }
    co.clamped = c.childBool("clamped", false);
    co.locked = c.childBool("locked", false);
    if (Node mt = c.child("motion_type"); mt && !mt.text().empty()) {
      const std::string t = toLower(mt.text());
      pc.has_file_motion = true;
      if (t == "rotational")
        pc.file_motion = MotionType::Rotational;
      else if (t == "translational")
        pc.file_motion = MotionType::Translational;
      else if (t == "coupled")
        pc.file_motion = MotionType::Coupled;
      else
        mt.fail("expected rotational, translational or coupled, got '" + mt.text() + "'");
    }
    out.push_back(pc);
  }
  return out;
}

int OsimReader::addCoordinate(const ParsedCoordinate& pc, int joint, const std::string& joint_name) {
  std::string name = pc.coord.name;
  if (auto it = coord_index_.find(name); it != coord_index_.end()) {
    // OpenSim 4 names a coordinate by its path (/jointset/J/q): only siblings must differ, and a
    // lookup by the bare name finds the first. The later one is called "J/q" here.
    if (m_->coordinates[it->second].joint == joint)
      pc.node.fail("duplicate coordinate name '" + name + "' in joint '" + joint_name + "'");
    name = joint_name + "/" + name;
    if (coord_index_.count(name)) pc.node.fail("duplicate coordinate name '" + name + "'");
    m_->warnings.push_back(formatLocated(pc.node.where(), "coordinate '" + pc.coord.name + "' of joint '" +
                                                              joint_name + "' shares its name with another " +
                                                              "joint's; it is called '" + name + "'"));
  }
  const int ci = int(m_->coordinates.size());
  m_->coordinates.push_back(pc.coord);
  m_->coordinates.back().name = name;
  m_->coordinates.back().joint = joint;
  coord_index_[name] = ci;
  return ci;
}

/// Reads one joint element whose child body is @p child; returns its index in Model::joints.
int OsimReader::readJoint(const Node& j, int child, bool v4) {
  const std::string type = j.name();
  // OpenSim reads joints without a name (test models of formats 10905 to 30000 have them).
  const std::string name = claimJointName(j, child);
  joint_nodes_.push_back(j);

  Joint jt;
  jt.name = name;
  jt.child_body = child;
  jt.reverse = j.childBool("reverse", false);
  if (!v4) {
    Node pb = j.requireChild("parent_body");
    auto it = body_index_.find(pb.text());
    if (it == body_index_.end()) {
      std::vector<std::string> names;
      for (const Body& b : m_->bodies) names.push_back(b.name);
      pb.fail("unknown parent body '" + pb.text() + "' (expected one of " + listNames(names) + ")");
    }
    if (it->second == child) pb.fail("expected a parent body other than the joint's own body '" + pb.text() + "'");
    jt.parent_body = it->second;
    jt.X_PF = legacyParentOffset(j);
    jt.X_BM = legacyChildOffset(j);
  }
  const int ji = int(m_->joints.size());
  std::vector<ParsedCoordinate> coords = readJointCoordinates(j);

  // Native joint types: coordinates in the mobilizer's q order, as the file lists them.
  struct Native {
    const char* tag;
    JointType type;
    std::vector<MotionType> motions;
  };
  const MotionType R = MotionType::Rotational, T = MotionType::Translational;
  static const std::vector<Native> natives = {
      {"WeldJoint", JointType::Weld, {}},          {"PinJoint", JointType::Pin, {R}},
      {"SliderJoint", JointType::Slider, {T}},     {"BallJoint", JointType::Ball, {R, R, R}},
      {"GimbalJoint", JointType::Gimbal, {R, R, R}}, {"UniversalJoint", JointType::Universal, {R, R}},
      {"FreeJoint", JointType::Free, {R, R, R, T, T, T}}};
  for (const Native& nt : natives) {
    if (type != nt.tag) continue;
    jt.type = nt.type;
    if (coords.size() != nt.motions.size())
      j.fail("expected " + std::to_string(nt.motions.size()) + " coordinates for a " + type + ", got " +
             std::to_string(coords.size()));
    for (size_t k = 0; k < coords.size(); ++k) {
      const int ci = addCoordinate(coords[k], ji, jt.name);
      m_->coordinates[ci].motion_type = nt.motions[k];
      jt.coordinates.push_back(ci);
    }
    m_->joints.push_back(jt);
    return ji;
  }
  if (type == "PlanarJoint") {
    // Simbody's Planar mobilizer: rotation about z, then translation along x and y of F.
    if (coords.size() != 3) j.fail("expected 3 coordinates for a PlanarJoint, got " + std::to_string(coords.size()));
    jt.type = JointType::Custom;
    const Vec3 axes[6] = {Vec3::UnitZ(), Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()};
    for (int a = 0; a < 6; ++a) jt.spatial[a].axis = axes[a];
    const MotionType motions[3] = {R, T, T};
    const int axis_of[3] = {0, 3, 4};
    for (int k = 0; k < 3; ++k) {
      const int ci = addCoordinate(coords[k], ji, jt.name);
      m_->coordinates[ci].motion_type = motions[k];
      jt.coordinates.push_back(ci);
      jt.spatial[axis_of[k]].coordinates = {ci};
      jt.spatial[axis_of[k]].function = makeLinear(1.0, 0.0);
    }
    m_->joints.push_back(jt);
    return ji;
  }
  if (type == "CustomJoint") {
    jt.type = JointType::Custom;
    readCustomJoint(j, jt, ji, coords);
    m_->joints.push_back(jt);
    return ji;
  }
  if (type == "EllipsoidJoint" || type == "ScapulothoracicJoint") {
    const bool scap = type == "ScapulothoracicJoint";
    const size_t n = scap ? 4 : 3;
    if (coords.size() != n)
      j.fail("expected " + std::to_string(n) + " coordinates for a " + type + ", got " + std::to_string(coords.size()));
    if (jt.reverse) j.child("reverse").fail("expected reverse false for a " + type + ", got true");
    jt.type = scap ? JointType::Scapulothoracic : JointType::Ellipsoid;
    readEllipsoidProperties(j, jt);
    for (size_t k = 0; k < coords.size(); ++k) {
      const int ci = addCoordinate(coords[k], ji, jt.name);
      m_->coordinates[ci].motion_type = R;
      jt.coordinates.push_back(ci);
    }
    m_->joints.push_back(jt);
    return ji;
  }
  if (type == "ConstantCurvatureJoint")
    j.fail("unsupported joint type '" + type + "' in format " + std::to_string(m_->format_version) + " (expected " +
           kJointTypes + ")");
  j.fail("unknown joint type '" + type + "' (expected " + kJointTypes + ")");
}

void OsimReader::readEllipsoidProperties(const Node& j, Joint& jt) {
  const char* radii = jt.type == JointType::Scapulothoracic ? "thoracic_ellipsoid_radii_x_y_z" : "radii_x_y_z";
  Node r = j.requireChild(radii);
  jt.radii = r.toVec3();
  if (!(jt.radii.minCoeff() > 0) || !jt.radii.allFinite())
    r.fail("expected three positive semi-axes (m), got '" + r.text() + "'");
  if (jt.type != JointType::Scapulothoracic) return;
  if (Node o = j.child("scapula_winging_axis_origin"); o && !o.text().empty()) {
    const std::vector<double> v = o.toDoubles();
    if (v.size() != 2) o.fail("expected 2 numbers (x y in the ellipsoid's joint frame), got " + std::to_string(v.size()));
    jt.winging_origin = Eigen::Vector2d(v[0], v[1]);
  }
  jt.winging_direction = j.childDouble("scapula_winging_axis_direction", 0.0);
  if (!std::isfinite(jt.winging_direction))
    j.child("scapula_winging_axis_direction").fail("expected a finite angle (rad), got " +
                                                   j.childText("scapula_winging_axis_direction"));
}

void OsimReader::readCustomJointAxes(const Node& j, std::array<AxisInfo, 6>& axes) {
  static const char* const axis_names[6] = {"rotation1",    "rotation2",    "rotation3",
                                            "translation1", "translation2", "translation3"};
  if (Node set = j.child("TransformAxisSet")) return readTransformAxisSet(set, axes);
  // A SpatialTransform may list fewer than six axes (format 10901 on) or be absent: the others
  // are OpenSim's defaults, zero functions on independent unit axes.
  std::array<bool, 6> seen{};
  const Node st = j.child("SpatialTransform");
  const std::vector<Node> axis_nodes = st ? st.children("TransformAxis") : std::vector<Node>();
  for (size_t k = 0; k < axis_nodes.size(); ++k) {
    const Node& an = axis_nodes[k];
    int a = -1;
    const std::string an_name = an.nameAttr();
    for (int i = 0; i < 6; ++i)
      if (an_name == axis_names[i]) a = i;
    if (a < 0) {
      if (!an_name.empty())
        an.fail("expected a TransformAxis named rotation1..3 or translation1..3, got '" + an_name + "'");
      if (k >= 6) an.fail("expected at most 6 TransformAxis elements, got more");
      a = int(k);
    }
    if (seen[a]) an.fail(std::string("duplicate TransformAxis '") + axis_names[a] + "'");
    seen[a] = true;
    AxisInfo& info = axes[a];
    readAxis(an, info);
    info.coordinate_names = an.child("coordinates").toWords();
  }
  fillMissingAxes(axes, seen);
}

// Formats before 10901: <TransformAxisSet> of TransformAxis with <is_rotation>, one <coordinate>,
// <axis> and a function. Rotations fill rotation1.. in order, translations translation1.., as
// OpenSim's CustomJoint::updateFromXMLNode converts them.
void OsimReader::readTransformAxisSet(const Node& set, std::array<AxisInfo, 6>& axes) {
  std::array<bool, 6> seen{};
  int next[2] = {0, 3};
  for (const Node& an : set.child("objects").children("TransformAxis")) {
    const bool rotation = an.childBool("is_rotation", false);
    int& slot = next[rotation ? 0 : 1];
    if (slot >= (rotation ? 3 : 6))
      an.fail(std::string("expected at most 3 ") + (rotation ? "rotation" : "translation") + " axes, got more");
    AxisInfo& info = axes[slot];
    seen[slot] = true;
    ++slot;
    readAxis(an, info);
    if (Node c = an.child("coordinate"); c && !c.text().empty()) info.coordinate_names = {c.text()};
  }
  fillMissingAxes(axes, seen);
}

void OsimReader::readCustomJoint(const Node& j, Joint& jt, int ji, std::vector<ParsedCoordinate>& coords) {
  static const char* const axis_names[6] = {"rotation1",    "rotation2",    "rotation3",
                                            "translation1", "translation2", "translation3"};
  std::array<AxisInfo, 6> axes;
  readCustomJointAxes(j, axes);
  // OpenSim refuses collinear rotation or translation axes (CustomJoint::extendFinalizeFromProperties).
  for (int s = 0; s <= 3; s += 3)
    for (int p = 0; p < 3; ++p)
      for (int q = p + 1; q < 3; ++q)
        if (axes[s + p].axis.normalized().cross(axes[s + q].axis.normalized()).norm() < 1e-5)
          (axes[s + q].node ? axes[s + q].node : j)
              .fail(std::string("expected independent axes, but '") + axis_names[s + q] + "' is collinear with '" +
                    axis_names[s + p] + "'");

  if (coords.empty()) {
    // OpenSim 4 builds missing coordinates from the transform, in order of first appearance.
    for (const AxisInfo& info : axes)
      for (const std::string& n : info.coordinate_names) {
        const bool have = std::any_of(coords.begin(), coords.end(),
                                      [&](const ParsedCoordinate& pc) { return pc.coord.name == n; });
        if (!have) {
          ParsedCoordinate pc;
          pc.coord.name = n;
          pc.coord.range_min = -10.0;
          pc.coord.range_max = 10.0;
          pc.node = info.node;
          coords.push_back(pc);
        }
      }
  }
  std::vector<std::string> listed;
  for (const ParsedCoordinate& pc : coords) listed.push_back(pc.coord.name);
  std::vector<int> global(coords.size());
  for (size_t k = 0; k < coords.size(); ++k) {
    global[k] = addCoordinate(coords[k], ji, jt.name);
    jt.coordinates.push_back(global[k]);
  }
  for (int a = 0; a < 6; ++a) {
    AxisInfo& info = axes[a];
    TransformAxis& ax = jt.spatial[a];
    ax.axis = info.axis;
    for (const std::string& n : info.coordinate_names) {
      auto it = std::find(listed.begin(), listed.end(), n);
      if (it == listed.end())
        info.node.child("coordinates")
            .fail("unknown coordinate '" + n + "' (expected one of the joint's coordinates: " + listNames(listed) +
                  ")");
      ax.coordinates.push_back(global[it - listed.begin()]);
    }
    const int nargs = int(ax.coordinates.size());
    if (info.function) {
      if (auto* c = dynamic_cast<const Constant*>(info.function.get()); c && nargs > 1)
        info.function = std::make_shared<Constant>(c->getValue(), nargs);
      if (nargs > 0 && info.function->getArgumentSize() != nargs)
        info.node.fail("expected a function of " + std::to_string(nargs) + " coordinates, got a " +
                       info.function->getTypeName() + " of " + std::to_string(info.function->getArgumentSize()) +
                       " argument(s)");
      ax.function = info.function;
    } else if (nargs > 1) {
      info.node.fail("expected a function of the " + std::to_string(nargs) + " coordinates, got none");
    }
  }
  // Motion types as OpenSim 4 derives them (CustomJoint::constructCoordinates): a coordinate
  // moved with slope +-1 by a LinearFunction is Rotational or Translational after that axis;
  // any other dependence makes it Coupled unless a pure axis already classified it.
  for (size_t k = 0; k < coords.size(); ++k) {
    const std::string& n = coords[k].coord.name;
    int mt = -1;  // -1 undefined, else MotionType
    for (int a = 0; a < 6; ++a) {
      const AxisInfo& info = axes[a];
      if (std::find(info.coordinate_names.begin(), info.coordinate_names.end(), n) == info.coordinate_names.end())
        continue;
      // An axis without a function moves by its coordinate itself (the identity map).
      const auto* lf = dynamic_cast<const LinearFunction*>(info.function.get());
      const bool pure = !info.function || (lf && (lf->getSlope() == 1.0 || lf->getSlope() == -1.0));
      if (pure)
        mt = int(a < 3 ? MotionType::Rotational : MotionType::Translational);
      else if (mt < 0)
        mt = int(MotionType::Coupled);
    }
    Coordinate& c = m_->coordinates[global[k]];
    if (mt >= 0) {
      c.motion_type = MotionType(mt);
    } else {
      c.motion_type = coords[k].has_file_motion ? coords[k].file_motion : MotionType::Rotational;
      m_->warnings.push_back(formatLocated(coords[k].node.where(), "coordinate '" + n + "' of joint '" + jt.name +
                                                                       "' moves no transform axis"));
    }
  }
}

/// Every body but ground must be the child of exactly one joint; say where, with a line. A joint
/// whose child is already another joint's child, from a body no joint has as child, is used from
/// its child as OpenSim's multibody graph does (Joint::reversed_in_tree).
void OsimReader::checkTree() {
  std::vector<int> parent_joint(m_->bodies.size(), -1), child_count(m_->bodies.size(), 0);
  for (const Joint& jt : m_->joints) ++child_count[jt.child_body];
  auto reversible = [&](int j) {
    const Joint& jt = m_->joints[j];
    return jt.parent_body != 0 && child_count[jt.parent_body] == 0 && !jt.reverse && !jt.reversed_in_tree &&
           jt.type != JointType::Ellipsoid && jt.type != JointType::Scapulothoracic;
  };
  auto reverseInTree = [&](int j) {
    Joint& jt = m_->joints[j];
    std::swap(jt.parent_body, jt.child_body);
    std::swap(jt.X_PF, jt.X_BM);
    jt.reversed_in_tree = true;
    child_count[jt.child_body] = 1;
    parent_joint[jt.child_body] = j;
  };
  for (size_t j = 0; j < m_->joints.size(); ++j) {
    const int c = m_->joints[j].child_body;
    if (parent_joint[c] < 0) {
      parent_joint[c] = int(j);
    } else if (reversible(int(j))) {
      reverseInTree(int(j));
    } else if (const int k = parent_joint[c]; reversible(k)) {
      parent_joint[c] = int(j);
      reverseInTree(k);
    } else {
      joint_nodes_[j].fail("body '" + m_->bodies[c].name + "' is already the child of joint '" +
                           m_->joints[parent_joint[c]].name + "'; closed loops are not supported");
    }
  }
  for (size_t b = 1; b < m_->bodies.size(); ++b)
    if (parent_joint[b] < 0)
      body_nodes_[b].fail("expected a joint connecting body '" + m_->bodies[b].name + "' to the tree, got none");
}

}  // namespace kneesim::model::osim
