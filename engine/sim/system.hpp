#pragma once
// The Simbody multibody system built from an immutable model description.
//
// Model/Data split: a System is built once from a Model and never changes; every buffer a
// computation needs (the Simbody State, Jacobian scratch) lives in a Workspace, one per thread.
// Simbody types stay out of this header.

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "model/model.hpp"

namespace kneesim::sim {

/// Spatial vectors of every model body, column b for body b (ground is column 0): rows 0-2 the
/// rotational part, rows 3-5 the translational part, both expressed in ground (Simbody's
/// SpatialVec order). As forces: the moment about the body's origin and the force. As motions:
/// the angular velocity or acceleration and that of the body's origin.
using SpatialColumns = Eigen::Matrix<double, 6, Eigen::Dynamic>;

/// The kinematics of a realised velocity state that recursive dynamics needs, gathered in one
/// sweep: each of Simbody's accessors looks its subsystem up again, which costs more than the
/// arithmetic of a Newton-Euler sweep. Filled by System::calcTreeKinematics().
struct TreeKinematics {
  std::vector<Eigen::Isometry3d> X_GB;  ///< Per body: its pose in ground.
  SpatialColumns V_GB;  ///< Per body: angular velocity and velocity of its origin, in ground.
  SpatialColumns a_GB;  ///< Per body: its acceleration when qddot = 0 (Simbody's total Coriolis acceleration).
  SpatialColumns H;     ///< Per coordinate: its motion axis (System::getMobilityAxis()).
};

/// Spatial accelerations of every body of @p model for the accelerations @p qddot at the state
/// @p kin was gathered from (column b: angular acceleration and acceleration of b's origin, in
/// ground): A = J qddot + Jdot qdot. @p A_G must have one column per body. No allocation.
void calcBodyAccelerations(const model::Model& model, const TreeKinematics& kin, const Eigen::VectorXd& qddot,
                           SpatialColumns& A_G);

/// Per-thread scratch data for a System: the Simbody State and Jacobian buffers.
class Workspace {
 public:
  ~Workspace();
  Workspace(const Workspace&) = delete;
  Workspace& operator=(const Workspace&) = delete;

