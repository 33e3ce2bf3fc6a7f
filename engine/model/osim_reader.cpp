#include "model/osim_reader.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <unordered_map>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"

namespace kneesim::model {

namespace {

using xml::Node;

const char* const kJointTypes =
    "WeldJoint, PinJoint, SliderJoint, BallJoint, FreeJoint, UniversalJoint, GimbalJoint, PlanarJoint or CustomJoint";
const char* const kFunctionTypes =
    "Constant, LinearFunction, PolynomialFunction, SimmSpline, NaturalCubicSpline, PiecewiseLinearFunction or "
    "MultiplierFunction";

bool isFunctionTag(const std::string& t) {
  static const std::set<std::string> tags = {"Constant",           "LinearFunction",          "PolynomialFunction",
                                             "SimmSpline",         "NaturalCubicSpline",      "natCubicSpline",
                                             "PiecewiseLinearFunction", "MultiplierFunction"};
  return tags.count(t) > 0;
}

std::string listNames(const std::vector<std::string>& names, size_t max_names = 12) {
  std::string out;
  for (size_t i = 0; i < names.size() && i < max_names; ++i) out += (i ? ", " : "") + names[i];
  if (names.size() > max_names) out += ", ... (" + std::to_string(names.size()) + " in all)";
  return out.empty() ? "none" : out;
}

/// The element holding an object-valued property: either a wrapper <property><Type/></property>
/// (OpenSim 3.x) or a child <Type name="property"/> (OpenSim 4.x). Children whose tags are in
/// @p others are other properties of the owner. Returns a null Node when the property is absent
/// or empty.
Node findObjectProperty(const Node& owner, const char* property, std::initializer_list<const char*> others) {
  if (Node w = owner.child(property)) {
    const auto kids = w.children();
    if (kids.size() > 1) w.fail("expected one function, got " + std::to_string(kids.size()) + " elements");
    return kids.empty() ? Node() : kids[0];
  }
  for (const Node& c : owner.children()) {
    const std::string tag = c.name();
    bool other = false;
    for (const char* o : others) other = other || tag == o;
    if (other) continue;
    if (c.nameAttr() == property || isFunctionTag(tag)) return c;
  }
  return Node();
}

std::vector<double> requireDoubles(const Node& owner, const char* tag) {
  Node c = owner.requireChild(tag);
  return c.toDoubles();
}

FunctionPtr parseFunction(const Node& el) {
  const std::string tag = el.name();
  if (tag == "Constant") return makeConstant(el.childDouble("value", 0.0));
  if (tag == "LinearFunction") {
    std::vector<double> c{1.0, 0.0};
    if (Node n = el.child("coefficients"); n && !n.text().empty()) c = n.toDoubles();
    if (c.size() != 2)
      el.child("coefficients").fail("expected 2 coefficients (slope intercept), got " + std::to_string(c.size()));
    return makeLinear(c[0], c[1]);
  }
  if (tag == "PolynomialFunction") {
    std::vector<double> c = requireDoubles(el, "coefficients");
    if (c.empty()) el.child("coefficients").fail("expected at least 1 coefficient, got 0");
    return makePolynomial(std::move(c));
  }
  if (tag == "SimmSpline" || tag == "NaturalCubicSpline" || tag == "natCubicSpline" ||
      tag == "PiecewiseLinearFunction") {
    std::vector<double> x = requireDoubles(el, "x");
    std::vector<double> y = requireDoubles(el, "y");
    const std::string problem = checkKnots(x, y);
    if (!problem.empty()) el.fail(problem);
    if (tag == "PiecewiseLinearFunction") return makePiecewiseLinear(std::move(x), std::move(y));
    if (tag == "NaturalCubicSpline") return makeNaturalCubicSpline(std::move(x), std::move(y));
    return makeSimmSpline(std::move(x), std::move(y));
  }
  if (tag == "MultiplierFunction") {
    Node inner = findObjectProperty(el, "function", {"scale"});
    if (!inner) el.fail("expected a function to scale, got none");
    return makeMultiplier(parseFunction(inner), el.childDouble("scale", 1.0));
  }
  el.fail("unknown function type '" + tag + "' (expected " + kFunctionTypes + ")");
}

/// OpenSim's "rX rY rZ tx ty tz" transform (body-fixed XYZ angles, then a translation).
Pose parseSixTransform(const Node& n) {
  const std::vector<double> v = n.toDoubles();
  if (v.size() != 6) n.fail("expected 6 numbers (rX rY rZ tx ty tz), got " + std::to_string(v.size()));
  return poseFromXYZ(Vec3(v[0], v[1], v[2]), Vec3(v[3], v[4], v[5]));
}

/// Splits a component path into its names, resolving "." and "..".
std::vector<std::string> splitPath(const std::string& path) {
  std::vector<std::string> out;
  for (auto part : splitOn(path, '/')) {
    if (part.empty() || part == ".") continue;
    if (part == "..") {
      if (!out.empty()) out.pop_back();
      continue;
    }
    out.emplace_back(part);
  }
  return out;
}

std::string joinPath(const std::vector<std::string>& parts) {
  std::string out;
  for (const auto& p : parts) out += "/" + p;
  return out.empty() ? "/" : out;
}

struct ParsedCoordinate {
  Coordinate coord;
  Node node;
  bool has_file_motion = false;
  MotionType file_motion = MotionType::Rotational;
};

struct AxisInfo {
  Node node;
  std::vector<std::string> coordinate_names;
  Vec3 axis = Vec3::UnitX();
  FunctionPtr function;  // null when the file gives none
};

/// A PhysicalOffsetFrame (OpenSim 4.x), resolved lazily to a body and a pose in that body.
struct OffsetFrame {
  Node node;
  std::string path;        // absolute component path of the frame
  std::string parent_ref;  // socket_parent as written
  Pose X_PF = Pose::Identity();
  int state = 0;  // 0 unresolved, 1 being resolved, 2 resolved
  int body = -1;
  Pose X_BF = Pose::Identity();
};

class OsimReader {
 public:
  OsimReader(const xml::Document& doc, const std::string& label) : doc_(doc), label_(label) {
    folder_ = std::filesystem::path(label).parent_path().string();
  }

