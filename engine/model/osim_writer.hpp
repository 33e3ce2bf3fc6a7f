#pragma once
// Writer for OpenSim model files in document format 40000 (OpenSim 4.0).
//
// The layout is OpenSim 4.0's: a <Ground>, a BodySet of <Body> (mass, mass_center, inertia
// "Ixx Iyy Izz Ixy Ixz Iyz" about the centre of mass), a JointSet whose joints own their
// PhysicalOffsetFrames and name them in socket_parent_frame/socket_child_frame, coordinates
// inside their joint, a ConstraintSet of CoordinateCouplerConstraints and Point, PointOnLine,
// ConstantDistance and Weld constraints (a WeldConstraint owns its two frames), and a MarkerSet whose
// markers name their body by component path (/bodyset/<body>). Object-valued properties are
// written as <Type name="property">, as OpenSim 4 writes them. readOsim() reads the result back
// into an identical model (same bodies, joints, frames, functions, couplers, markers, meshes).
//
// What is not written: Model::ignored (muscles, wrap objects, ... that the reader listed but
// did not keep) and Model::warnings. Coordinate motion types are not written either: OpenSim 4
// and readOsim() derive them from the joint. Meshes are named after their files (OpenSim needs
// names; readOsim() does not keep them); a mesh whose pose in its body is not the identity hangs
// from a PhysicalOffsetFrame of the body named "<mesh>_frame".

#include <string>
#include <vector>

#include "model/model.hpp"

namespace kneesim::model {

/// What writeOsim() puts besides the model itself.
struct OsimWriteOptions {
  /// Lines of the comment written after the XML declaration (provenance, how to regenerate).
  std::vector<std::string> comment;
  /// OpenSim's <credits> and <publications> strings ("" leaves them out).
  std::string credits;
  std::string publications;
};

/// The model as the text of a format-40000 .osim file. Throws InputError naming the model and
/// joint if the model has a joint reversed in the OpenSim 3 sense (reverse = true in a model
/// read from a document older than 40000): OpenSim 4 keeps a joint's transform parent-to-child
/// whatever its `reverse` flag, so such a joint has no format-40000 equivalent and must be
/// rebuilt forward first.
std::string formatOsim(const Model& model, const OsimWriteOptions& options = {});

/// Writes formatOsim(@p model) to @p path atomically (no partial file on failure).
void writeOsim(const std::string& path, const Model& model, const OsimWriteOptions& options = {});

/// OpenSim's body-fixed X-Y-Z Euler angles of @p R (the inverse of poseFromXYZ's rotation): the
/// angles (a, b, c) with R = Rx(a) Ry(b) Rz(c), b in [-pi/2, pi/2].
Vec3 calcXYZFromRotation(const Mat3& R);

/// The shortest decimal text that reads back as exactly @p value (at most 17 significant digits).
std::string formatExact(double value);

}  // namespace kneesim::model
