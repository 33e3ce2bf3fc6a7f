#include "model/urdf_check.hpp"

#include <cmath>
#include <locale>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <tinyxml.h>

#include "core/strings.hpp"

namespace kneesim::model::urdf_check {

namespace {

using xml::Node;

/// A number as urdfdom reads one (urdf::strToDouble: a C++ stream in the classic locale that must
/// take the whole text), so that what passes here passes urdfdom too.
bool parseUrdfNumber(const std::string& s, double& v) {
  std::stringstream ss;
  ss.imbue(std::locale::classic());
  ss << s;
  ss >> v;
  return !ss.fail() && ss.eof();
}

/// Numbers in an attribute, checked with file and line (urdfdom would only print a message), and
/// finite. Read as urdfdom reads them: a single number is the whole attribute; a vector is split
/// on spaces (urdf::Vector3::init: only ' ', empty pieces skipped).
std::vector<double> attrNumbers(const Node& n, const char* key, size_t count, bool required) {
  const auto a = n.attr(key);
  if (!a) {
    if (required) n.fail(std::string("missing attribute '") + key + "'");
    return {};
  }
  std::vector<std::string> pieces;
  if (count == 1) {
    pieces.push_back(*a);
  } else {
    for (auto w : splitOn(*a, ' '))
      if (!w.empty()) pieces.emplace_back(w);
  }
  std::vector<double> out;
  for (const std::string& w : pieces) {
    double v;
    if (!parseUrdfNumber(w, v) || !std::isfinite(v))
      n.fail(std::string("attribute '") + key + "': expected a number, got '" + w + "'");
    out.push_back(v);
  }
  if (count && out.size() != count)
    n.fail(std::string("attribute '") + key + "': expected " + std::to_string(count) + " numbers, got " +
           std::to_string(out.size()) + " ('" + *a + "')");
  return out;
}

void checkOrigin(const Node& owner) {
  for (const Node& o : owner.children("origin")) {
    attrNumbers(o, "xyz", 3, false);
    attrNumbers(o, "rpy", 3, false);
  }
}

/// The shape of a <visual> or <collision>: urdfdom leaks the shape when one of its attributes does
/// not parse (urdfdom 3.0's parseGeometry drops its raw pointer on the error path), so every
/// attribute it reads is checked here first and urdfdom only ever sees numbers.
void checkGeometry(const Node& geometry) {
  if (!geometry) return;
  const std::vector<Node> shapes = geometry.children();
  if (shapes.empty()) return;
  const Node& shape = shapes.front();  // urdfdom reads the first element only
  const std::string type = shape.name();
  if (type == "mesh") {
    if (shape.attr("filename").value_or("").empty()) shape.fail("expected a filename attribute, got none");
    attrNumbers(shape, "scale", 3, false);
  } else if (type == "box") {
    attrNumbers(shape, "size", 3, true);
  } else if (type == "sphere") {
    attrNumbers(shape, "radius", 1, true);
  } else if (type == "cylinder") {
    attrNumbers(shape, "radius", 1, true);
    attrNumbers(shape, "length", 1, true);
  } else {
    shape.fail("unknown geometry <" + type + "> (expected box, cylinder, sphere or mesh)");
  }
}

}  // namespace

const char* const kJointTypes = "revolute, continuous, prismatic, fixed or floating";

namespace {

/// The joints must make a tree of the links: one parent joint per link and no loop. urdfdom links
/// parent and child links by shared pointers both ways, so a loop (a joint from a link to itself,
/// or round a cycle) leaks the whole model when urdfdom rejects it; refused here first.
void checkTree(const std::vector<Node>& joints) {
  std::map<std::string, const Node*> parent_joint;  // child link -> its joint
  for (const Node& j : joints) {
    const std::string parent = *j.child("parent").attr("link"), child = *j.child("child").attr("link");
    if (parent == child) j.fail("expected a joint between two links, got '" + child + "' as its parent and child");
    const auto [it, inserted] = parent_joint.emplace(child, &j);
    if (!inserted)
      j.fail("link '" + child + "' is already the child of joint '" + it->second->nameAttr() +
             "' (expected one parent joint per link)");
  }
  for (const auto& [link, joint] : parent_joint) {
    std::string up = *joint->child("parent").attr("link");
    for (size_t steps = 0; steps <= parent_joint.size(); ++steps) {
      if (up == link) joint->fail("joint loop: link '" + link + "' is its own ancestor (expected a tree of links)");
      const auto it = parent_joint.find(up);
      if (it == parent_joint.end()) break;
      up = *it->second->child("parent").attr("link");
    }
  }
}

}  // namespace

/// Our own pass over the XML: everything urdfdom would reject with only a console message gets
/// a file:line here. Returns link and joint elements in file order.
void validate(const xml::Document& doc, std::vector<Node>& links, std::vector<Node>& joints) {
  Node robot = doc.root();
  if (robot.name() != "robot") robot.fail("expected a URDF <robot> element, got <" + robot.name() + ">");
  std::set<std::string> link_names, joint_names;
  for (const Node& l : robot.children("link")) {
    const std::string name = l.nameAttr();
    if (name.empty()) l.fail("expected a name attribute on <link>, got none");
    if (!link_names.insert(name).second) l.fail("duplicate link name '" + name + "'");
    for (const Node& in : l.children("inertial")) {
      checkOrigin(in);
      attrNumbers(in.requireChild("mass"), "value", 1, true);
      Node I = in.requireChild("inertia");
      for (const char* k : {"ixx", "ixy", "ixz", "iyy", "iyz", "izz"}) attrNumbers(I, k, 1, true);
    }
    for (const char* tag : {"visual", "collision"})
      for (const Node& v : l.children(tag)) {
        checkOrigin(v);
        checkGeometry(v.child("geometry"));
      }
    links.push_back(l);
  }
  if (links.empty()) robot.fail("expected at least one <link>, got none");
  for (const Node& j : robot.children("joint")) {
    const std::string name = j.nameAttr();
    if (name.empty()) j.fail("expected a name attribute on <joint>, got none");
    if (!joint_names.insert(name).second) j.fail("duplicate joint name '" + name + "'");
    const std::string type = j.attr("type").value_or("");
    if (type == "planar") j.fail("unsupported joint type 'planar' (expected " + std::string(kJointTypes) + ")");
    if (type != "revolute" && type != "continuous" && type != "prismatic" && type != "fixed" && type != "floating")
      j.fail("unknown joint type '" + type + "' (expected " + kJointTypes + ")");
    for (const char* role : {"parent", "child"}) {
      Node r = j.requireChild(role);
      const std::string link = r.attr("link").value_or("");
      if (!link_names.count(link)) r.fail(std::string("unknown ") + role + " link '" + link + "'");
    }
    checkOrigin(j);
    if (Node ax = j.child("axis")) {
      const auto v = attrNumbers(ax, "xyz", 3, false);
      if (!v.empty() && std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) < 1e-12)
        ax.fail("expected a non-zero axis, got '" + ax.attr("xyz").value_or("") + "'");
    }
    if (Node lim = j.child("limit")) {
      for (const char* k : {"lower", "upper", "effort", "velocity"}) attrNumbers(lim, k, 1, false);
      const auto lo = attrNumbers(lim, "lower", 1, false), hi = attrNumbers(lim, "upper", 1, false);
      if (!lo.empty() && !hi.empty() && lo[0] > hi[0])
        lim.fail("expected lower <= upper, got " + std::to_string(lo[0]) + " > " + std::to_string(hi[0]));
    } else if (type == "revolute" || type == "prismatic") {
      j.fail("expected a <limit> for a " + type + " joint, got none");
    }
    if (Node mm = j.child("mimic")) {
      attrNumbers(mm, "multiplier", 1, false);
      attrNumbers(mm, "offset", 1, false);
      if (mm.attr("joint").value_or("").empty()) mm.fail("expected a joint attribute, got none");
    }
    joints.push_back(j);
  }
  for (const Node& j : joints)
    if (Node mm = j.child("mimic"))
      if (!joint_names.count(*mm.attr("joint"))) mm.fail("unknown mimicked joint '" + *mm.attr("joint") + "'");
  checkTree(joints);
}


