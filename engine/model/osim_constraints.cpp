// The .osim reader's constraints: CoordinateCouplerConstraints; others are listed as ignored.
#include "model/osim_reader_internal.hpp"

#include "core/error.hpp"
#include "core/strings.hpp"

namespace kneesim::model::osim {

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

}  // namespace kneesim::model::osim
