// One static-optimisation frame: the equations of motion as linear equalities in the
// activations (moment arms times optimal forces against inverse dynamics), solved by SoSolver.
#include "muscle/static_optimization.hpp"

#include <cmath>
#include <mutex>

#include "core/error.hpp"
#include "identify/least_squares.hpp"
#include "muscle/so_solver.hpp"
#include "sim/interior_point.hpp"

namespace kneesim::muscle {

SoWorkspace::~SoWorkspace() = default;

StaticOptimization::StaticOptimization(std::shared_ptr<const dynamics::InverseDynamics> id, const SoOptions& options)
    : id_(std::move(id)), options_(options), paths_(id_->getSystem()), forces_(id_->getModel()) {
  const model::Model& m = id_->getModel();
  for (size_t i = 0; i < m.muscles.size(); ++i) {
    const model::Muscle& mu = m.muscles[i];
    if (mu.enabled) actuators_.push_back({mu.name, true, int(i), mu.min_control, mu.max_control});
  }
  for (size_t i = 0; i < m.actuators.size(); ++i) {
    const model::CoordinateActuator& a = m.actuators[i];
    if (a.enabled) actuators_.push_back({a.name, false, int(i), a.min_control, a.max_control});
  }
  std::vector<bool> constrained(m.coordinates.size(), false);
  for (const model::CoordinateCoupler& cc : m.couplers) constrained[cc.dependent] = true;
  for (size_t c = 0; c < m.coordinates.size(); ++c)
    if (!constrained[c] && !m.coordinates[c].locked) free_.push_back(int(c));
  if (actuators_.size() < free_.size())
    throw InputError({m.source_file, 0, "ForceSet"},
                     "static optimization needs at least as many actuators as unconstrained coordinates, got " +
                         std::to_string(actuators_.size()) + " actuators for " + std::to_string(free_.size()) +
                         " coordinates (add reserve actuators)");
  if (!(options_.activation_exponent >= 1.0))
    throw InputError({m.source_file, 0, "activation_exponent"}, "expected an activation exponent >= 1");
}

std::unique_ptr<SoWorkspace> StaticOptimization::createWorkspace() const {
  auto ws = std::make_unique<SoWorkspace>();
  const int n = id_->getNumCoordinates(), na = int(actuators_.size()), nc = int(free_.size());
  ws->id_ = id_->createWorkspace();
  ws->paths_ = paths_.createWorkspace();
  ws->solver_ = std::make_unique<SoSolver>(na, nc, options_.activation_exponent, options_.convergence, options_.max_iterations);
  ws->C_ = Eigen::MatrixXd::Zero(n, n);
  ws->A_ = ws->A_acc_ = Eigen::MatrixXd::Zero(nc, na);
  ws->mass_ = Eigen::MatrixXd::Zero(nc, nc);
  ws->d_ = ws->qddot_ = ws->tau_ = ws->g_ = ws->tau0_ = ws->unit_qddot_ = Eigen::VectorXd::Zero(n);
  ws->b_acc_ = Eigen::VectorXd::Zero(nc);
  ws->b_ = Eigen::VectorXd::Zero(nc);
  ws->fopt_ = ws->x_ = ws->force_ = ws->lower_ = ws->upper_ = Eigen::VectorXd::Zero(na);
  for (int j = 0; j < na; ++j) {
    ws->lower_[j] = actuators_[j].min_control;
    ws->upper_[j] = actuators_[j].max_control;
  }
  return ws;
}

SoFrameStatus StaticOptimization::solveFrame(SoWorkspace& ws, double t, const Eigen::VectorXd& q,
                                             const Eigen::VectorXd& qdot, const Eigen::VectorXd& qddot,
                                             const dynamics::ExternalLoads* loads) const {
  const model::Model& m = id_->getModel();
  const int na = int(actuators_.size()), nc = int(free_.size());
  // Accelerations of the coupled coordinates follow the free ones; locked coordinates stay.
  calcCouplingMatrix(m, q, ws.C_);
  for (size_t c = 0; c < m.coordinates.size(); ++c)
    if (m.coordinates[c].locked) ws.C_.col(int(c)).setZero();
  calcCouplingAcceleration(m, q, qdot, ws.d_);
  ws.qddot_.noalias() = ws.C_ * qddot;
  ws.qddot_ += ws.d_;

  dynamics::IdWorkspace& idws = *ws.id_;
  id_->setState(idws, q, qdot);
  if (loads) loads->addBodyForces(id_->getSystem(), idws.getSimWorkspace(), t, idws.updAppliedForces());
  if (options_.opensim_optimizer) calcReducedMassMatrix(ws);
  id_->calcGeneralizedForces(idws, ws.qddot_, ws.tau_);
  for (int r = 0; r < nc; ++r) ws.b_[r] = ws.C_.col(free_[r]).dot(ws.tau_);

  paths_.realize(idws.getSimWorkspace(), q, *ws.paths_);
  for (int j = 0; j < na; ++j) {
    const SoActuator& a = actuators_[j];
    if (a.is_muscle) {
      paths_.calcGeneralizedForces(idws.updSimWorkspace(), *ws.paths_, a.index, ws.g_);
      const model::Muscle& mu = m.muscles[a.index];
      const double length = paths_.getLength(*ws.paths_, a.index), speed = -ws.g_.dot(qdot);
      ws.fopt_[j] = options_.use_muscle_physiology ? forces_.calcRigidTendonForce(a.index, 1.0, length, speed)
                                                   : mu.max_isometric_force;
      for (int r = 0; r < nc; ++r) ws.A_(r, j) = ws.fopt_[j] * ws.C_.col(free_[r]).dot(ws.g_);
    } else {
      const model::CoordinateActuator& ca = m.actuators[a.index];
      ws.fopt_[j] = ca.optimal_force;
      for (int r = 0; r < nc; ++r) ws.A_(r, j) = ws.fopt_[j] * ws.C_(ca.coordinate, free_[r]);
    }
  }

  // Start from the previous frame's answer (OpenSim starts every frame from zero; the optimum
  // of a strictly convex problem does not depend on it).
  if (!ws.has_previous_) ws.x_.setZero();
  ws.x_ = ws.x_.cwiseMax(ws.lower_).cwiseMin(ws.upper_);
  SoFrameStatus status;
  if (options_.opensim_optimizer) {
    // OpenSim's problem: the accelerations' equations (M_r^-1 A x = M_r^-1 b), solved by
    // Simbody's optimizer from zero at every frame.
    ws.mass_ldlt_.compute(ws.mass_);
    ws.A_acc_ = ws.mass_ldlt_.solve(ws.A_);
    ws.b_acc_ = ws.mass_ldlt_.solve(ws.b_);
    ws.x_.setZero();
    const sim::SimbodyOptimizerSettings settings{options_.convergence, options_.max_iterations};
    std::lock_guard<std::mutex> lock(identify::getIpoptMutex());  // one Ipopt at a time
    status.converged =
        sim::minimizePowerSumWithSimbody(ws.A_acc_, ws.b_acc_, ws.lower_, ws.upper_, options_.activation_exponent,
                                         settings, ws.x_, status.message);
  } else {
    status.converged = ws.solver_->solve(ws.A_, ws.b_, ws.lower_, ws.upper_, ws.x_, status.iterations);
  }
  ws.has_previous_ = status.converged;
  ws.force_ = ws.x_.cwiseProduct(ws.fopt_);
  for (int r = 0; r < nc; ++r) {
    const double v = std::abs(ws.A_.row(r).dot(ws.x_) - ws.b_[r]);
    if (v > status.max_violation) {
      status.max_violation = v;
      status.worst_coordinate = free_[r];
    }
  }
  return status;
}

void StaticOptimization::calcReducedMassMatrix(SoWorkspace& ws) const {
  // Column k: the generalised forces a unit acceleration of free coordinate k (its coupled
  // coordinates following) adds to those of the couplers' own accelerations d.
  dynamics::IdWorkspace& idws = *ws.id_;
  const int nc = int(free_.size());
  id_->calcGeneralizedForces(idws, ws.d_, ws.tau0_);
  for (int k = 0; k < nc; ++k) {
    ws.unit_qddot_ = ws.C_.col(free_[k]) + ws.d_;
    id_->calcGeneralizedForces(idws, ws.unit_qddot_, ws.tau_);
    ws.tau_ -= ws.tau0_;
    for (int r = 0; r < nc; ++r) ws.mass_(r, k) = ws.C_.col(free_[r]).dot(ws.tau_);
  }
}

void StaticOptimization::addActuatorLoads(const SoWorkspace& ws, sim::SpatialColumns& F,
                                          Eigen::Ref<Eigen::VectorXd> mobility) const {
  const model::Model& m = id_->getModel();
  for (size_t j = 0; j < actuators_.size(); ++j) {
    const SoActuator& a = actuators_[j];
    if (a.is_muscle)
      paths_.addLoads(*ws.paths_, a.index, ws.force_[int(j)], F, mobility);
    else
      mobility[m.actuators[a.index].coordinate] += ws.force_[int(j)];
  }
}

io::Storage makeActuatorStorage(const StaticOptimization& so, const std::vector<double>& times,
                                const Eigen::MatrixXd& values) {
  io::Storage s;
  s.name = "Static Optimization";
  s.labels.push_back("time");
  for (const SoActuator& a : so.getActuators()) s.labels.push_back(a.name);
  s.data.resize(Eigen::Index(times.size()), Eigen::Index(s.labels.size()));
  for (size_t f = 0; f < times.size(); ++f) {
    s.data(Eigen::Index(f), 0) = times[f];
    s.data.row(Eigen::Index(f)).tail(values.cols()) = values.row(Eigen::Index(f));
  }
  s.header.emplace_back("inDegrees", "no");
  return s;
}

}  // namespace kneesim::muscle