  std::shared_ptr<Model> read() {
    Node root = doc_.root();
    Node model_el;
    // OpenSim takes a document without a version for its oldest layout (XMLDocument: 10500).
    m_->format_version = 10500;
    if (root.name() == "OpenSimDocument") {
      if (auto v = root.attr("Version")) {
        double d;
        if (!tryParseDouble(*v, d)) root.fail("expected a numeric Version attribute, got '" + *v + "'");
        m_->format_version = int(d);
      }
      model_el = root.requireChild("Model");
    } else if (root.name() == "Model") {
      model_el = root;  // very old files have no OpenSimDocument wrapper
    } else {
      root.fail("expected an OpenSim model (<OpenSimDocument> or <Model>), got <" + root.name() + ">");
    }
    m_->name = model_el.nameAttr();
    m_->source_file = label_;
    m_->gravity = model_el.childVec3("gravity", m_->gravity);
    if (Node u = model_el.child("length_units")) {
      const std::string units = toLower(u.text());
      if (!units.empty() && units != "meters" && units != "meter" && units != "m" && units != "metres")
        m_->warnings.push_back(formatLocated(u.where(), "length_units '" + u.text() +
                                                            "' ignored: OpenSim reads every length in the file as metres"));
    }

    const bool v4 = bool(model_el.child("JointSet"));
    readBodies(model_el, v4);
    if (v4) {
      registerFrames(model_el);
      readJointSet(model_el);
      attachMeshes4();
    } else {
      for (const auto& pj : pending_joints_) readJoint(pj.first, pj.second, /*v4=*/false);
    }
    checkTree();
    readConstraints(model_el);
    readMarkers(model_el, v4);
    readIgnoredSets(model_el);

    try {
      m_->finalize();
    } catch (const std::invalid_argument& e) {
      throw InputError({label_, 0, ""}, e.what());
    }
    return m_;
  }

