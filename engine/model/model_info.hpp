#pragma once
// What a model holds, in words: `kneesim model info` and the warnings other tools print about
// components kneesim reads past.

#include <ostream>
#include <string>

#include "model/model.hpp"

namespace kneesim::model {

/// One line naming the components of @p model that kneesim does not simulate although they
/// decide where the bodies go (enabled constraints of types kneesim does not enforce, ligaments,
/// contact), counted by category with their types; "" when there are none. Tools running
/// kinematics print it as a warning.
std::string describeIgnoredKinematics(const Model& model);

/// Writes a readable description of @p model: file and format, gravity, bodies (mass), joints
/// (type, parent, child, coordinates), coordinates (motion type, default, range in degrees or
/// metres, clamped or locked), couplers, constraints, markers, every component kept out of the
/// simulation with its type and category, and the reader's warnings.
void printModelInfo(const Model& model, std::ostream& os);

}  // namespace kneesim::model
