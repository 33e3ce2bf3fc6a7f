#pragma once
// A joint's net load in a chosen frame: the force and moment one body applies to the other
// through the joint, at the joint centre, expressed in ground, the parent or the child.
//
// The loads come from InverseDynamics::calcJointLoads() (the parent's load on each child, about
// the child's origin, in ground). As OpenSim's JointReaction reports them, the load on the child
// acts at the origin of the joint frame fixed on the child (M), the load on the parent is its
// opposite, acting at the origin of the joint frame fixed on the parent (F), and "point" is that
// origin expressed in the chosen frame.

#include <string>

#include <Eigen/Core>

#include "sim/system.hpp"

namespace kneesim::dynamics {

/// Which body the reported load acts on.
enum class LoadOnBody { Child, Parent };
/// Which frame the reported vectors are expressed in.
enum class LoadFrame { Ground, Parent, Child };

/// A joint load expressed in a frame.
struct JointLoad {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< N
  Eigen::Vector3d moment = Eigen::Vector3d::Zero();  ///< N·m, about point
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< m, the joint centre in the frame
};

/// The load joint @p joint transmits, from @p F_joint (InverseDynamics::calcJointLoads()) and the
/// poses realised in @p ws. No allocation.
JointLoad expressJointLoad(const sim::System& system, const sim::Workspace& ws, int joint,
                           const sim::SpatialColumns& F_joint, LoadOnBody on, LoadFrame frame);

/// "child" or "parent" (case-insensitive); throws std::invalid_argument otherwise.
LoadOnBody parseLoadOnBody(const std::string& s);
/// "ground", "parent" or "child" (case-insensitive); throws std::invalid_argument otherwise.
LoadFrame parseLoadFrame(const std::string& s);

/// The name of the body @p on or @p frame refers to for joint @p joint, as OpenSim's
/// JointReaction labels its columns (<joint>_on_<body>_in_<frame>_fx ...).
std::string getLoadBodyName(const model::Model& model, int joint, LoadOnBody on);
std::string getLoadFrameName(const model::Model& model, int joint, LoadFrame frame);

}  // namespace kneesim::dynamics
