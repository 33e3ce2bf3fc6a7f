// `kneesim model info` and the one-line warning about ignored components that pose a model.
#include "model/model_info.hpp"

#include <cmath>
#include <iomanip>
#include <map>
#include <set>

#include "core/strings.hpp"

namespace kneesim::model {

namespace {

const char* motionName(MotionType t) {
  switch (t) {
    case MotionType::Rotational: return "rotational";
    case MotionType::Translational: return "translational";
    case MotionType::Coupled: return "coupled";
  }
  return "?";
}

std::string plural(size_t n, const std::string& word) {
  if (n == 1) return "1 " + word;
  if (endsWith(word, "y")) return std::to_string(n) + " " + word.substr(0, word.size() - 1) + "ies";
  if (endsWith(word, "sh")) return std::to_string(n) + " " + word + "es";
  return std::to_string(n) + " " + word + "s";
}

/// "3 ligaments (Blankevoort1991Ligament), 1 constraint (RollingOnSurfaceConstraint)".
std::string countByCategory(const std::vector<IgnoredComponent>& items) {
  std::map<std::string, std::pair<size_t, std::set<std::string>>> by;
  for (const IgnoredComponent& c : items) {
    auto& e = by[c.category];
    ++e.first;
    e.second.insert(c.type);
  }
  std::string out;
  for (const auto& [category, e] : by) {
    std::vector<std::string> types(e.second.begin(), e.second.end());
    out += (out.empty() ? "" : ", ") + plural(e.first, category) + " (" + join(types, ", ") + ")";
  }
  return out;
}

/// The muscles and coordinate actuators kneesim simulates (paths and moment arms; forces in static
/// optimization and joint reaction), so the listing says what is used, not only what is left out.
void printForces(const Model& m, std::ostream& os) {
  if (!m.muscles.empty()) {
    os << plural(m.muscles.size(), "muscle")
       << " (paths, lengths and moment arms; forces in static optimization and joint reaction):\n";
    for (const Muscle& mu : m.muscles)
      os << "  " << std::left << std::setw(24) << mu.name << std::right << " " << mu.type << ", max isometric force "
         << mu.max_isometric_force << " N, " << plural(mu.path.points.size(), "path point")
         << (mu.path.wraps.empty() ? "" : ", " + plural(mu.path.wraps.size(), "wrap"))
         << (mu.enabled ? "" : " (disabled)") << "\n";
  }
  if (!m.actuators.empty()) {
    os << plural(m.actuators.size(), "coordinate actuator") << " (static optimization):\n";
    for (const CoordinateActuator& a : m.actuators)
      os << "  " << std::left << std::setw(24) << a.name << std::right << " on "
         << (a.coordinate >= 0 ? m.coordinates[a.coordinate].name : std::string("?")) << ", optimal force "
         << a.optimal_force << (a.enabled ? "" : " (disabled)") << "\n";
  }
}

}  // namespace

std::string describeIgnoredKinematics(const Model& model) {
  std::vector<IgnoredComponent> items;
  for (const IgnoredComponent& c : model.ignored)
    if (c.affects_kinematics) items.push_back(c);
  if (items.empty()) return "";
  return model.source_file + ": " + countByCategory(items) +
         " not simulated; in OpenSim they help decide where the bodies go, here the kinematics ignore them";
}

void printModelInfo(const Model& m, std::ostream& os) {
  const auto flags = os.flags();
  const auto precision = os.precision();
  const double deg = 180.0 / M_PI;
  os << "model " << (m.name.empty() ? "(unnamed)" : m.name) << "\n";
  os << "  file: " << m.source_file << "\n";
  if (m.format_version > 0) os << "  format: OpenSim document version " << m.format_version << "\n";
  os << std::setprecision(6) << "  gravity: " << m.gravity.x() << " " << m.gravity.y() << " " << m.gravity.z()
     << " m/s^2\n";

  os << plural(m.bodies.size() - 1, "body") << " besides ground:\n";
  for (size_t b = 1; b < m.bodies.size(); ++b)
    os << "  " << std::left << std::setw(24) << m.bodies[b].name << std::right << " mass " << m.bodies[b].mass
       << " kg" << (m.bodies[b].meshes.empty() ? "" : ", " + plural(m.bodies[b].meshes.size(), "mesh")) << "\n";

  os << plural(m.joints.size(), "joint") << ":\n";
  for (const Joint& j : m.joints) {
    std::vector<std::string> coords;
    for (int c : j.coordinates) coords.push_back(m.coordinates[c].name);
    os << "  " << std::left << std::setw(24) << j.name << std::right << " " << getJointTypeName(j.type) << " "
       << m.bodies[j.parent_body].name << " -> " << m.bodies[j.child_body].name
       << (j.reverse ? " (reverse)" : "") << (j.reversed_in_tree ? " (the file's child -> parent)" : "") << (coords.empty() ? "" : ": " + join(coords, ", ")) << "\n";
  }

  os << plural(m.coordinates.size(), "coordinate") << " (rotational in degrees, translational in m):\n";
  for (const Coordinate& c : m.coordinates) {
    const double s = c.motion_type == MotionType::Rotational ? deg : 1.0;
    os << "  " << std::left << std::setw(24) << c.name << std::right << " " << std::setw(13) << motionName(c.motion_type)
       << "  default " << std::setw(9) << c.default_value * s << "  range " << c.range_min * s << " to "
       << c.range_max * s << (c.clamped ? ", clamped" : "") << (c.locked ? ", locked" : "") << "\n";
  }

  if (!m.couplers.empty()) {
    os << plural(m.couplers.size(), "coordinate coupler") << ":\n";
    for (const CoordinateCoupler& cc : m.couplers) {
      std::vector<std::string> ind;
      for (int c : cc.independents) ind.push_back(m.coordinates[c].name);
      os << "  " << std::left << std::setw(24) << cc.name << std::right << " " << m.coordinates[cc.dependent].name
         << " = " << (cc.scale_factor != 1.0 ? formatSignificant(cc.scale_factor, 6) + " * " : "")
         << cc.function->getTypeName() << "(" << join(ind, ", ") << ")\n";
    }
  }
  if (!m.constraints.empty()) {
    os << plural(m.constraints.size(), "constraint") << ":\n";
    for (const Constraint& k : m.constraints) {
      os << "  " << std::left << std::setw(24) << k.name << std::right << " " << getConstraintTypeName(k.type) << " "
         << m.bodies[k.body1].name << " - " << m.bodies[k.body2].name;
      if (k.type == ConstraintType::ConstantDistance) os << ", distance " << k.distance << " m";
      os << "\n";
    }
  }

  os << plural(m.markers.size(), "marker") << ":\n";
  for (const Marker& mk : m.markers)
    os << "  " << std::left << std::setw(24) << mk.name << std::right << " on " << m.bodies[mk.body].name << " at "
       << mk.p_BM.x() << " " << mk.p_BM.y() << " " << mk.p_BM.z() << (mk.fixed ? " (fixed)" : "") << "\n";

  printForces(m, os);

  if (m.ignored.empty()) {
    os << "every component is simulated\n";
  } else {
    os << plural(m.ignored.size(), "component") << " not simulated: " << countByCategory(m.ignored) << "\n";
    for (const IgnoredComponent& c : m.ignored)
      os << "  " << std::left << std::setw(24) << (c.name.empty() ? "(unnamed)" : c.name) << std::right << " " << c.type
         << " (" << c.category << (c.affects_kinematics ? ", poses the model in OpenSim" : "") << ")\n";
  }
  if (const std::string w = describeIgnoredKinematics(m); !w.empty()) os << "warning: " << w << "\n";
  for (const std::string& w : m.warnings) os << "warning: " << w << "\n";
  os.flags(flags);
  os.precision(precision);
}

}  // namespace kneesim::model
