// The .osim reader's OpenSim 4.x frames: PhysicalOffsetFrames, StationDefinedFrames and Stations
// registered by component path, and socket paths resolved to a body and a pose in it.
#include "model/osim_reader_internal.hpp"

#include <cctype>
#include <map>

#include "core/error.hpp"
#include "core/strings.hpp"

namespace kneesim::model::osim {

namespace {

bool isJointTag(const std::string& tag) { return endsWith(tag, "Joint"); }

/// Component tags another part of the reader takes from a <components> list.
bool isReadElsewhere(const std::string& tag) {
  return tag == "Body" || isJointTag(tag) || tag == "Marker" || tag == "PointConstraint" ||
         tag == "PointOnLineConstraint" || tag == "ConstantDistanceConstraint" || tag == "WeldConstraint" ||
         tag == "CoordinateCouplerConstraint";
}

/// OpenSim's "+x", "-y", ... (StationDefinedFrame's ab_axis and ab_x_ac_axis): axis 0..2 and sign.
bool parseDirection(const std::string& s, int& axis, double& sign) {
  std::string t(trim(s));
  sign = 1.0;
  if (!t.empty() && (t[0] == '+' || t[0] == '-')) {
    sign = t[0] == '-' ? -1.0 : 1.0;
    t = t.substr(1);
  }
  if (t.size() != 1) return false;
  const char c = char(std::tolower(static_cast<unsigned char>(t[0])));
  if (c < 'x' || c > 'z') return false;
  axis = c - 'x';
  return true;
}

}  // namespace

OffsetFrame& OsimReader::addFrameEntry(const Node& n, const std::string& path, int kind, const char* parent_socket) {
  if (frames_.count(path)) n.fail("duplicate component path '" + path + "'");
  OffsetFrame& of = frames_[path];
  of.kind = OffsetFrame::Kind(kind);
  of.node = n;
  of.path = path;
  if (!parent_socket) return of;
  of.parent_node = findSocket(n, {parent_socket});
  if (!of.parent_node || of.parent_node.text().empty())
    n.fail(std::string("expected <socket_") + parent_socket + "> naming a frame, got none");
  of.parent_ref = of.parent_node.text();
  return of;
}

void OsimReader::registerFrame(const Node& f, const std::string& path) {
  OffsetFrame& of = addFrameEntry(f, path, int(OffsetFrame::Kind::Offset), "parent");
  of.X_PF = poseFromXYZ(f.childVec3("orientation", Vec3::Zero()), f.childVec3("translation", Vec3::Zero()));
  registerComponents(f, path);
}

void OsimReader::registerStation(const Node& st, const std::string& path) {
  OffsetFrame& of = addFrameEntry(st, path, int(OffsetFrame::Kind::Station), "parent_frame");
  of.X_PF = Pose(Eigen::Translation3d(st.childVec3("location", Vec3::Zero())));
}

void OsimReader::registerStationDefinedFrame(const Node& f, const std::string& path) {
  OffsetFrame& of = addFrameEntry(f, path, int(OffsetFrame::Kind::StationDefined), nullptr);
  static const char* const sockets[4] = {"point_a", "point_b", "point_c", "origin_point"};
  for (int k = 0; k < 4; ++k) {
    of.station_nodes[k] = findSocket(f, {sockets[k]});
    if (!of.station_nodes[k] || of.station_nodes[k].text().empty())
      f.fail(std::string("expected <socket_") + sockets[k] + "> naming a Station, got none");
    of.station_refs[k] = of.station_nodes[k].text();
  }
  of.ab_axis = f.childText("ab_axis", "+x");
  of.ab_x_ac_axis = f.childText("ab_x_ac_axis", "+y");
  registerComponents(f, path);
}

// Frames and stations among a component's <components>; what the reader takes elsewhere
// (bodies, joints, markers, constraints of a model's <components>) is skipped; anything else
// there is listed as ignored.
void OsimReader::registerComponents(const Node& owner, const std::string& owner_path) {
  for (const Node& c : owner.child("components").children()) {
    const std::string tag = c.name();
    const std::string path = owner_path + "/" + c.nameAttr();
    if (tag == "PhysicalOffsetFrame")
      registerFrame(c, path);
    else if (tag == "Station")
      registerStation(c, path);
    else if (tag == "StationDefinedFrame")
      registerStationDefinedFrame(c, path);
    else if (!isReadElsewhere(tag))
      ignore(c, "components");
  }
}

void OsimReader::registerFrames(const Node& model_el) {
  registerComponents(model_el, "");
  if (Node g = model_el.child("Ground")) registerComponents(g, "/ground");
  for (const auto& [path, b] : body_paths_)
    if (b > 0) registerComponents(body_nodes_[b], path);
  for (const Node& j : model_el.child("JointSet").child("objects").children())
    joint_elements_.push_back({j, "/jointset/" + j.nameAttr()});
  for (const Node& j : model_el.child("components").children())
    if (isJointTag(j.name())) joint_elements_.push_back({j, "/" + j.nameAttr()});
  for (const JointElement& je : joint_elements_) {
    for (const Node& f : je.node.child("frames").children()) {
      if (f.name() == "PhysicalOffsetFrame")
        registerFrame(f, je.path + "/" + f.nameAttr());
      else if (f.name() == "StationDefinedFrame")
        registerStationDefinedFrame(f, je.path + "/" + f.nameAttr());
      else
        f.fail("expected <PhysicalOffsetFrame> or <StationDefinedFrame>, got <" + f.name() + ">");
    }
    registerComponents(je.node, je.path);
  }
  // WeldConstraints (TwoFrameLinkers) own the frames they link.
  for (const Node& c : model_el.child("ConstraintSet").child("objects").children())
    for (const Node& f : c.child("frames").children("PhysicalOffsetFrame"))
      registerFrame(f, "/constraintset/" + c.nameAttr() + "/" + f.nameAttr());
  for (const Node& c : model_el.child("components").children("WeldConstraint"))
    for (const Node& f : c.child("frames").children("PhysicalOffsetFrame"))
      registerFrame(f, "/" + c.nameAttr() + "/" + f.nameAttr());
  for (const Node& c : model_el.child("ComponentSet").child("objects").children()) {
    if (c.name() == "PhysicalOffsetFrame") registerFrame(c, "/componentset/" + c.nameAttr());
    if (c.name() == "Station") registerStation(c, "/componentset/" + c.nameAttr());
    if (c.name() == "StationDefinedFrame") registerStationDefinedFrame(c, "/componentset/" + c.nameAttr());
  }
}

std::pair<int, Pose> OsimReader::resolveFrame(const std::string& ref, const std::string& owner_path, const Node& where) {
  const std::string path = joinPath(splitPath(startsWith(ref, "/") ? ref : owner_path + "/" + ref));
  if (auto r = lookupFrame(path)) return resolveEntry(*r, where);
  // OpenSim 4.0 pre-releases (30501-30516) wrote connectee names relative to other owners
  // ("../rod1", "rod1"); accept a unique match by name.
  const std::vector<std::string> parts = splitPath(ref);
  if (!parts.empty()) {
    std::vector<std::string> matches;
    const std::string& last = parts.back();
    for (const auto& kv : body_paths_) {
      const auto bp = splitPath(kv.first);
      if (!bp.empty() && bp.back() == last) matches.push_back(kv.first);
    }
    for (const auto& kv : frames_) {
      const auto fp = splitPath(kv.first);
      if (!fp.empty() && fp.back() == last) matches.push_back(kv.first);
    }
    if (matches.size() == 1) return resolveEntry(*lookupFrame(matches[0]), where);
    if (matches.size() > 1) where.fail("frame '" + ref + "' is ambiguous (matches " + listNames(matches) + ")");
  }
  where.fail("unknown frame '" + ref +
             "' (expected /ground, /bodyset/<body> or the path of a PhysicalOffsetFrame, StationDefinedFrame or "
             "Station)");
}

std::optional<FrameEntry> OsimReader::lookupFrame(const std::string& path) {
  if (auto it = body_paths_.find(path); it != body_paths_.end()) return FrameEntry{it->second, ""};
  if (frames_.count(path)) return FrameEntry{-1, path};
  return std::nullopt;
}

std::pair<int, Pose> OsimReader::resolveEntry(const FrameEntry& e, const Node& where) {
  if (e.body >= 0) return {e.body, Pose::Identity()};
  OffsetFrame& f = frames_.at(e.offset_path);
  if (f.state == 2) return {f.body, f.X_BF};
  if (f.state == 1) where.fail("frame '" + f.path + "' is its own ancestor (a cycle of sockets)");
  f.state = 1;
  if (f.kind == OffsetFrame::Kind::StationDefined) {
    resolveStationDefined(f);
  } else {
    const auto parent = resolveFrame(f.parent_ref, f.path, f.parent_node);
    f.body = parent.first;
    f.X_BF = parent.second * f.X_PF;
  }
  f.state = 2;
  return {f.body, f.X_BF};
}

// OpenSim's StationDefinedFrame (4.5): ab = unit(b - a), ab_x_ac = unit(ab x (c - a)),
// ab_x_ab_x_ac = ab x ab_x_ac; they become the frame axes that ab_axis and ab_x_ac_axis name
// (default +x and +y, the third axis being their cross product); the origin is origin_point.
void OsimReader::resolveStationDefined(OffsetFrame& f) {
  Vec3 p[4];
  int body = -1;
  for (int k = 0; k < 4; ++k) {
    const auto r = resolveFrame(f.station_refs[k], f.path, f.station_nodes[k]);
    if (k > 0 && r.first != body)
      f.station_nodes[k].fail("expected the stations of a StationDefinedFrame on one body, got '" +
                               m_->bodies[r.first].name + "' and '" + m_->bodies[body].name + "'");
    body = r.first;
    p[k] = r.second.translation();
  }
  const Vec3 ab = p[1] - p[0], ac = p[2] - p[0];
  if (ab.norm() < 1e-12 || ac.norm() < 1e-12 || ab.cross(ac).norm() < 1e-12 * ab.norm() * ac.norm())
    f.node.fail("expected point_a, point_b and point_c to form a triangle, got collinear or coincident points");
  const Vec3 e0 = ab.normalized();
  const Vec3 e1 = e0.cross(ac).normalized();
  const Vec3 e2 = e0.cross(e1);
  int a0 = 0, a1 = 1;
  double s0 = 1, s1 = 1;
  if (!parseDirection(f.ab_axis, a0, s0)) f.node.child("ab_axis").fail("expected +x, -x, +y, -y, +z or -z, got '" + f.ab_axis + "'");
  if (!parseDirection(f.ab_x_ac_axis, a1, s1))
    f.node.child("ab_x_ac_axis").fail("expected +x, -x, +y, -y, +z or -z, got '" + f.ab_x_ac_axis + "'");
  if (a0 == a1) {
    // OpenSim falls back to the next axis with a warning; so does kneesim.
    m_->warnings.push_back(formatLocated(f.node.where(), "ab_x_ac_axis '" + f.ab_x_ac_axis + "' is parallel to ab_axis '" +
                                                             f.ab_axis + "': the next axis is used"));
    a1 = (a0 + 1) % 3;
    s1 = 1;
  }
  const int a2 = 3 - a0 - a1;
  const double s2 = ((a1 - a0 + 3) % 3 == 1 ? 1.0 : -1.0) * s0 * s1;  // sign of axis(a0) x axis(a1)
  Mat3 R;
  R.col(a0) = s0 * e0;
  R.col(a1) = s1 * e1;
  R.col(a2) = s2 * e2;
  f.body = body;
  f.X_BF = Pose::Identity();
  f.X_BF.linear() = R;
  f.X_BF.translation() = p[3];
}

}  // namespace kneesim::model::osim
