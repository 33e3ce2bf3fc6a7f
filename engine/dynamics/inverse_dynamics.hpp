#pragma once
// Inverse dynamics on an immutable model: the generalised forces that produce given
// accelerations under gravity and applied loads, and the net loads every joint transmits.
//
// This is the API other analyses build on (static optimisation, joint reaction):
//   auto id = std::make_shared<const InverseDynamics>(model);   // once, shared by threads
//   auto ws = id->createWorkspace();                             // once per thread
//   sim::SpatialColumns& F = ws->updAppliedForces();             // zeroed by setState()
//   id->setState(*ws, q, qdot);                                  // positions and velocities
//   loads.addBodyForces(id->getSystem(), ws->updSimWorkspace(), t, F);  // external loads
//   id->calcGeneralizedForces(*ws, qddot, tau);                  // tau, model order
//   id->calcJointLoads(*ws, qddot, F_joint);                     // net joint loads
// Nothing allocates after createWorkspace(). Coordinate couplers are ignored (each coupled
// coordinate gets its own generalised force), as OpenSim's InverseDynamicsSolver does.

#include <memory>

#include <Eigen/Core>

#include "model/model.hpp"
#include "sim/system.hpp"

namespace kneesim::dynamics {

/// Per-thread buffers of InverseDynamics.
class IdWorkspace {
 public:
  /// The Simbody workspace (for body poses, external loads, station positions).
  sim::Workspace& updSimWorkspace() { return *sim_; }
  const sim::Workspace& getSimWorkspace() const { return *sim_; }
  /// Forces applied to the bodies other than gravity (column per body: moment about the body's
  /// origin and force, in ground). setState() zeroes them; add loads after it.
  sim::SpatialColumns& updAppliedForces() { return F_applied_; }
  const sim::SpatialColumns& getAppliedForces() const { return F_applied_; }

 private:
  friend class InverseDynamics;
  std::unique_ptr<sim::Workspace> sim_;
  sim::TreeKinematics kin_;
  sim::SpatialColumns F_applied_, A_G_, F_joint_;
};

/// Inverse dynamics of one model; immutable and shared between threads.
class InverseDynamics {
 public:
  /// Builds the Simbody system of @p model (throws InputError if Simbody rejects it).
  explicit InverseDynamics(model::ModelPtr model);
  /// Uses an existing system.
  explicit InverseDynamics(std::shared_ptr<const sim::System> system);

  const sim::System& getSystem() const { return *system_; }
  const model::Model& getModel() const { return system_->getModel(); }
  int getNumCoordinates() const { return system_->getNumCoordinates(); }

  /// A workspace for one thread (couplers disabled: inverse dynamics ignores them).
  std::unique_ptr<IdWorkspace> createWorkspace() const;

  /// Sets coordinates @p q and rates @p qdot (model order, SI), realises velocities, and zeroes
  /// the applied forces.
  void setState(IdWorkspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) const;

  /// Generalised forces @p tau (model order; N·m or N) that produce @p qddot at the state set
  /// by setState() under gravity and ws's applied forces: M qddot + C - G - J^T F, what
  /// Simbody's calcResidualForceIgnoringConstraints gives (OpenSim's InverseDynamicsSolver),
  /// computed as the joint loads of calcJointLoads() projected on each coordinate's motion axis.
  void calcGeneralizedForces(IdWorkspace& ws, const Eigen::VectorXd& qddot, Eigen::Ref<Eigen::VectorXd> tau) const;

  /// Net loads the joints transmit at the state set by setState() with accelerations @p qddot
  /// and ws's applied forces: column b of @p F_joint is the spatial force body b's parent
  /// applies to b through b's joint (moment about b's origin, force; in ground), from a
  /// Newton-Euler sweep from the leaves to the root. It includes the part that drives the
  /// joint's own coordinates: projecting it on the joint's motion axes gives calcGeneralizedForces().
  /// Column 0 (ground) is zero. @p F_joint must have one column per body.
  void calcJointLoads(IdWorkspace& ws, const Eigen::VectorXd& qddot, sim::SpatialColumns& F_joint) const;

 private:
  std::shared_ptr<const sim::System> system_;
};

}  // namespace kneesim::dynamics