void differs(const Node& n, const std::string& value) {
  n.fail("urdfdom reads '" + value + "' differently (its XML parser, TinyXML, drops an '&' that starts no entity and " +
         "reads some bytes otherwise): expected a name urdfdom reads as written");
}

namespace {

std::optional<std::string> tinyAttr(const TiXmlElement* e, const char* key) {
  const char* v = e ? e->Attribute(key) : nullptr;
  return v ? std::optional<std::string>(v) : std::nullopt;
}

void sameName(const Node& n, const char* key, const TiXmlElement* e) {
  const std::string mine = n.attr(key).value_or("");
  if (tinyAttr(e, key) != mine) differs(n, mine);
}

}  // namespace

void sameReadingAsUrdfdom(const std::string& text, const std::vector<Node>& links, const std::vector<Node>& joints) {
  // As urdf::parseURDF reads it: the text up to its first NUL, the first <robot>, then its <link> and
  // <joint> elements in order and the first <parent>, <child> and <mimic> of each joint.
  TiXmlDocument doc;
  doc.Parse(text.c_str());
  if (doc.Error()) return;  // urdfdom refuses the file before it builds anything; its message says why
  const TiXmlElement* robot = doc.FirstChildElement("robot");
  if (!robot) return;  // the same
  const TiXmlElement* l = robot->FirstChildElement("link");
  for (const Node& n : links) {
    if (!l) differs(n, n.nameAttr());
    sameName(n, "name", l);
    l = l->NextSiblingElement("link");
  }
  if (l) differs(links.back(), tinyAttr(l, "name").value_or(""));
  const TiXmlElement* j = robot->FirstChildElement("joint");
  for (const Node& n : joints) {
    if (!j) differs(n, n.nameAttr());
    sameName(n, "name", j);
    for (const char* role : {"parent", "child"}) sameName(n.child(role), "link", j->FirstChildElement(role));
    if (Node mm = n.child("mimic")) sameName(mm, "joint", j->FirstChildElement("mimic"));
    j = j->NextSiblingElement("joint");
  }
  if (j) differs(joints.empty() ? links.back() : joints.back(), tinyAttr(j, "name").value_or(""));
}

}  // namespace kneesim::model::urdf_check
