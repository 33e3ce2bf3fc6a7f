#include "dynamics/inverse_dynamics.hpp"

#include "core/error.hpp"

namespace kneesim::dynamics {

InverseDynamics::InverseDynamics(model::ModelPtr model) : system_(std::make_shared<const sim::System>(std::move(model))) {}

InverseDynamics::InverseDynamics(std::shared_ptr<const sim::System> system) : system_(std::move(system)) {}

std::unique_ptr<IdWorkspace> InverseDynamics::createWorkspace() const {
  auto ws = std::make_unique<IdWorkspace>();
  ws->sim_ = system_->createWorkspace();
  // Couplers would make Simbody evaluate (and allocate for) their errors at every realisation.
  system_->setCouplersEnabled(*ws->sim_, false);
  const int nb = int(getModel().bodies.size());
  ws->F_applied_ = sim::SpatialColumns::Zero(6, nb);
  ws->A_G_ = sim::SpatialColumns::Zero(6, nb);
  ws->F_joint_ = sim::SpatialColumns::Zero(6, nb);
  // Size the kinematics buffers at the default state.
  system_->realizeVelocity(*ws->sim_, system_->getDefaultCoordinates(), Eigen::VectorXd::Zero(getNumCoordinates()));
  system_->calcTreeKinematics(*ws->sim_, ws->kin_);
  return ws;
}

void InverseDynamics::setState(IdWorkspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) const {
  system_->realizeVelocity(*ws.sim_, q, qdot);
  system_->calcTreeKinematics(*ws.sim_, ws.kin_);
  ws.F_applied_.setZero();
}

void InverseDynamics::calcGeneralizedForces(IdWorkspace& ws, const Eigen::VectorXd& qddot,
                                            Eigen::Ref<Eigen::VectorXd> tau) const {
  const model::Model& m = getModel();
  KNEESIM_CHECK(tau.size() == getNumCoordinates(), "generalised force size does not match the model");
  calcJointLoads(ws, qddot, ws.F_joint_);
  // The work rate of the load on the child per unit rate of c is c's generalised force.
  for (int c = 0; c < tau.size(); ++c)
    tau[c] = ws.kin_.H.col(c).dot(ws.F_joint_.col(m.joints[m.coordinates[c].joint].child_body));
}

void InverseDynamics::calcJointLoads(IdWorkspace& ws, const Eigen::VectorXd& qddot, sim::SpatialColumns& F_joint) const {
  const model::Model& m = getModel();
  KNEESIM_CHECK(F_joint.cols() == int(m.bodies.size()), "joint load columns do not match the bodies");
  const sim::TreeKinematics& kin = ws.kin_;
  sim::calcBodyAccelerations(m, kin, qddot, ws.A_G_);
  F_joint.setZero();
  // Joints are ordered parent before child, so the reverse order visits children first.
  for (int j = int(m.joints.size()) - 1; j >= 0; --j) {
    const model::Joint& jt = m.joints[j];
    const int b = jt.child_body;
    const model::Body& body = m.bodies[b];
    const Eigen::Isometry3d& X_GB = kin.X_GB[b];
    const Eigen::Vector3d w = kin.V_GB.col(b).head<3>(), alpha = ws.A_G_.col(b).head<3>(), a_o = ws.A_G_.col(b).tail<3>();
    const Eigen::Matrix3d R = X_GB.linear();
    const Eigen::Vector3d r = R * body.mass_center;  // origin to mass centre, in ground
    const Eigen::Matrix3d I_C = R * body.inertia * R.transpose();
    const Eigen::Vector3d a_C = a_o + alpha.cross(r) + w.cross(w.cross(r));
    const Eigen::Vector3d f = body.mass * (a_C - m.gravity);  // net force minus gravity
    const Eigen::Vector3d moment = I_C * alpha + w.cross(I_C * w) + r.cross(f);
    // The joint supplies what the motion needs beyond the applied loads and what the children
    // pull (they are already in F_joint.col(b) as -reactions, shifted to b's origin below).
    F_joint.col(b).head<3>() += moment - ws.F_applied_.col(b).head<3>();
    F_joint.col(b).tail<3>() += f - ws.F_applied_.col(b).tail<3>();
    // The parent feels the reaction: shift the load from b's origin to the parent's origin.
    const int p = jt.parent_body;
    if (p == 0) continue;
    const Eigen::Vector3d d = X_GB.translation() - kin.X_GB[p].translation();
    F_joint.col(p).head<3>() += F_joint.col(b).head<3>() + d.cross(Eigen::Vector3d(F_joint.col(b).tail<3>()));
    F_joint.col(p).tail<3>() += F_joint.col(b).tail<3>();
  }
}

}  // namespace kneesim::dynamics
