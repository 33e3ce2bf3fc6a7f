#pragma once
// Reader for OpenSim model files (.osim), document versions 10500 to 40600 (docs/models.md).
//
// The layouts OpenSim 4.x reads: joints nested in their child body (parent_body,
// location_in_parent, orientation_in_parent, location, orientation; up to 30000), the 4.0
// pre-releases' JointSet with <connectors> and location_in_child (30500-30516), and OpenSim 4's
// JointSet with PhysicalOffsetFrames and sockets, bodies and joints also in the model's
// <components>. Lengths are taken as metres and angles as radians, which is what OpenSim itself
// does with every model file; a <length_units> other than metres is kept as a warning on the
// model rather than converted.
//
// Wrap objects, muscles of the types kneesim evaluates and coordinate actuators are read too
// (model/osim_forces.hpp). Components kneesim does not simulate (other forces, ligaments,
// contact, controllers, probes, constraints of other types, disabled constraints) are listed in
// Model::ignored with their category. Unknown joint or function types are errors.

#include <string>

#include "model/model.hpp"

namespace kneesim::model {

/// Reads the OpenSim model at @p path and returns it finalised. Mesh files are looked for next
/// to the model, then in its Geometry/ folder; a missing mesh leaves MeshRef::resolved_path
/// empty and adds a warning. Throws InputError ("file:line: element/path: ...") on a malformed
/// or inconsistent model.
ModelPtr readOsim(const std::string& path);

/// Parses the text of an OpenSim model. @p label names it in error messages, and its folder is
/// where mesh files are looked for. Throws InputError like readOsim().
ModelPtr parseOsim(const std::string& text, const std::string& label);

}  // namespace kneesim::model
