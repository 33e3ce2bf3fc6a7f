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
/// uses), native mobilizers for the other joint types, Constraint::CoordinateCoupler for couplers.
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

  /// Position-level errors of the couplers, scale * f(independents) - dependent, one per coupler
  /// (Simbody's qErr; computed from the model's function for couplers disabled in @p ws).
  Eigen::VectorXd calcCouplerErrors(const Workspace& ws) const;

  /// Enables or disables the couplers' Simbody constraints in @p ws (they are enabled in a new
  /// workspace). Inverse kinematics eliminates couplers itself and disables them: Simbody would
  /// otherwise evaluate their errors, allocating, at every realizePosition().
  void setCouplersEnabled(Workspace& ws, bool enabled) const;

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
