// The .osim reader's constraints: CoordinateCouplerConstraint, PointConstraint,
// PointOnLineConstraint, ConstantDistanceConstraint and WeldConstraint, in the 3.x (body names)
// and 4.x (sockets) forms; disabled ones and other types are listed as ignored.
#include "model/osim_reader_internal.hpp"

#include <cmath>

#include "core/error.hpp"
#include "core/strings.hpp"

namespace kneesim::model::osim {

namespace {

bool isBodyConstraint(const std::string& tag) {
  return tag == "PointConstraint" || tag == "PointOnLineConstraint" || tag == "ConstantDistanceConstraint" ||
         tag == "WeldConstraint";
}

bool isDisabled(const Node& c) { return c.childBool("isDisabled", false) || !c.childBool("isEnforced", true); }

}  // namespace

int OsimReader::requireCoordinate(const Node& where, const std::string& n) {
  auto it = coord_index_.find(n);
  if (it == coord_index_.end()) {
    std::vector<std::string> names;
    for (const Coordinate& c : m_->coordinates) names.push_back(c.name);
    where.fail("unknown coordinate '" + n + "' (expected one of " + listNames(names) + ")");
  }
  return it->second;
}

void OsimReader::readConstraints(const Node& model_el) {
  std::vector<std::pair<Node, std::string>> items;  // element, component path
  for (const Node& c : model_el.child("ConstraintSet").child("objects").children())
    items.emplace_back(c, "/constraintset/" + c.nameAttr());
  // The model's <components>, and those of its ground, bodies and joints: OpenSim adds every
  // constraint component to the system, whoever owns it.
  auto owned = [&](const Node& owner, const std::string& owner_path) {
    for (const Node& c : owner.child("components").children())
      if (c.name() == "CoordinateCouplerConstraint" || isBodyConstraint(c.name()))
        items.emplace_back(c, owner_path + "/" + c.nameAttr());
  };
  owned(model_el, "");
  if (Node g = model_el.child("Ground")) owned(g, "/ground");
  for (const auto& [p, b] : body_paths_)
    if (b > 0) owned(body_nodes_[b], p);
  for (const JointElement& je : joint_elements_) owned(je.node, je.path);
  for (const auto& [c, path] : items) {
    const std::string tag = c.name();
    if (tag != "CoordinateCouplerConstraint" && !isBodyConstraint(tag)) {
      ignore(c, "ConstraintSet");
      continue;
    }
    if (isDisabled(c)) {
      IgnoredComponent ic = classifyIgnored(c, "ConstraintSet");
      ic.type += " (disabled)";
      m_->ignored.push_back(ic);
      continue;
    }
    if (tag == "CoordinateCouplerConstraint")
      readCoupler(c);
    else
      readBodyConstraint(c, path);
  }
}

void OsimReader::readCoupler(const Node& c) {
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
                               {"isDisabled", "isEnforced", "independent_coordinate_names", "dependent_coordinate_name",
                                "scale_factor"});
  if (!fn) c.fail("expected a coupled_coordinates_function, got none");
  cc.function = parseFunction(fn);
  if (auto* k = dynamic_cast<const Constant*>(cc.function.get()); k && cc.independents.size() > 1)
    cc.function = std::make_shared<Constant>(k->getValue(), int(cc.independents.size()));
  if (cc.function->getArgumentSize() != int(cc.independents.size()))
    fn.fail("expected a function of " + std::to_string(cc.independents.size()) + " coordinates, got a " +
            cc.function->getTypeName() + " of " + std::to_string(cc.function->getArgumentSize()) + " argument(s)");
  cc.scale_factor = c.childDouble("scale_factor", 1.0);
  m_->couplers.push_back(std::move(cc));
}

