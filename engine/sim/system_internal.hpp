#pragma once
// Internal to sim/system*.cpp: the Simbody tree a System holds, the conversions to and from Simbody
// types, and the steps that build the tree, one file each:
//   system.cpp              the constructor's order, workspaces, kinematics, Jacobians, inverse dynamics
//   system_joints.cpp       OpenSim's joints as Simbody mobilized bodies (CustomJoint's SpatialTransform)
//   system_constraints.cpp  coordinate couplers and OpenSim's constraints (Point, PointOnLine,
//                           ConstantDistance, Weld) as Simbody constraints, and their errors
// Not installed: Simbody's types stay out of the public header system.hpp.

#ifdef NDEBUG
#error "Simbody headers must not be compiled with NDEBUG: Debian's Simbody is built without it (simbody#701)"
#endif
#include <Simbody.h>

#include <string>
#include <vector>

#include "sim/system.hpp"

namespace kneesim::sim {

namespace detail {

inline SimTK::Vec3 toSimTK(const Eigen::Vector3d& v) { return SimTK::Vec3(v.x(), v.y(), v.z()); }

inline SimTK::Transform toSimTK(const Eigen::Isometry3d& X) {
  SimTK::Mat33 R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R(i, j) = X.linear()(i, j);
  return SimTK::Transform(SimTK::Rotation(R, true), toSimTK(X.translation()));
}

inline Eigen::Isometry3d toEigen(const SimTK::Transform& X) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out.linear()(i, j) = X.R().asMat33()(i, j);
    out.translation()(i) = X.p()[i];
  }
  return out;
}

/// The Simbody system built from a model and the maps between the model's numbering and Simbody's.
struct SimbodyTree {
  SimTK::MultibodySystem system;
  SimTK::SimbodyMatterSubsystem matter{system};
  SimTK::GeneralForceSubsystem forces{system};
  std::vector<SimTK::MobilizedBodyIndex> mobod;  // per model body
  // Per model coordinate: the mobilized body whose mobilizer it is (the child body's, except in a
  // ScapulothoracicJoint, which chains three) and its q's index in that mobilizer.
  std::vector<SimTK::MobilizedBodyIndex> coord_mobod;
  std::vector<int> coord_mq;
  std::vector<SimTK::ConstraintIndex> couplers;  // per model coupler
  std::vector<SimTK::ConstraintIndex> constraints;  // per Model::constraints entry
  std::vector<int> q_index;  // per model coordinate: index into State Q
  std::vector<int> u_index;  // per model coordinate: index into State U
  int nq = 0, nu = 0;
  // Station Jacobians: for each model body, the coordinates of the joint that moves it and the
  // body's parent; coordinates whose mobilizer has qdot != u (Gimbal, Ball, Free, Ellipsoid).
  std::vector<std::vector<int>> body_coords;
  std::vector<int> parent_body;
  std::vector<int> n_coords;   // coordinates whose q differs from u, grouped by mobilizer
  std::vector<int> n_group;    // their mobilized body (index), one group per mobilizer
  SimTK::State default_state;  // realised to Model stage with Euler angles
};

/// Whether a joint of type @p t has qdot = u (N is the identity): false for the mobilizers whose
/// rotation q are Euler angles (Gimbal, Ball, Free, Ellipsoid and the ScapulothoracicJoint's).
bool isQDotEqualToU(model::JointType t);

/// Adds a mobilized body per joint of @p m (parents first) to @p tree, filling mobod, coord_mobod
/// and coord_mq; a body's invalid inertia is replaced by a point mass and said in @p warnings.
/// Throws InputError naming the joint when its description or Simbody rejects it.
void addJoints(const model::Model& m, const SystemOptions& options, SimbodyTree& tree,
               std::vector<std::string>& warnings);

/// Adds the model's coordinate couplers to @p tree as Simbody CoordinateCoupler constraints (one
/// per coupler, in the model's order, in tree.couplers); the joints must be added first.
void addCouplers(const model::Model& m, SimbodyTree& tree);

/// Adds Model::constraints to @p tree as Simbody's Ball, Rod, PointOnLine and Weld constraints
/// (in tree.constraints, in the model's order); the joints must be added first.
void addConstraints(const model::Model& m, SimbodyTree& tree);

}  // namespace detail

struct System::Impl : detail::SimbodyTree {};

struct Workspace::Impl {
  SimTK::State state;
  // Station-Jacobian scratch, sized once at creation.
  std::vector<Eigen::Matrix<double, 6, 1>> H;  // per coordinate: (w, v) of its body for u = 1
  std::vector<Eigen::Vector3d> p_GB;           // per coordinate: its mobilized body's origin in ground
  SimTK::Vector q_unit, u_out;                 // N^-1 columns for qdot != u mobilizers
  Eigen::Matrix<double, Eigen::Dynamic, 6> block;  // one joint's columns while converting
  Eigen::Matrix<double, 6, 6> NInv;
  // Inverse dynamics buffers, sized once at creation.
  SimTK::Vector mobility_forces, udot, residual;
  SimTK::Vector_<SimTK::SpatialVec> body_forces;
  std::vector<Eigen::Matrix<double, 6, 1>> subtree;  // per body: force on its subtree
  std::vector<Eigen::Vector3d> p_GBody;              // per body: its origin in ground
};

}  // namespace kneesim::sim
