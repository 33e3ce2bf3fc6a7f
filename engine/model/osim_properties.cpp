// The .osim reader's property forms shared by every component: functions, six-number transforms,
// component paths.
#include "model/osim_reader_internal.hpp"

#include <set>

#include "core/error.hpp"
#include "core/strings.hpp"

namespace kneesim::model::osim {

namespace {

const char* const kFunctionTypes =
    "Constant, LinearFunction, PolynomialFunction, SimmSpline, NaturalCubicSpline, PiecewiseLinearFunction or "
    "MultiplierFunction";

std::vector<double> requireDoubles(const Node& owner, const char* tag) {
  Node c = owner.requireChild(tag);
  return c.toDoubles();
}

}  // namespace

bool isFunctionTag(const std::string& t) {
  static const std::set<std::string> tags = {"Constant",           "LinearFunction",          "PolynomialFunction",
                                             "SimmSpline",         "NaturalCubicSpline",      "natCubicSpline",
                                             "PiecewiseLinearFunction", "MultiplierFunction"};
  return tags.count(t) > 0;
}

std::string listNames(const std::vector<std::string>& names, size_t max_names) {
  std::string out;
  for (size_t i = 0; i < names.size() && i < max_names; ++i) out += (i ? ", " : "") + names[i];
  if (names.size() > max_names) out += ", ... (" + std::to_string(names.size()) + " in all)";
  return out.empty() ? "none" : out;
}

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

Pose parseSixTransform(const Node& n) {
  const std::vector<double> v = n.toDoubles();
  if (v.size() != 6) n.fail("expected 6 numbers (rX rY rZ tx ty tz), got " + std::to_string(v.size()));
  return poseFromXYZ(Vec3(v[0], v[1], v[2]), Vec3(v[3], v[4], v[5]));
}

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

Node findSocket(const Node& owner, std::initializer_list<const char*> names) {
  for (const char* name : names) {
    const std::string n(name);
    if (Node s = owner.child(("socket_" + n).c_str())) return s;
    // 30508-30516 wrote socket_<name>_connectee_name (OpenSim renames it to socket_<name>).
    if (Node s = owner.child(("socket_" + n + "_connectee_name").c_str())) return s;
    if (Node s = owner.child(("connector_" + n + "_connectee_name").c_str())) return s;
    for (const Node& c : owner.child("connectors").children()) {
      if (c.nameAttr() != n) continue;
      // 30500-30502 wrote <connected_to_name>, later versions <connectee_name>.
      if (Node old = c.child("connected_to_name")) return old;
      return c.requireChild("connectee_name");
    }
  }
  return Node();
}

IgnoredComponent classifyIgnored(const Node& el, const std::string& set_tag) {
  IgnoredComponent out{el.name(), el.nameAttr()};
  const std::string& t = out.type;
  auto has = [&](const char* part) { return t.find(part) != std::string::npos; };
  if (has("Ligament")) {
    out.category = "ligament";
  } else if (set_tag == "ContactGeometrySet" || startsWith(t, "Contact") || endsWith(t, "ContactMesh")) {
    out.category = "contact geometry";  // shapes only; the forces between them are what pose a model
  } else if (has("Contact") || t == "HuntCrossleyForce" || t == "ElasticFoundationForce" ||
             t == "SmoothSphereHalfSpaceForce") {
    out.category = "contact";
  } else if (endsWith(t, "Muscle") || has("Muscle_Deprecated")) {
    out.category = "muscle";
  } else if (set_tag == "ConstraintSet" || endsWith(t, "Constraint")) {
    out.category = "constraint";
  } else if (startsWith(t, "Wrap")) {
    out.category = "wrap object";
  } else if (set_tag == "ControllerSet" || endsWith(t, "Controller")) {
    out.category = "controller";
  } else if (set_tag == "ProbeSet" || endsWith(t, "Probe")) {
    out.category = "probe";
  } else if (set_tag == "ForceSet" || endsWith(t, "Force") || endsWith(t, "Actuator") || has("Bushing") ||
             has("Spring")) {
    out.category = "force";
  }
  // A constraint left out moves the bodies away from where OpenSim puts them; a model posed by
  // ligaments and contact (a JAM knee) has coordinates that only those forces determine.
  const bool disabled = el.childBool("isDisabled", false) || !el.childBool("isEnforced", true);
  out.affects_kinematics =
      out.category == "ligament" || out.category == "contact" || (out.category == "constraint" && !disabled);
  return out;
}

}  // namespace kneesim::model::osim