void OsimReader::readBodyConstraint(const Node& c, const std::string& path) {
  Constraint k;
  k.name = c.nameAttr();
  const std::string tag = c.name();
  // A body named in a 3.x element or a frame path in a 4.x socket: the body and the pose of the
  // named frame in it.
  auto frameOf = [&](std::initializer_list<const char*> sockets, const char* legacy) -> std::pair<int, Pose> {
    Node n = findSocket(c, sockets);
    if (!n) n = c.child(legacy);
    if (!n || n.text().empty())
      c.fail(std::string("expected <socket_") + *sockets.begin() + "> or <" + legacy + "> naming a body, got none");
    auto it = body_index_.find(n.text());
    if (it != body_index_.end()) return {it->second, Pose::Identity()};
    return resolveFrame(n.text(), path, n);
  };
  if (tag == "PointConstraint" || tag == "ConstantDistanceConstraint") {
    k.type = tag == "PointConstraint" ? ConstraintType::Point : ConstraintType::ConstantDistance;
    const auto f1 = frameOf({"body_1"}, "body_1"), f2 = frameOf({"body_2"}, "body_2");
    k.body1 = f1.first;
    k.body2 = f2.first;
    k.X_B1F1.translation() = f1.second * c.childVec3("location_body_1", Vec3::Zero());
    k.X_B2F2.translation() = f2.second * c.childVec3("location_body_2", Vec3::Zero());
    if (k.type == ConstraintType::ConstantDistance) {
      Node d = c.requireChild("constant_distance");
      k.distance = d.toDouble();
      // Simbody's Rod cannot hold two points together; a PointConstraint does that.
      if (!(k.distance > 0) || !std::isfinite(k.distance))
        d.fail("expected a positive distance (m), got " + d.text());
    }
  } else if (tag == "PointOnLineConstraint") {
    k.type = ConstraintType::PointOnLine;
    const auto line = frameOf({"line_body"}, "line_body"), follower = frameOf({"follower_body"}, "follower_body");
    k.body1 = line.first;
    k.body2 = follower.first;
    Node dn = c.requireChild("line_direction_vec");
    const Vec3 dir = line.second.linear() * dn.toVec3();
    if (!(dir.norm() > 1e-12)) dn.fail("expected a non-zero line direction, got '" + dn.text() + "'");
    // F1: origin on the line, x along it (y and z complete a right-handed frame).
    const Vec3 x = dir.normalized();
    const Vec3 helper = std::abs(x.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
    const Vec3 y = x.cross(helper).normalized();
    k.X_B1F1.linear().col(0) = x;
    k.X_B1F1.linear().col(1) = y;
    k.X_B1F1.linear().col(2) = x.cross(y);
    k.X_B1F1.translation() = line.second * c.childVec3("point_on_line", Vec3::Zero());
    k.X_B2F2.translation() = follower.second * c.childVec3("point_on_follower", Vec3::Zero());
  } else {  // WeldConstraint
    k.type = ConstraintType::Weld;
    if (findSocket(c, {"frame1"})) {
      Node n1 = findSocket(c, {"frame1"}), n2 = findSocket(c, {"frame2"});
      if (!n2) c.fail("expected <socket_frame2> naming the second frame, got none");
      const auto f1 = resolveFrame(n1.text(), path, n1), f2 = resolveFrame(n2.text(), path, n2);
      k.body1 = f1.first;
      k.body2 = f2.first;
      k.X_B1F1 = f1.second;
      k.X_B2F2 = f2.second;
    } else {
      const auto f1 = frameOf({"body_1"}, "body_1"), f2 = frameOf({"body_2"}, "body_2");
      k.body1 = f1.first;
      k.body2 = f2.first;
      k.X_B1F1 = f1.second * poseFromXYZ(c.childVec3("orientation_body_1", Vec3::Zero()),
                                          c.childVec3("location_body_1", Vec3::Zero()));
      k.X_B2F2 = f2.second * poseFromXYZ(c.childVec3("orientation_body_2", Vec3::Zero()),
                                          c.childVec3("location_body_2", Vec3::Zero()));
    }
  }
  if (k.body1 == k.body2) c.fail("expected a constraint between two bodies, got both on '" + m_->bodies[k.body1].name + "'");
  m_->constraints.push_back(std::move(k));
}

}  // namespace kneesim::model::osim