 private:
  // ----------------------------------------------------------------------------- bodies
  void readBodies(const Node& model_el, bool v4) {
    Body ground;
    ground.name = "ground";
    m_->bodies.push_back(ground);
    body_nodes_.push_back(Node());
    body_index_["ground"] = 0;
    if (Node g = model_el.child("Ground")) {
      body_nodes_[0] = g;
      readWrapObjects(g);
    }
    Node set = model_el.requireChild("BodySet");
    bool ground_seen = v4;
    for (const Node& b : set.child("objects").children()) {
      if (b.name() != "Body") {
        m_->ignored.push_back({b.name(), b.nameAttr()});
        continue;
      }
      const std::string name = b.nameAttr();
      if (name.empty()) b.fail("expected a name attribute on <Body>, got none");
      int index;
      if (name == "ground" && !v4) {
        if (ground_seen) b.fail("duplicate body name 'ground'");
        ground_seen = true;
        index = 0;
        body_nodes_[0] = b;
      } else {
        if (body_index_.count(name)) b.fail("duplicate body name '" + name + "'");
        index = int(m_->bodies.size());
        m_->bodies.emplace_back();
        body_nodes_.push_back(b);
        body_index_[name] = index;
      }
      Body& body = m_->bodies[index];
      body.name = name;
      if (index > 0) {
        body.mass = b.childDouble("mass", 0.0);
        if (!std::isfinite(body.mass) || body.mass < 0)
          b.child("mass").fail("expected a non-negative mass, got " + b.childText("mass"));
        body.mass_center = b.childVec3("mass_center", Vec3::Zero());
        body.inertia = readInertia(b);
      }
      readWrapObjects(b);
      if (!v4) {
        readMeshes3(b, index);
        Node jw = b.child("Joint");
        std::vector<Node> kids = jw ? jw.children() : std::vector<Node>();
        if (kids.size() > 1) jw.fail("expected one joint in <Joint>, got " + std::to_string(kids.size()));
        if (index == 0) {
          if (!kids.empty()) kids[0].fail("expected no joint on ground, got <" + kids[0].name() + ">");
        } else {
          if (kids.empty())
            b.fail("expected a joint connecting body '" + name + "' to its parent, got " +
                   (jw ? "an empty <Joint>" : "no <Joint>"));
          pending_joints_.emplace_back(kids[0], index);
        }
      }
    }
    if (!ground_seen) set.fail("expected a body named 'ground', got none");
  }

  Mat3 readInertia(const Node& b) {
    Mat3 I = Mat3::Zero();
    if (Node n = b.child("inertia"); n && !n.text().empty()) {
      const std::vector<double> v = n.toDoubles();
      if (v.size() != 6) n.fail("expected 6 numbers (Ixx Iyy Izz Ixy Ixz Iyz), got " + std::to_string(v.size()));
      I << v[0], v[3], v[4], v[3], v[1], v[5], v[4], v[5], v[2];
    } else {
      const double xx = b.childDouble("inertia_xx", 0), yy = b.childDouble("inertia_yy", 0),
                   zz = b.childDouble("inertia_zz", 0), xy = b.childDouble("inertia_xy", 0),
                   xz = b.childDouble("inertia_xz", 0), yz = b.childDouble("inertia_yz", 0);
      I << xx, xy, xz, xy, yy, yz, xz, yz, zz;
    }
    if (!I.allFinite()) b.fail("expected finite inertia values");
    return I;
  }