 private:
  friend class System;
  struct Impl;
  explicit Workspace(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// How a System is built.
struct SystemOptions {
  /// Build CustomJoints with Simbody's MobilizedBody::FunctionBased (as OpenSim does) instead of
  /// kneesim's own Custom mobilizer with the same kinematics. FunctionBased allocates on every
  /// evaluation and is about half as fast; it is kept to cross-check the two in tests.
  bool simbody_function_based = false;
};

/// A Simbody MultibodySystem built from a model: a Custom mobilizer evaluating the model's
/// functions for CustomJoints (the kinematics of Simbody's FunctionBased mobilizer, which OpenSim
/// uses), native mobilizers for the other joint types (Ellipsoid for EllipsoidJoint; Ellipsoid,
/// Pin and Weld in a chain with two massless bodies for ScapulothoracicJoint, as OpenSim builds
/// it), Constraint::CoordinateCoupler for couplers and Ball, PointOnLine, Rod and Weld
/// constraints for Model::constraints.
class System {
 public:
  /// Builds the Simbody system. Throws InputError (naming the model file and joint) if Simbody
  /// rejects part of the model.
  explicit System(model::ModelPtr model, SystemOptions options = {});
  ~System();
  System(const System&) = delete;
  System& operator=(const System&) = delete;

  const model::Model& getModel() const { return *model_; }
  const model::ModelPtr& getModelPtr() const { return model_; }
  int getNumCoordinates() const { return int(model_->coordinates.size()); }
  /// Problems noticed while building that did not stop it (e.g. an invalid inertia replaced).
  const std::vector<std::string>& getWarnings() const { return warnings_; }

  /// A fresh workspace with default coordinate values, realised to Position.
  std::unique_ptr<Workspace> createWorkspace() const;

  /// Default values of all coordinates, in model order.
  Eigen::VectorXd getDefaultCoordinates() const;

  /// Sets all coordinates (model order, SI units: rad or m) and realises positions.
  void realizePosition(Workspace& ws, const Eigen::VectorXd& q) const;

  /// X_GB, the pose of body @p body in ground (after realizePosition).
  Eigen::Isometry3d getBodyPose(const Workspace& ws, int body) const;

  /// Location in ground of the point p_BS fixed on body @p body.
  Eigen::Vector3d findStationLocation(const Workspace& ws, int body, const Eigen::Vector3d& p_BS) const;

  /// Jacobian of station locations in ground with respect to the model coordinates:
  /// J is 3*n x getNumCoordinates(), rows 3i..3i+2 belong to station i. @p J must already
  /// have that size (no allocation once the workspace has seen the station count).
  void calcStationJacobian(Workspace& ws, const std::vector<int>& bodies,
                           const std::vector<Eigen::Vector3d>& stations, Eigen::Ref<Eigen::MatrixXd> J) const;

  /// Generalised forces (one per model coordinate, in the coordinates' speeds u) equivalent to
  /// the body forces @p F (see SpatialColumns: column b the moment about body b's origin and the
  /// force, in ground): tau = J^T F. After realizePosition(); @p tau has one entry per
  /// coordinate. Allocates nothing once the workspace has been used once.
  void calcGeneralizedForcesFromBodyForces(Workspace& ws, const SpatialColumns& F,
                                           Eigen::Ref<Eigen::VectorXd> tau) const;

  /// Position-level errors of the couplers, scale * f(independents) - dependent, one per coupler
  /// (Simbody's qErr; computed from the model's function for couplers disabled in @p ws).
  Eigen::VectorXd calcCouplerErrors(const Workspace& ws) const;

  /// Enables or disables the couplers' Simbody constraints in @p ws (they are enabled in a new
  /// workspace). Inverse kinematics eliminates couplers itself and disables them: Simbody would
  /// otherwise evaluate their errors, allocating, at every realizePosition().
  void setCouplersEnabled(Workspace& ws, bool enabled) const;

  /// Sets the coordinates @p q and their rates @p qdot (model order, SI units) and realises
  /// velocities. The rates are used as Simbody's speeds u even for mobilizers whose qdot differs
  /// from u (Ball, Free, Gimbal), as OpenSim's InverseDynamicsTool does. No allocation when the
  /// workspace's couplers are disabled (see setCouplersEnabled()).
  void realizeVelocity(Workspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) const;

  /// Inverse dynamics at the realised velocity state with Simbody's own algorithm
  /// (calcResidualForceIgnoringConstraints, what OpenSim's InverseDynamicsSolver calls): the
  /// generalised forces tau (model coordinate order) that give the accelerations @p qddot under
  /// gravity and the applied body forces @p F_G (one column per model body, see SpatialColumns;
  /// ground's column is ignored), ignoring the couplers: tau = M qddot + C - G - J^T F.
  /// Simbody allocates in it (about 10 blocks a call): dynamics::InverseDynamics computes the same
  /// without allocating; this one is the reference it is tested against.
  void calcResidualForces(Workspace& ws, const Eigen::VectorXd& qddot, const SpatialColumns& F_G,
                          Eigen::Ref<Eigen::VectorXd> tau) const;

  /// Gathers the kinematics of the state realised by realizeVelocity() into @p kin (see
  /// TreeKinematics). Allocates only when @p kin is not yet sized for this model.
  void calcTreeKinematics(const Workspace& ws, TreeKinematics& kin) const;

  /// The motion axis of coordinate @p coordinate after realizePosition(): the spatial velocity
  /// (angular velocity, velocity of the origin; in ground) of its joint's child body relative to
  /// the parent for a unit rate of the coordinate (a column of Simbody's H matrix). A load
  /// (moment about the child's origin, force) on the child does work at the rate axis . load.
  Eigen::Matrix<double, 6, 1> getMobilityAxis(const Workspace& ws, int coordinate) const;

  /// Spatial velocity of body @p body (angular velocity and velocity of its origin, in ground)
  /// after realizeVelocity().
  Eigen::Matrix<double, 6, 1> getBodyVelocity(const Workspace& ws, int body) const;

  /// The model's coordinates in Simbody's mobility order, which is the order OpenSim writes
  /// generalised forces in (Model::getCoordinatesInMultibodyTreeOrder).
  std::vector<int> getCoordinatesInTreeOrder() const;

  /// Enables or disables Simbody's constraints for Model::constraints (Point, PointOnLine,
  /// ConstantDistance, Weld) in @p ws; they are enabled in a new workspace. Inverse kinematics
  /// enforces them itself (ik/constraint_terms.hpp) and disables them, as it does the couplers.
  void setConstraintsEnabled(Workspace& ws, bool enabled) const;

  /// Simbody's position errors of Model::constraints[k] at the positions realised in @p ws
  /// (the constraint must be enabled there): Ball p2 - p1 (m), PointOnLine the two offsets
  /// across the line (m), Rod its length error, Weld three perpendicularity dot products then
  /// the origin offset (m).
  Eigen::VectorXd calcConstraintPositionErrors(const Workspace& ws, int k) const;

  /// Number of position equations of Model::constraints[k] (3, 2, 1 or 6).
  int getNumConstraintEquations(int k) const;

  /// Whether N (qdot = N u) is the identity for every mobilizer, so dq = du.
  bool isQDotEqualToU() const { return qdot_is_u_; }

 private:
  struct Impl;
  model::ModelPtr model_;
  std::unique_ptr<Impl> impl_;
  std::vector<std::string> warnings_;
  bool qdot_is_u_ = true;
};

}  // namespace kneesim::sim
