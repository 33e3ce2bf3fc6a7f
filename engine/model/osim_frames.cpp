// The .osim reader's OpenSim 4.x frames: PhysicalOffsetFrames registered by path and socket paths
// resolved to a body and a pose in it.
#include "model/osim_reader_internal.hpp"

#include <map>

#include "core/error.hpp"
#include "core/strings.hpp"

namespace kneesim::model::osim {

void OsimReader::registerFrame(const Node& f, const std::string& path) {
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
void OsimReader::registerComponents(const Node& owner, const std::string& owner_path) {
  for (const Node& c : owner.child("components").children()) {
    if (c.name() == "PhysicalOffsetFrame")
      registerFrame(c, owner_path + "/" + c.nameAttr());
    else
      m_->ignored.push_back({c.name(), c.nameAttr()});
  }
}

void OsimReader::registerFrames(const Node& model_el) {
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
std::pair<int, Pose> OsimReader::resolveFrame(const std::string& ref, const std::string& owner_path, const Node& where) {
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

std::optional<FrameEntry> OsimReader::lookupFrame(const std::string& path) {
  if (path == "/ground") return FrameEntry{0, ""};
  const auto parts = splitPath(path);
  if (parts.size() == 2 && parts[0] == "bodyset") {
    auto it = body_index_.find(parts[1]);
    if (it != body_index_.end() && it->second > 0) return FrameEntry{it->second, ""};
  }
  if (frames_.count(path)) return FrameEntry{-1, path};
  return std::nullopt;
}

std::pair<int, Pose> OsimReader::resolveEntry(const FrameEntry& e, const Node& where) {
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

}  // namespace kneesim::model::osim
