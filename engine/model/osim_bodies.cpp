// The .osim reader's bodies: mass properties, the joints nested in 3.x bodies, display meshes of
// both layouts.
#include "model/osim_reader_internal.hpp"

#include <cmath>

#include "core/error.hpp"
#include "core/strings.hpp"

namespace kneesim::model::osim {

void OsimReader::readBodies(const Node& model_el, bool v4) {
  Body ground;
  ground.name = "ground";
  m_->bodies.push_back(ground);
  body_nodes_.push_back(Node());
  body_index_["ground"] = 0;
  body_paths_["/ground"] = 0;
  if (Node g = model_el.child("Ground")) {
    body_nodes_[0] = g;
    readWrapObjects(g, 0);
  }
  // OpenSim 4 models may list their bodies in the model's <components> (Moco writes them so)
  // instead of a BodySet; both are read, with component paths /bodyset/<b> and /<b>.
  Node set = v4 ? model_el.child("BodySet") : model_el.requireChild("BodySet");
  // The ground is a body named 'ground' in the BodySet of 3.x layouts and of the 4.0 development
  // layouts written before <Ground> existed (30500-30504; OpenSim moves it to <Ground>).
  const bool ground_in_bodyset = !v4 || !model_el.child("Ground");
  bool ground_seen = v4, ground_body_read = false;
  for (const Node& b : set.child("objects").children()) {
    if (b.name() != "Body") {
      ignore(b, "BodySet");
      continue;
    }
    const std::string name = b.nameAttr();
    if (name.empty()) b.fail("expected a name attribute on <Body>, got none");
    if (name == "ground" && ground_in_bodyset) {
      if (ground_body_read) b.fail("duplicate body name 'ground'");
      ground_seen = ground_body_read = true;
      body_nodes_[0] = b;
      readWrapObjects(b, 0);
      if (v4) continue;
      readMeshes3(b, 0);
      Node jw = b.child("Joint");
      if (jw && !jw.children().empty())
        jw.children()[0].fail("expected no joint on ground, got <" + jw.children()[0].name() + ">");
      continue;
    }
    const int index = addBody(b, "/bodyset/" + name);
    if (!v4) {
      readMeshes3(b, index);
      Node jw = b.child("Joint");
      std::vector<Node> kids = jw ? jw.children() : std::vector<Node>();
      if (kids.size() > 1) jw.fail("expected one joint in <Joint>, got " + std::to_string(kids.size()));
      if (kids.empty())
        b.fail("expected a joint connecting body '" + name + "' to its parent, got " +
               (jw ? "an empty <Joint>" : "no <Joint>"));
      pending_joints_.emplace_back(kids[0], index);
    }
  }
  if (!ground_seen) set.fail("expected a body named 'ground', got none");
  if (v4)
    for (const Node& b : model_el.child("components").children("Body")) addBody(b, "/" + b.nameAttr());
}

int OsimReader::addBody(const Node& b, const std::string& path) {
  const std::string name = b.nameAttr();
  if (name.empty()) b.fail("expected a name attribute on <Body>, got none");
  if (body_index_.count(name)) b.fail("duplicate body name '" + name + "'");
  const int index = int(m_->bodies.size());
  m_->bodies.emplace_back();
  body_nodes_.push_back(b);
  body_index_[name] = index;
  body_paths_[path] = index;
  Body& body = m_->bodies[index];
  body.name = name;
  body.mass = b.childDouble("mass", 0.0);
  if (!std::isfinite(body.mass) || body.mass < 0)
    b.child("mass").fail("expected a non-negative mass, got " + b.childText("mass"));
  body.mass_center = b.childVec3("mass_center", Vec3::Zero());
  body.inertia = readInertia(b);
  readWrapObjects(b, index);
  return index;
}

Mat3 OsimReader::readInertia(const Node& b) {
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

void OsimReader::addMesh(int body, const Node& where, const std::string& file, const Vec3& scale, const Pose& X_BG) {
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
void OsimReader::readMeshes3(const Node& b, int body) {
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
void OsimReader::readMeshes4(const Node& frame, const std::string& owner_path, int body, const Pose& X_BF) {
  for (const Node& g : frame.child("attached_geometry").children("Mesh")) {
    int b = body;
    Pose X = X_BF;
    if (Node sf = findSocket(g, {"frame"}); sf && !sf.text().empty() && sf.text() != "..") {
      const auto r = resolveFrame(sf.text(), owner_path + "/" + g.nameAttr(), sf);
      b = r.first;
      X = r.second;
    }
    addMesh(b, g, g.childText("mesh_file"), g.childVec3("scale_factors", Vec3::Ones()), X);
  }
}

void OsimReader::readFrameWrapObjects() {
  for (auto& kv : frames_) {
    OffsetFrame& f = kv.second;
    if (f.kind != OffsetFrame::Kind::Offset || !f.node.child("WrapObjectSet")) continue;
    const auto r = resolveEntry(FrameEntry{-1, kv.first}, f.node);
    const size_t first = m_->wrap_objects.size();
    readWrapObjects(f.node, r.first);
    for (size_t k = first; k < m_->wrap_objects.size(); ++k) m_->wrap_objects[k].X_BW = r.second * m_->wrap_objects[k].X_BW;
  }
}

void OsimReader::attachMeshes4() {
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

}  // namespace kneesim::model::osim
