// System (sim/system.hpp): its construction in order, workspaces, positions and velocities, station
// Jacobians, generalised forces and inverse dynamics. The joints are built in system_joints.cpp, the
// couplers and constraints in system_constraints.cpp.

#include "sim/system.hpp"

#include <algorithm>
#include <string>

#include "core/error.hpp"
#include "sim/system_internal.hpp"

namespace kneesim::sim {

using detail::toEigen;
using detail::toSimTK;

namespace {

/// Realises the topology and the default State (Euler angles, the model's default coordinates)
/// and finds each coordinate's q and u in the State.
void realizeDefaultState(const model::Model& m, detail::SimbodyTree& d) {
  try {
    d.system.realizeTopology();
    d.default_state = d.system.getDefaultState();
    d.matter.setUseEulerAngles(d.default_state, true);
    d.system.realizeModel(d.default_state);
  } catch (const std::exception& e) {
    throw InputError({m.source_file, 0, ""}, std::string("Simbody could not build the model: ") + e.what());
  }
  d.nq = d.default_state.getNQ();
  d.nu = d.default_state.getNU();
  d.q_index.resize(m.coordinates.size());
  d.u_index.resize(m.coordinates.size());
  for (size_t i = 0; i < m.coordinates.size(); ++i) {
    const SimTK::MobilizedBody& mb = d.matter.getMobilizedBody(d.coord_mobod[i]);
    KNEESIM_CHECK(d.coord_mq[i] < mb.getNumQ(d.default_state), "coordinate beyond its mobilizer's q");
    d.q_index[i] = int(mb.getFirstQIndex(d.default_state)) + d.coord_mq[i];
    d.u_index[i] = int(mb.getFirstUIndex(d.default_state)) + d.coord_mq[i];
  }
  // With Euler angles a Ball or Free mobilizer uses 3 of the 4 rotation q slots Simbody keeps
  // for its quaternion, so State::getNQ() may exceed the coordinates; the q in use must not.
  int nq_in_use = 0;
  for (SimTK::MobilizedBodyIndex b(1); b < d.matter.getNumBodies(); ++b)
    nq_in_use += d.matter.getMobilizedBody(b).getNumQ(d.default_state);
  KNEESIM_CHECK(nq_in_use == int(m.coordinates.size()),
                "Simbody uses " + std::to_string(nq_in_use) + " q but the model has " +
                    std::to_string(m.coordinates.size()) + " coordinates");
  for (size_t i = 0; i < m.coordinates.size(); ++i) d.default_state.updQ()[d.q_index[i]] = m.coordinates[i].default_value;
}

/// The tables the station Jacobians walk: each body's coordinates and parent, and the
/// coordinates whose mobilizer has qdot != u, grouped by mobilizer.
void mapJacobianTree(const model::Model& m, detail::SimbodyTree& d) {
  d.body_coords.assign(m.bodies.size(), {});
  d.parent_body.assign(m.bodies.size(), -1);
  for (size_t j = 0; j < m.joints.size(); ++j) {
    const model::Joint& jt = m.joints[j];
    d.body_coords[jt.child_body] = jt.coordinates;
    d.parent_body[jt.child_body] = jt.parent_body;
    if (!detail::isQDotEqualToU(jt.type))
      for (size_t k = 0; k < jt.coordinates.size(); ++k) {
        if (jt.type == model::JointType::Scapulothoracic && k == 3) continue;  // the winging Pin has qdot = u
        d.n_coords.push_back(jt.coordinates[k]);
        d.n_group.push_back(int(d.coord_mobod[jt.coordinates[k]]));
      }
  }
}

}  // namespace

Workspace::Workspace(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Workspace::~Workspace() = default;

System::~System() = default;

System::System(model::ModelPtr model, SystemOptions options)
    : model_(std::move(model)), impl_(std::make_unique<Impl>()) {
  const model::Model& m = *model_;
  Impl& d = *impl_;
  SimTK::Force::Gravity(d.forces, d.matter, toSimTK(m.gravity));
  detail::addJoints(m, options, d, warnings_);
  for (const model::Joint& jt : m.joints) qdot_is_u_ = qdot_is_u_ && detail::isQDotEqualToU(jt.type);
  detail::addCouplers(m, d);
  detail::addConstraints(m, d);
  realizeDefaultState(m, d);
  mapJacobianTree(m, d);
  d.system.realize(d.default_state, SimTK::Stage::Position);
}

std::unique_ptr<Workspace> System::createWorkspace() const {
  auto impl = std::make_unique<Workspace::Impl>();
  impl->state = impl_->default_state;
  impl->H.assign(model_->coordinates.size(), Eigen::Matrix<double, 6, 1>::Zero());
  impl->p_GB.assign(model_->coordinates.size(), Eigen::Vector3d::Zero());
  impl->q_unit.resize(impl_->nq);
  impl->u_out.resize(impl_->nu);
  impl->NInv.setZero();
  impl->mobility_forces.resize(impl_->nu);
  impl->mobility_forces = 0;
  impl->udot.resize(impl_->nu);
  impl->residual.resize(impl_->nu);
  impl->body_forces.resize(impl_->matter.getNumBodies());
  impl->subtree.assign(model_->bodies.size(), Eigen::Matrix<double, 6, 1>::Zero());
  impl->p_GBody.assign(model_->bodies.size(), Eigen::Vector3d::Zero());
  impl_->system.realize(impl->state, SimTK::Stage::Position);
  return std::unique_ptr<Workspace>(new Workspace(std::move(impl)));
}

Eigen::VectorXd System::getDefaultCoordinates() const {
  Eigen::VectorXd q(model_->coordinates.size());
  for (size_t i = 0; i < model_->coordinates.size(); ++i) q[i] = model_->coordinates[i].default_value;
  return q;
}

void System::realizePosition(Workspace& ws, const Eigen::VectorXd& q) const {
  KNEESIM_ASSERT(q.size() == getNumCoordinates());
  SimTK::Vector& Q = ws.impl_->state.updQ();
  for (int i = 0; i < q.size(); ++i) Q[impl_->q_index[i]] = q[i];
  impl_->system.realize(ws.impl_->state, SimTK::Stage::Position);
}

Eigen::Isometry3d System::getBodyPose(const Workspace& ws, int body) const {
  return toEigen(impl_->matter.getMobilizedBody(impl_->mobod[body]).getBodyTransform(ws.impl_->state));
}

Eigen::Vector3d System::findStationLocation(const Workspace& ws, int body, const Eigen::Vector3d& p_BS) const {
  const SimTK::Vec3 p = impl_->matter.getMobilizedBody(impl_->mobod[body])
                            .findStationLocationInGround(ws.impl_->state, toSimTK(p_BS));
  return Eigen::Vector3d(p[0], p[1], p[2]);
}

void System::calcStationJacobian(Workspace& ws, const std::vector<int>& bodies,
                                 const std::vector<Eigen::Vector3d>& stations, Eigen::Ref<Eigen::MatrixXd> J) const {
  // Column c of the Jacobian for a station S on a body at or below the body B that coordinate c
  // moves is w x (p_S - p_B) + v, with (w, v) = H_c, the spatial velocity of B in ground for
  // u_c = 1 (Simbody's hinge-matrix column, cached at Position stage). This costs O(stations x
  // depth) small products instead of one Simbody sweep per row, and allocates nothing.
  Workspace::Impl& w = *ws.impl_;
  const Impl& d = *impl_;
  const model::Model& m = *model_;
  const int n = int(bodies.size());
  KNEESIM_CHECK(int(stations.size()) == n && J.rows() == 3 * n && J.cols() == getNumCoordinates(),
                "station Jacobian sizes do not match");
  for (size_t c = 0; c < m.coordinates.size(); ++c) {
    const SimTK::MobilizedBody& mb = d.matter.getMobilizedBody(d.coord_mobod[c]);
    const SimTK::SpatialVec H = mb.getHCol(w.state, SimTK::MobilizerUIndex(d.coord_mq[c]));
    w.H[c] << H[0][0], H[0][1], H[0][2], H[1][0], H[1][1], H[1][2];
    const SimTK::Vec3& p = mb.getBodyOriginLocation(w.state);
    w.p_GB[c] = Eigen::Vector3d(p[0], p[1], p[2]);
  }
  J.setZero();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p_S = findStationLocation(ws, bodies[i], stations[i]);
    for (int a = bodies[i]; a > 0; a = d.parent_body[a])
      for (int c : d.body_coords[a])
        J.block<3, 1>(3 * i, c) = w.H[c].head<3>().cross(p_S - w.p_GB[c]) + w.H[c].tail<3>();
  }
  if (d.n_coords.empty()) return;
  // Mobilizers with qdot = N u, N != I: dp/dq = dp/du N^-1, one mobilizer's block at a time.
  for (size_t k = 0; k < d.n_coords.size();) {
    const int group = d.n_group[k];
    size_t e = k;
    while (e < d.n_coords.size() && d.n_group[e] == group) ++e;
    const int nb = int(e - k);
    for (int jj = 0; jj < nb; ++jj) {
      w.q_unit = 0;
      w.q_unit[d.q_index[d.n_coords[k + jj]]] = 1;
      d.matter.multiplyByNInv(w.state, false, w.q_unit, w.u_out);
      for (int ii = 0; ii < nb; ++ii) w.NInv(ii, jj) = w.u_out[d.u_index[d.n_coords[k + ii]]];
    }
    if (w.block.rows() != J.rows()) w.block.resize(J.rows(), 6);
    for (int ii = 0; ii < nb; ++ii) w.block.col(ii) = J.col(d.n_coords[k + ii]);
    for (int jj = 0; jj < nb; ++jj) {
      J.col(d.n_coords[k + jj]).setZero();
      for (int ii = 0; ii < nb; ++ii) J.col(d.n_coords[k + jj]) += w.NInv(ii, jj) * w.block.col(ii);
    }
    k = e;
  }
}

void System::calcGeneralizedForcesFromBodyForces(Workspace& ws, const SpatialColumns& F,
                                                 Eigen::Ref<Eigen::VectorXd> tau) const {
  // tau_c = H_c . (the force on the subtree of the body coordinate c moves, as a torque about
  // that body's origin and a force), with H_c Simbody's hinge-matrix column (see
  // calcStationJacobian). Subtree sums keep torques about the ground origin so they add without
  // shifting. Simbody's multiplyBySystemJacobianTranspose does the same but allocates.
  Workspace::Impl& w = *ws.impl_;
  const Impl& d = *impl_;
  const model::Model& m = *model_;
  KNEESIM_CHECK(F.cols() == int(m.bodies.size()) && tau.size() == getNumCoordinates(),
                "body force and generalised force sizes do not match the model");
  for (size_t b = 1; b < m.bodies.size(); ++b) {
    const SimTK::Vec3& p = d.matter.getMobilizedBody(d.mobod[b]).getBodyOriginLocation(w.state);
    w.p_GBody[b] = Eigen::Vector3d(p[0], p[1], p[2]);
    w.subtree[b].head<3>() = F.col(b).head<3>() + w.p_GBody[b].cross(Eigen::Vector3d(F.col(b).tail<3>()));
    w.subtree[b].tail<3>() = F.col(b).tail<3>();
  }
  for (auto j = m.joints.rbegin(); j != m.joints.rend(); ++j)  // children before parents
    if (j->parent_body > 0) w.subtree[j->parent_body] += w.subtree[j->child_body];
  for (size_t c = 0; c < m.coordinates.size(); ++c) {
    // The coordinate's own mobilizer (a ScapulothoracicJoint chains three above its body); the
    // subtree it moves is still that of the joint's child body.
    const int a = m.joints[m.coordinates[c].joint].child_body;
    const SimTK::MobilizedBody& mb = d.matter.getMobilizedBody(d.coord_mobod[c]);
    const SimTK::SpatialVec& H = mb.getHCol(w.state, SimTK::MobilizerUIndex(d.coord_mq[c]));
    const SimTK::Vec3& o = mb.getBodyOriginLocation(w.state);
    const Eigen::Vector3d f = w.subtree[a].tail<3>();
    const Eigen::Vector3d M = w.subtree[a].head<3>() - Eigen::Vector3d(o[0], o[1], o[2]).cross(f);
    tau[int(c)] = H[0][0] * M[0] + H[0][1] * M[1] + H[0][2] * M[2] + H[1][0] * f[0] + H[1][1] * f[1] + H[1][2] * f[2];
  }
}

void System::realizeVelocity(Workspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) const {
  KNEESIM_ASSERT(q.size() == getNumCoordinates() && qdot.size() == getNumCoordinates());
  SimTK::State& s = ws.impl_->state;
  SimTK::Vector& Q = s.updQ();
  SimTK::Vector& U = s.updU();
  for (int i = 0; i < q.size(); ++i) {
    Q[impl_->q_index[i]] = q[i];
    U[impl_->u_index[i]] = qdot[i];
  }
  impl_->system.realize(s, SimTK::Stage::Velocity);
}

void System::calcResidualForces(Workspace& ws, const Eigen::VectorXd& qddot, const SpatialColumns& F_G,
                                Eigen::Ref<Eigen::VectorXd> tau) const {
  const model::Model& m = *model_;
  const Impl& d = *impl_;
  Workspace::Impl& w = *ws.impl_;
  KNEESIM_CHECK(qddot.size() == getNumCoordinates() && tau.size() == getNumCoordinates() &&
                    F_G.cols() == int(m.bodies.size()),
                "inverse dynamics sizes do not match the model");
  for (int i = 0; i < qddot.size(); ++i) w.udot[d.u_index[i]] = qddot[i];
  // Gravity as body forces (the Gravity force element acts only when Dynamics is realised,
  // which inverse dynamics does not need): m g at the mass centre, moment about the origin.
  const SimTK::Vec3 g = toSimTK(m.gravity);
  w.body_forces = SimTK::SpatialVec(SimTK::Vec3(0), SimTK::Vec3(0));
  for (size_t b = 1; b < m.bodies.size(); ++b) {
    const SimTK::MobilizedBody& mb = d.matter.getMobilizedBody(d.mobod[b]);
    const SimTK::Vec3 p_BCm_G = mb.getBodyRotation(w.state) * toSimTK(m.bodies[b].mass_center);
    const SimTK::Vec3 f = m.bodies[b].mass * g + SimTK::Vec3(F_G(3, b), F_G(4, b), F_G(5, b));
    const SimTK::Vec3 moment = SimTK::cross(p_BCm_G, m.bodies[b].mass * g) + SimTK::Vec3(F_G(0, b), F_G(1, b), F_G(2, b));
    w.body_forces[d.mobod[b]] += SimTK::SpatialVec(moment, f);
  }
  d.matter.calcResidualForceIgnoringConstraints(w.state, w.mobility_forces, w.body_forces, w.udot, w.residual);
  for (int i = 0; i < tau.size(); ++i) tau[i] = w.residual[d.u_index[i]];
}

void System::calcTreeKinematics(const Workspace& ws, TreeKinematics& kin) const {
  const model::Model& m = *model_;
  const Impl& d = *impl_;
  const SimTK::State& state = ws.impl_->state;
  const int nb = int(m.bodies.size()), nc = getNumCoordinates();
  if (int(kin.X_GB.size()) != nb) kin.X_GB.assign(nb, Eigen::Isometry3d::Identity());
  if (kin.V_GB.cols() != nb) kin.V_GB.resize(6, nb);
  if (kin.a_GB.cols() != nb) kin.a_GB.resize(6, nb);
  if (kin.H.cols() != nc) kin.H.resize(6, nc);
  for (int b = 0; b < nb; ++b) {
    const SimTK::MobilizedBody& mb = d.matter.getMobilizedBody(d.mobod[b]);
    kin.X_GB[b] = toEigen(mb.getBodyTransform(state));
    const SimTK::SpatialVec& V = mb.getBodyVelocity(state);
    kin.V_GB.col(b) << V[0][0], V[0][1], V[0][2], V[1][0], V[1][1], V[1][2];
    const SimTK::SpatialVec& a = d.matter.getTotalCoriolisAcceleration(state, d.mobod[b]);
    kin.a_GB.col(b) << a[0][0], a[0][1], a[0][2], a[1][0], a[1][1], a[1][2];
  }
  for (int c = 0; c < nc; ++c) kin.H.col(c) = getMobilityAxis(ws, c);
}

void calcBodyAccelerations(const model::Model& m, const TreeKinematics& kin, const Eigen::VectorXd& qddot,
                           SpatialColumns& A_G) {
  KNEESIM_CHECK(qddot.size() == int(m.coordinates.size()) && A_G.cols() == int(m.bodies.size()) &&
                    int(kin.X_GB.size()) == int(m.bodies.size()),
                "body acceleration sizes do not match the model");
  // J qddot recursively from the root (the parent's acceleration shifted to the child's origin
  // has no velocity term here: those are all in a_GB), then a_GB = Jdot qdot.
  A_G.col(0).setZero();
  for (const model::Joint& jt : m.joints) {
    const int b = jt.child_body, p = jt.parent_body;
    Eigen::Matrix<double, 6, 1> A = A_G.col(p);
    const Eigen::Vector3d r = kin.X_GB[b].translation() - kin.X_GB[p].translation();
    A.tail<3>() += Eigen::Vector3d(A_G.col(p).head<3>()).cross(r);
    for (int c : jt.coordinates) A += qddot[c] * kin.H.col(c);
    A_G.col(b) = A;
  }
  A_G.rightCols(A_G.cols() - 1) += kin.a_GB.rightCols(A_G.cols() - 1);
}

Eigen::Matrix<double, 6, 1> System::getMobilityAxis(const Workspace& ws, int coordinate) const {
  const model::Coordinate& co = model_->coordinates[coordinate];
  const SimTK::State& s = ws.impl_->state;
  // The coordinate's own mobilizer: in a ScapulothoracicJoint's chain it moves an intermediate
  // body, whose axis is shifted to the child body's origin (the rest of the chain is rigid).
  const SimTK::MobilizedBody& mb = impl_->matter.getMobilizedBody(impl_->coord_mobod[coordinate]);
  SimTK::SpatialVec H = mb.getHCol(s, SimTK::MobilizerUIndex(impl_->coord_mq[coordinate]));
  const SimTK::MobilizedBodyIndex child = impl_->mobod[model_->joints[co.joint].child_body];
  if (impl_->coord_mobod[coordinate] != child) {
    const SimTK::Vec3 r = impl_->matter.getMobilizedBody(child).getBodyOriginLocation(s) - mb.getBodyOriginLocation(s);
    H[1] += SimTK::cross(H[0], r);
  }
  Eigen::Matrix<double, 6, 1> out;
  out << H[0][0], H[0][1], H[0][2], H[1][0], H[1][1], H[1][2];
  return out;
}

Eigen::Matrix<double, 6, 1> System::getBodyVelocity(const Workspace& ws, int body) const {
  const SimTK::SpatialVec& V = impl_->matter.getMobilizedBody(impl_->mobod[body]).getBodyVelocity(ws.impl_->state);
  Eigen::Matrix<double, 6, 1> out;
  out << V[0][0], V[0][1], V[0][2], V[1][0], V[1][1], V[1][2];
  return out;
}

std::vector<int> System::getCoordinatesInTreeOrder() const {
  std::vector<int> order(model_->coordinates.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = int(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return impl_->u_index[a] < impl_->u_index[b]; });
  return order;
}

}  // namespace kneesim::sim