  void readWrapObjects(const Node& b) {
    for (const Node& w : b.child("WrapObjectSet").child("objects").children())
      m_->ignored.push_back({w.name(), w.nameAttr()});
  }

  void addMesh(int body, const Node& where, const std::string& file, const Vec3& scale, const Pose& X_BG) {
    if (file.empty()) return;
    MeshRef mesh;
    mesh.file = file;
    mesh.scale = scale;
    mesh.X_BG = X_BG;
    mesh.resolved_path = findMeshFile(file, folder_);
    if (mesh.resolved_path.empty())
      m_->warnings.push_back(formatLocated(where.where(), "mesh file '" + file + "' of body '" +
                                                              m_->bodies[body].name +
                                                              "' not found next to the model or in Geometry/"));
    m_->bodies[body].meshes.push_back(std::move(mesh));
  }

  // OpenSim 2.x/3.x: VisibleObject with a GeometrySet of DisplayGeometry, or geometry_files.
  void readMeshes3(const Node& b, int body) {
    Node vis = b.child("VisibleObject");
    if (!vis) return;
    Pose X_BV = Pose::Identity();
    if (Node t = vis.child("transform"); t && !t.text().empty()) X_BV = parseSixTransform(t);
    const Vec3 vis_scale = vis.childVec3("scale_factors", Vec3::Ones());
    for (const Node& g : vis.child("GeometrySet").child("objects").children("DisplayGeometry")) {
      Pose X_VG = Pose::Identity();
      if (Node t = g.child("transform"); t && !t.text().empty()) X_VG = parseSixTransform(t);
      const Vec3 scale = vis_scale.cwiseProduct(g.childVec3("scale_factors", Vec3::Ones()));
      addMesh(body, g, g.childText("geometry_file"), scale, X_BV * X_VG);
    }
    if (Node files = vis.child("geometry_files"))
      for (const std::string& f : files.toWords()) addMesh(body, files, f, vis_scale, X_BV);
  }

  // OpenSim 4.x: attached_geometry of a frame at @p owner_path; only Mesh matters, other
  // shapes are display only. A Mesh's socket_frame, when it names another frame, wins.
  void readMeshes4(const Node& frame, const std::string& owner_path, int body, const Pose& X_BF) {
    for (const Node& g : frame.child("attached_geometry").children("Mesh")) {
      int b = body;
      Pose X = X_BF;
      if (Node sf = g.child("socket_frame"); sf && !sf.text().empty() && sf.text() != "..") {
        const auto r = resolveFrame(sf.text(), owner_path + "/" + g.nameAttr(), sf);
        b = r.first;
        X = r.second;
      }
      addMesh(b, g, g.childText("mesh_file"), g.childVec3("scale_factors", Vec3::Ones()), X);
    }
  }

  // ----------------------------------------------------------------------------- frames (4.x)
  void registerFrame(const Node& f, const std::string& path) {
    if (frames_.count(path)) f.fail("duplicate frame path '" + path + "'");
    OffsetFrame of;
    of.node = f;
    of.path = path;
    of.parent_ref = f.requireChild("socket_parent").text();
    if (of.parent_ref.empty()) f.child("socket_parent").fail("expected the path of a parent frame, got nothing");
    of.X_PF = poseFromXYZ(f.childVec3("orientation", Vec3::Zero()), f.childVec3("translation", Vec3::Zero()));
    frames_[path] = of;
    registerComponents(f, path);
  }

  // PhysicalOffsetFrames among a component's <components>; anything else there is ignored.
  void registerComponents(const Node& owner, const std::string& owner_path) {
    for (const Node& c : owner.child("components").children()) {
      if (c.name() == "PhysicalOffsetFrame")
        registerFrame(c, owner_path + "/" + c.nameAttr());
      else
        m_->ignored.push_back({c.name(), c.nameAttr()});
    }
  }

