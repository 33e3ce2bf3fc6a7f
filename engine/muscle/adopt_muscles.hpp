#pragma once
// Muscles of one model carried onto another model of the same bones: JW's 24-DOF knee model has
// the UF "JW All Body" model's bodies (same names, same frames, except the patella, re-expressed
// in the button's frame) but no muscles; the UF model has 54. adoptMuscles() copies the donor's
// muscles and wrap objects onto the target's bodies, each point and wrap frame re-expressed in
// the target body's frame, so that the target's kinematics (IK, seated knee path) drive the
// donor's muscle paths.

#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/error.hpp"
#include "model/model.hpp"

namespace kneesim::muscle {

/// How a donor body maps onto a target body.
struct BodyCorrespondence {
  std::string donor_body;
  std::string target_body;
  /// Pose of the donor body's frame in the target body's frame (identity: the same frame).
  Eigen::Isometry3d X_TD = Eigen::Isometry3d::Identity();
};

/// What adoptMuscles() did.
struct AdoptedMuscles {
  model::ModelPtr model;            ///< The target with the adopted muscles and wrap objects.
  std::vector<std::string> adopted;  ///< Muscle names, in the donor's order.
  /// "name: why" for each donor muscle left out (a body or coordinate the target lacks, or
  /// excluded by name).
  std::vector<std::string> left_out;
};

/// The correspondence of donor body @p body that puts it where the donor's default pose puts it
/// relative to its parent body, with the target's joint of that body at its zero transform
/// (X_PF X_BM^-1): how the knee model tool placed the patellar button's frame (knee_model.cpp,
/// X_P_patsrc). The parent must have the same name and frame in both models. Throws InputError at
/// @p where if either model lacks the body or its parent joint, or the parents differ.
BodyCorrespondence calcDefaultPoseCorrespondence(const model::Model& target, const model::Model& donor,
                                                 const std::string& body, const SourceLocation& where);

/// Copies @p donor's enabled muscles onto @p target: a donor body maps by @p map, else onto the
/// target body of the same name with the same frame; conditional and moving points' coordinates
/// map by name. A muscle whose points or wrap objects lie on a body the target lacks (or whose
/// coordinates it lacks), or whose name is in @p exclude, is left out and listed. Wrap objects
/// used by adopted muscles are copied. The target's own muscles and actuators are kept. Throws
/// InputError at @p where if a name in @p exclude is not a donor muscle.
AdoptedMuscles adoptMuscles(const model::Model& target, const model::Model& donor,
                            const std::vector<BodyCorrespondence>& map, const std::vector<std::string>& exclude,
                            const SourceLocation& where);

}  // namespace kneesim::muscle
