#pragma once
// Reads the force elements of an OpenSim model file (document versions 20302 to 4xxxx): wrap
// objects on bodies, muscles with geometry paths and coordinate actuators from the ForceSet, and
// a stand-alone actuator set file (an OpenSim <ForceSet> document, as StaticOptimization's
// force_set_files name them).
//
// Muscles of the types kneesim evaluates (Schutte1993Muscle_Deprecated, Thelen2003Muscle,
// Thelen2003Muscle_Deprecated, Millard2012EquilibriumMuscle) and CoordinateActuators become Model::muscles and
// Model::actuators; every other force is listed in Model::ignored and kept out.

#include <functional>
#include <string>
#include <utility>

#include "core/xml.hpp"
#include "model/model.hpp"

namespace kneesim::model {

/// What the force reader needs from the model reader that calls it.
struct OsimForceContext {
  /// OpenSim 4.x layout (sockets name frames and coordinates by component path).
  bool v4 = false;
  /// The function an element describes (a SimmSpline, a Constant, ...), or null when the element
  /// is not a function. Throws InputError on a malformed function.
  std::function<FunctionPtr(const xml::Node& element)> parse_function;
  /// OpenSim 4.x: the body and pose in it of the frame @p path (absolute, or relative to the
  /// component at @p owner_path). Throws InputError at @p where if there is no such frame.
  std::function<std::pair<int, Pose>(const std::string& path, const std::string& owner_path, const xml::Node& where)>
      resolve_frame;
};

/// Reads the WrapObjectSet of @p frame_element, the element of body @p body (0 for ground), and
/// appends its objects to @p m.wrap_objects. Unknown wrap types are listed in m.ignored.
void readOsimWrapObjects(const xml::Node& frame_element, int body, Model& m);

/// Reads the ForceSet of the <Model> element @p model_element into @p m. Bodies, coordinates and
/// wrap objects must already be in @p m. Throws InputError ("file:line: element: ...") for a path
/// point on an unknown body, a wrap of an unknown wrap object, a muscle with fewer than two path
/// points, an unknown coordinate, or a non-finite or negative parameter.
void readOsimForceSet(const xml::Node& model_element, const OsimForceContext& ctx, Model& m);

/// Reads an actuator set file (an OpenSim document whose root or its child is a <ForceSet>) for
/// @p model: its muscles and coordinate actuators, checked against the model's bodies,
/// coordinates and wrap objects. Returns them in a copy of @p model's force lists: muscles and
/// actuators appended, or replacing the model's own when @p replace is true. Other forces are
/// listed in the returned model's ignored components.
ModelPtr readOsimActuatorSet(const std::string& path, const ModelPtr& model, bool replace);

}  // namespace kneesim::model