  void registerFrames(const Node& model_el) {
    registerComponents(model_el, "");
    if (Node g = model_el.child("Ground")) registerComponents(g, "/ground");
    for (size_t b = 1; b < m_->bodies.size(); ++b) registerComponents(body_nodes_[b], "/bodyset/" + m_->bodies[b].name);
    for (const Node& j : model_el.child("JointSet").child("objects").children())
      for (const Node& f : j.child("frames").children()) {
        if (f.name() != "PhysicalOffsetFrame") f.fail("expected <PhysicalOffsetFrame>, got <" + f.name() + ">");
        registerFrame(f, "/jointset/" + j.nameAttr() + "/" + f.nameAttr());
      }
    for (const Node& c : model_el.child("ComponentSet").child("objects").children())
      if (c.name() == "PhysicalOffsetFrame") registerFrame(c, "/componentset/" + c.nameAttr());
  }

  /// Resolves the frame named by @p ref (absolute, or relative to the component at
  /// @p owner_path) to a body and the frame's pose in it.
  std::pair<int, Pose> resolveFrame(const std::string& ref, const std::string& owner_path, const Node& where) {
    const std::string path =
        joinPath(splitPath(startsWith(ref, "/") ? ref : owner_path + "/" + ref));
    if (auto r = lookupFrame(path)) return resolveEntry(*r, where);
    // OpenSim 4.0 pre-releases wrote paths in other forms; accept a unique match by name.
    const std::vector<std::string> parts = splitPath(ref);
    if (!parts.empty()) {
      std::vector<std::string> matches;
      const std::string& last = parts.back();
      if (last == "ground") matches.push_back("/ground");
      if (body_index_.count(last) && last != "ground") matches.push_back("/bodyset/" + last);
      for (const auto& kv : frames_) {
        const auto fp = splitPath(kv.first);
        if (!fp.empty() && fp.back() == last) matches.push_back(kv.first);
      }
      if (matches.size() == 1) return resolveEntry(*lookupFrame(matches[0]), where);
      if (matches.size() > 1)
        where.fail("frame '" + ref + "' is ambiguous (matches " + listNames(matches) + ")");
    }
    where.fail("unknown frame '" + ref + "' (expected /ground, /bodyset/<body> or the path of a PhysicalOffsetFrame)");
  }

  struct FrameEntry {
    int body = -1;             // >= 0 for ground and bodies
    std::string offset_path;   // non-empty for offset frames
  };

  std::optional<FrameEntry> lookupFrame(const std::string& path) {
    if (path == "/ground") return FrameEntry{0, ""};
    const auto parts = splitPath(path);
    if (parts.size() == 2 && parts[0] == "bodyset") {
      auto it = body_index_.find(parts[1]);
      if (it != body_index_.end() && it->second > 0) return FrameEntry{it->second, ""};
    }
    if (frames_.count(path)) return FrameEntry{-1, path};
    return std::nullopt;
  }

  std::pair<int, Pose> resolveEntry(const FrameEntry& e, const Node& where) {
    if (e.body >= 0) return {e.body, Pose::Identity()};
    OffsetFrame& f = frames_.at(e.offset_path);
    if (f.state == 2) return {f.body, f.X_BF};
    if (f.state == 1) where.fail("frame '" + f.path + "' is its own ancestor (a cycle of socket_parent)");
    f.state = 1;
    const auto parent = resolveFrame(f.parent_ref, f.path, f.node.child("socket_parent"));
    f.body = parent.first;
    f.X_BF = parent.second * f.X_PF;
    f.state = 2;
    return {f.body, f.X_BF};
  }

  void attachMeshes4() {
    if (body_nodes_[0]) readMeshes4(body_nodes_[0], "/ground", 0, Pose::Identity());
    for (size_t b = 1; b < m_->bodies.size(); ++b)
      readMeshes4(body_nodes_[b], "/bodyset/" + m_->bodies[b].name, int(b), Pose::Identity());
    for (auto& kv : frames_) {
      OffsetFrame& f = kv.second;
      if (!f.node.child("attached_geometry")) continue;
      const auto r = resolveEntry(FrameEntry{-1, kv.first}, f.node);
      readMeshes4(f.node, kv.first, r.first, r.second);
    }
  }

