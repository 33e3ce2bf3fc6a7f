#pragma once
// URDF import (through urdfdom) and export of a model's skeleton.
//
// Import: links become bodies (the inertial frame's rotation is applied to the inertia so it is
// expressed in the link frame, about the centre of mass); revolute and continuous joints become
// PinJoints and prismatic joints SliderJoints whose joint frames are rotated so Simbody's pin z
// axis (slider x axis) lies along the URDF axis; fixed joints become welds and floating joints
// free joints. Joint limits become clamped coordinate ranges, <mimic> becomes a linear
// coordinate coupler, visual meshes become MeshRefs. A root link named "world" or "ground" is
// ground; any other root link is welded to ground at its origin. Planar joints are rejected.
// Coordinates take the names of their URDF joints (floating: <joint>_rx .. <joint>_tz).
//
// Export: see writeUrdf().

#include <string>
#include <vector>

#include "model/model.hpp"

namespace kneesim::model {

/// Reads the URDF file at @p path and returns the finalised model. Mesh files are looked for
/// next to the URDF, then in its Geometry/ folder ("package://" names are kept unresolved).
/// Throws InputError ("file:line: element: ...") on malformed or unsupported input.
ModelPtr readUrdf(const std::string& path);

/// Parses URDF text; @p label names it in errors and its folder is where meshes are looked for.
ModelPtr parseUrdf(const std::string& text, const std::string& label);

/// Writes the skeleton of @p model as URDF text: a root link "ground", one link per body with
/// its inertial and visual meshes, and for every joint a chain of URDF joints (one per moving
/// axis, through massless links named <joint>_<k>) that reproduces its kinematics exactly when
/// every moving axis is a linear function of a single coordinate with slope +-1 (Pin, Slider,
/// Gimbal, Universal, Free, Ball as body-fixed XYZ angles, identity CustomJoint axes, and
/// OpenSim 3.x reverse joints of those). The URDF joint moving an axis is named after the
/// coordinate, so readUrdf() gives the coordinates their names back. Further axes driven
/// linearly by an already exported coordinate, and linear couplers, become <mimic> joints.
/// Everything else cannot be said in URDF and is appended to @p lost (if not null), one line
/// each: axes driven by splines or several coordinates (frozen at the coordinates' default
/// values), nonlinear couplers, markers, unclamped or locked coordinates, non-zero defaults.
/// URDF needs effort and velocity limits; they are written as 0 (unknown).
std::string formatUrdf(const Model& model, std::vector<std::string>* lost);

/// formatUrdf() written atomically to @p path (no partial file on failure).
void writeUrdf(const Model& model, const std::string& path, std::vector<std::string>* lost);

}  // namespace kneesim::model