  // ----------------------------------------------------------------------------- joints
  void readJointSet(const Node& model_el) {
    for (const Node& j : model_el.child("JointSet").child("objects").children()) {
      const std::string path = "/jointset/" + j.nameAttr();
      Node pf = j.requireChild("socket_parent_frame"), cf = j.requireChild("socket_child_frame");
      const auto parent = resolveFrame(pf.text(), path, pf);
      const auto child = resolveFrame(cf.text(), path, cf);
      if (child.first == 0) cf.fail("expected a child frame on a body, got ground ('" + cf.text() + "')");
      if (child.first == parent.first)
        cf.fail("expected parent and child frames on different bodies, both are on '" +
                m_->bodies[child.first].name + "'");
      const int ji = readJoint(j, child.first, /*v4=*/true);
      m_->joints[ji].parent_body = parent.first;
      m_->joints[ji].X_PF = parent.second;
      m_->joints[ji].X_BM = child.second;
    }
  }

  std::vector<ParsedCoordinate> readJointCoordinates(const Node& j) {
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

  int addCoordinate(const ParsedCoordinate& pc, int joint) {
    if (coord_index_.count(pc.coord.name)) pc.node.fail("duplicate coordinate name '" + pc.coord.name + "'");
    const int ci = int(m_->coordinates.size());
    m_->coordinates.push_back(pc.coord);
    m_->coordinates.back().joint = joint;
    coord_index_[pc.coord.name] = ci;
    return ci;
  }

  /// Reads one joint element whose child body is @p child; returns its index in Model::joints.
  int readJoint(const Node& j, int child, bool v4) {
    const std::string type = j.name();
    const std::string name = j.nameAttr();
    if (name.empty()) j.fail("expected a name attribute on <" + type + ">, got none");
    if (joint_names_.count(name)) j.fail("duplicate joint name '" + name + "'");
    joint_names_.insert(name);
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
      jt.X_PF = poseFromXYZ(j.childVec3("orientation_in_parent", Vec3::Zero()),
                            j.childVec3("location_in_parent", Vec3::Zero()));
      jt.X_BM = poseFromXYZ(j.childVec3("orientation", Vec3::Zero()), j.childVec3("location", Vec3::Zero()));
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
        const int ci = addCoordinate(coords[k], ji);
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
        const int ci = addCoordinate(coords[k], ji);
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
    if (type == "EllipsoidJoint" || type == "ScapulothoracicJoint" || type == "ConstantCurvatureJoint")
      j.fail("unsupported joint type '" + type + "' (expected " + kJointTypes + ")");
    j.fail("unknown joint type '" + type + "' (expected " + kJointTypes + ")");
  }

  void readCustomJoint(const Node& j, Joint& jt, int ji, std::vector<ParsedCoordinate>& coords) {
    Node st = j.requireChild("SpatialTransform");
    static const char* const axis_names[6] = {"rotation1",    "rotation2",    "rotation3",
                                              "translation1", "translation2", "translation3"};
    std::array<AxisInfo, 6> axes;
    std::array<bool, 6> seen{};
    const std::vector<Node> axis_nodes = st.children("TransformAxis");
    for (size_t k = 0; k < axis_nodes.size(); ++k) {
      const Node& an = axis_nodes[k];
      int a = -1;
      const std::string an_name = an.nameAttr();
      for (int i = 0; i < 6; ++i)
        if (an_name == axis_names[i]) a = i;
      if (a < 0) {
        if (!an_name.empty())
          an.fail("expected a TransformAxis named rotation1..3 or translation1..3, got '" + an_name + "'");
        if (k >= 6) an.fail("expected 6 TransformAxis elements, got more");
        a = int(k);
      }
      if (seen[a]) an.fail(std::string("duplicate TransformAxis '") + axis_names[a] + "'");
      seen[a] = true;
      AxisInfo& info = axes[a];
      info.node = an;
      info.coordinate_names = an.child("coordinates").toWords();
      Node ax = an.requireChild("axis");
      info.axis = ax.toVec3();
      if (!(info.axis.norm() > 1e-12)) ax.fail("expected a non-zero axis, got '" + ax.text() + "'");
      if (Node fn = findObjectProperty(an, "function", {"coordinates", "axis", "is_rotation", "coordinate"}))
        info.function = parseFunction(fn);
    }
    for (int a = 0; a < 6; ++a)
      if (!seen[a]) st.fail(std::string("expected 6 TransformAxis elements, missing '") + axis_names[a] + "'");
    // OpenSim refuses collinear rotation or translation axes (CustomJoint::extendFinalizeFromProperties).
    for (int s = 0; s <= 3; s += 3)
      for (int p = 0; p < 3; ++p)
        for (int q = p + 1; q < 3; ++q)
          if (axes[s + p].axis.normalized().cross(axes[s + q].axis.normalized()).norm() < 1e-5)
            axes[s + q].node.fail(std::string("expected independent axes, but '") + axis_names[s + q] +
                                  "' is collinear with '" + axis_names[s + p] + "'");

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
      global[k] = addCoordinate(coords[k], ji);
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

  /// Every body but ground must be the child of exactly one joint; say where, with a line.
  void checkTree() {
    std::vector<int> parent_joint(m_->bodies.size(), -1);
    for (size_t j = 0; j < m_->joints.size(); ++j) {
      const int c = m_->joints[j].child_body;
      if (parent_joint[c] >= 0)
        joint_nodes_[j].fail("body '" + m_->bodies[c].name + "' is already the child of joint '" +
                             m_->joints[parent_joint[c]].name + "'; closed loops are not supported");
      parent_joint[c] = int(j);
    }
    for (size_t b = 1; b < m_->bodies.size(); ++b)
      if (parent_joint[b] < 0)
        body_nodes_[b].fail("expected a joint connecting body '" + m_->bodies[b].name + "' to the tree, got none");
  }

  // ----------------------------------------------------------------------------- constraints
  int requireCoordinate(const Node& where, const std::string& n) {
    auto it = coord_index_.find(n);
    if (it == coord_index_.end()) {
      std::vector<std::string> names;
      for (const Coordinate& c : m_->coordinates) names.push_back(c.name);
      where.fail("unknown coordinate '" + n + "' (expected one of " + listNames(names) + ")");
    }
    return it->second;
  }

  void readConstraints(const Node& model_el) {
    for (const Node& c : model_el.child("ConstraintSet").child("objects").children()) {
      if (c.name() != "CoordinateCouplerConstraint") {
        m_->ignored.push_back({c.name(), c.nameAttr()});
        continue;
      }
      const bool disabled = c.childBool("isDisabled", false) || !c.childBool("isEnforced", true);
      if (disabled) {
        m_->ignored.push_back({"CoordinateCouplerConstraint (disabled)", c.nameAttr()});
        continue;
      }
      CoordinateCoupler cc;
      cc.name = c.nameAttr();
      Node ind = c.requireChild("independent_coordinate_names");
      for (const std::string& n : ind.toWords()) cc.independents.push_back(requireCoordinate(ind, n));
      if (cc.independents.empty()) ind.fail("expected at least one independent coordinate, got none");
      Node dep = c.requireChild("dependent_coordinate_name");
      cc.dependent = requireCoordinate(dep, dep.text());
      for (int i : cc.independents)
        if (i == cc.dependent) dep.fail("expected the dependent coordinate to differ from the independent ones");
      Node fn = findObjectProperty(c, "coupled_coordinates_function",
                                   {"isDisabled", "isEnforced", "independent_coordinate_names",
                                    "dependent_coordinate_name", "scale_factor"});
      if (!fn) c.fail("expected a coupled_coordinates_function, got none");
      cc.function = parseFunction(fn);
      if (auto* k = dynamic_cast<const Constant*>(cc.function.get()); k && cc.independents.size() > 1)
        cc.function = std::make_shared<Constant>(k->getValue(), int(cc.independents.size()));
      if (cc.function->getArgumentSize() != int(cc.independents.size()))
        fn.fail("expected a function of " + std::to_string(cc.independents.size()) + " coordinates, got a " +
                cc.function->getTypeName() + " of " + std::to_string(cc.function->getArgumentSize()) +
                " argument(s)");
      cc.scale_factor = c.childDouble("scale_factor", 1.0);
      m_->couplers.push_back(std::move(cc));
    }
  }

  // ----------------------------------------------------------------------------- markers
  void readMarkers(const Node& model_el, bool v4) {
    std::set<std::string> names;
    for (const Node& mk : model_el.child("MarkerSet").child("objects").children()) {
      if (mk.name() != "Marker") {
        m_->ignored.push_back({mk.name(), mk.nameAttr()});
        continue;
      }
      Marker marker;
      marker.name = mk.nameAttr();
      if (marker.name.empty()) mk.fail("expected a name attribute on <Marker>, got none");
      if (!names.insert(marker.name).second) mk.fail("duplicate marker name '" + marker.name + "'");
      const Vec3 location = mk.childVec3("location", Vec3::Zero());
      if (Node pf = mk.child("socket_parent_frame"); pf && v4) {
        const auto frame = resolveFrame(pf.text(), "/markerset/" + marker.name, pf);
        marker.body = frame.first;
        marker.p_BM = frame.second * location;  // offset frames are expressed in the body frame
      } else {
        Node b = mk.requireChild("body");
        auto it = body_index_.find(b.text());
        if (it == body_index_.end()) {
          std::vector<std::string> bn;
          for (const Body& body : m_->bodies) bn.push_back(body.name);
          b.fail("unknown body '" + b.text() + "' (expected one of " + listNames(bn) + ")");
        }
        marker.body = it->second;
        marker.p_BM = location;
      }
      marker.fixed = mk.childBool("fixed", false);
      m_->markers.push_back(std::move(marker));
    }
  }

  // ----------------------------------------------------------------------------- the rest
  void readIgnoredSets(const Node& model_el) {
    static const std::set<std::string> handled = {"BodySet", "JointSet", "ConstraintSet", "MarkerSet"};
    for (const Node& s : model_el.children()) {
      const std::string tag = s.name();
      if (!endsWith(tag, "Set") || handled.count(tag)) continue;
      for (const Node& o : s.child("objects").children()) {
        if (tag == "ComponentSet" && o.name() == "PhysicalOffsetFrame") continue;
        m_->ignored.push_back({o.name(), o.nameAttr()});
      }
    }
  }

  const xml::Document& doc_;
  std::string label_;
  std::string folder_;
  std::shared_ptr<Model> m_ = std::make_shared<Model>();
  std::vector<Node> body_nodes_;
  std::unordered_map<std::string, int> body_index_;
  std::unordered_map<std::string, int> coord_index_;
  std::set<std::string> joint_names_;
  std::vector<Node> joint_nodes_;  // parallel to Model::joints until finalize()
  std::vector<std::pair<Node, int>> pending_joints_;
  std::map<std::string, OffsetFrame> frames_;
};

}  // namespace

ModelPtr parseOsim(const std::string& text, const std::string& label) {
  const auto doc = xml::Document::parse(text, label);
  OsimReader reader(*doc, label);
  return reader.read();
}

ModelPtr readOsim(const std::string& path) { return parseOsim(readFileText(path), path); }

}  // namespace kneesim::model
