#include "ik/solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.hpp"

namespace kneesim::ik {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

Solver::Solver(const sim::System& system, std::vector<MarkerTask> markers, std::vector<CoordinateTask> coordinates,
               SolverOptions options)
    : system_(system),
      marker_tasks_(std::move(markers)),
      coord_tasks_(std::move(coordinates)),
      options_(options),
      terms_(system.getModel()) {
  const model::Model& m = system_.getModel();
  const int nq = system_.getNumCoordinates();

  // Free variables: coordinates that are neither locked nor the dependent of a coupler.
  std::vector<char> dependent(nq, 0);
  for (const auto& cc : m.couplers) dependent[cc.dependent] = 1;
  var_of_coord_.assign(nq, -1);
  for (int c = 0; c < nq; ++c) {
    if (m.coordinates[c].locked || dependent[c]) continue;
    var_of_coord_[c] = int(free_.size());
    free_.push_back(c);
    const auto& co = m.coordinates[c];
    lower_.push_back(co.clamped ? co.range_min : -kInf);
    upper_.push_back(co.clamped ? co.range_max : kInf);
  }

  // Couplers in dependency order: a coupler whose independents are themselves dependent comes
  // after the couplers that set them.
  std::vector<char> done(m.couplers.size(), 0), known(nq, 1);
  for (const auto& cc : m.couplers) known[cc.dependent] = 0;
  for (size_t pass = 0; pass < m.couplers.size(); ++pass)
    for (size_t i = 0; i < m.couplers.size(); ++i) {
      if (done[i]) continue;
      bool ready = true;
      for (int c : m.couplers[i].independents) ready = ready && known[c];
      if (ready) {
        coupler_order_.push_back(int(i));
        done[i] = 1;
        known[m.couplers[i].dependent] = 1;
      }
    }
  if (coupler_order_.size() != m.couplers.size())
    throw InputError({m.source_file, 0, "ConstraintSet"}, "coordinate couplers form a cycle");

  const int nm = int(marker_tasks_.size());
  const int nc = int(coord_tasks_.size());
  const int nz = int(free_.size());
  for (const auto& t : marker_tasks_) {
    KNEESIM_CHECK(t.marker >= 0 && t.marker < int(m.markers.size()), "marker task index out of range");
    bodies_.push_back(m.markers[t.marker].body);
    stations_.push_back(m.markers[t.marker].p_BM);
  }
  weights_.assign(nm, 0.0);
  n_eq_ = terms_.getNumEquations();
  n_pen_ = penaltyConstraints() ? n_eq_ : 0;
  const int ns = terms_.getNumStations();
  k_points_.assign(ns, Eigen::Vector3d::Zero());
  Jk_.setZero(3 * ns, nq);
  JkE_.setZero(3 * ns, nz);
  c_.setZero(n_eq_);
  C_.setZero(n_eq_, nz);
  C_here_.setZero(n_eq_, nz);
  c_here_.setZero(n_eq_);
  AinvCt_.setZero(nz, n_eq_);
  S_.setZero(n_eq_, n_eq_);
  y_.setZero(nz);
  mu_.setZero(n_eq_);
  cy_.setZero(n_eq_);
  ldlt_s_ = Eigen::LDLT<Eigen::MatrixXd>(n_eq_);
  constraint_errors_.assign(terms_.getNumConstraints(), 0.0);
  Jq_.setZero(3 * nm, nq);
  E_.setZero(nq, nz);
  J_.setZero(3 * nm + nc + n_pen_, nz);
  r_.setZero(3 * nm + nc + n_pen_);
  H_.setZero(nz, nz);
  A_.setZero(nz, nz);
  g_.setZero(nz);
  step_.setZero(nz);
  z_.setZero(nz);
  z_trial_.setZero(nz);
  q_trial_.setZero(nq);
  ldlt_ = Eigen::LDLT<Eigen::MatrixXd>(nz);
  // Non-zero structure of E = dq/dz: a free coordinate depends on itself, a dependent one on the
  // union of its independents' variables; locked coordinates on nothing.
  e_cols_.assign(nq, {});
  for (int k = 0; k < nz; ++k) {
    e_cols_[free_[k]].push_back(k);
    E_(free_[k], k) = 1.0;
  }
  for (int i : coupler_order_) {
    const auto& cc = m.couplers[i];
    std::vector<int>& cols = e_cols_[cc.dependent];
    for (int ind : cc.independents) cols.insert(cols.end(), e_cols_[ind].begin(), e_cols_[ind].end());
    std::sort(cols.begin(), cols.end());
    cols.erase(std::unique(cols.begin(), cols.end()), cols.end());
  }
  active_.assign(nz, 0);
  marker_errors_.assign(nm, 0.0);
  q_last_.setZero(nq);
  q_before_.setZero(nq);
  model_markers_.assign(nm, Eigen::Vector3d::Zero());
}

void Solver::applyConstraints(Eigen::VectorXd& q) const {
  const model::Model& m = system_.getModel();
  for (size_t c = 0; c < m.coordinates.size(); ++c)
    if (m.coordinates[c].locked) q[c] = m.coordinates[c].default_value;
  double x[6];
  for (int i : coupler_order_) {
    const auto& cc = m.couplers[i];
    for (size_t k = 0; k < cc.independents.size(); ++k) x[k] = q[cc.independents[k]];
    q[cc.dependent] = cc.scale_factor * cc.function->calcValue(x);
  }
}

void Solver::buildExpansion(const Eigen::VectorXd& q) {
  // Rows of E = dq/dz: free coordinates are unit rows (set once in the constructor); a dependent
  // coordinate's row is the chain rule through its coupler, in dependency order. Only the
  // structurally non-zero entries are touched.
  const model::Model& m = system_.getModel();
  double x[6];
  int comp[1];
  for (int i : coupler_order_) {
    const auto& cc = m.couplers[i];
    const int dep = cc.dependent;
    for (int k : e_cols_[dep]) E_(dep, k) = 0.0;
    for (size_t k = 0; k < cc.independents.size(); ++k) x[k] = q[cc.independents[k]];
    for (size_t k = 0; k < cc.independents.size(); ++k) {
      comp[0] = int(k);
      const double d = cc.scale_factor * cc.function->calcDerivative(x, comp, 1);
      const int ind = cc.independents[k];
      for (int col : e_cols_[ind]) E_(dep, col) += d * E_(ind, col);
    }
  }
}

void Solver::expandJacobian(const Eigen::MatrixXd& Jq, Eigen::Ref<Eigen::MatrixXd> out) const {
  out.setZero();
  for (int c = 0; c < int(e_cols_.size()); ++c)
    for (int k : e_cols_[c]) out.col(k).noalias() += E_(c, k) * Jq.col(c);
}

void Solver::evalConstraintStations(sim::Workspace& ws, bool jacobian) {
  const auto& bodies = terms_.getStationBodies();
  const auto& stations = terms_.getStations();
  for (size_t i = 0; i < bodies.size(); ++i) k_points_[i] = system_.findStationLocation(ws, bodies[i], stations[i]);
  terms_.calcErrors(k_points_, c_);
  if (!jacobian) return;
  system_.calcStationJacobian(ws, bodies, stations, Jk_);
  expandJacobian(Jk_, JkE_);
  terms_.calcJacobian(k_points_, JkE_, C_);
}

void Solver::calcResidualJacobian(sim::Workspace& ws, const Eigen::VectorXd& q) {
  const int nm = int(marker_tasks_.size());
  const int nc = int(coord_tasks_.size());
  system_.calcStationJacobian(ws, bodies_, stations_, Jq_);
  if (!coupler_order_.empty()) buildExpansion(q);
  // J = diag(sqrt w) Jq E, accumulated column by column over E's non-zeros.
  J_.setZero();
  expandJacobian(Jq_, J_.topRows(3 * nm));
  for (int i = 0; i < nm; ++i)
    if (weights_[i] != 1.0) J_.middleRows<3>(3 * i) *= std::sqrt(weights_[i]);
  for (int j = 0; j < nc; ++j) {
    const int c = coord_tasks_[j].coordinate;
    const double sw = std::sqrt(coord_tasks_[j].weight);
    for (int k : e_cols_[c]) J_(3 * nm + j, k) = sw * E_(c, k);
  }
  if (n_eq_ == 0) return;
  evalConstraintStations(ws, true);
  if (n_pen_ > 0) J_.bottomRows(n_pen_) = std::sqrt(options_.constraint_weight) * C_;
  C_here_ = C_;  // projections of trial points overwrite C_ and c_
  c_here_ = c_;
}

double Solver::calcMarkerMotion() const {
  // Largest change of a tracked marker's position (m) or of a coordinate-task coordinate (rad or
  // m) predicted by the linearisation for step_. J_ rows carry sqrt(weight): divide it out.
  const int nm = int(marker_tasks_.size());
  double motion = 0;
  for (int i = 0; i < nm; ++i) {
    if (weights_[i] <= 0) continue;
    const Eigen::Vector3d d = J_.middleRows<3>(3 * i) * step_;
    motion = std::max(motion, d.norm() / std::sqrt(weights_[i]));
  }
  for (size_t j = 0; j < coord_tasks_.size(); ++j)
    motion = std::max(motion, std::abs(J_.row(3 * nm + int(j)).dot(step_)) / std::sqrt(coord_tasks_[j].weight));
  return motion;
}

double Solver::evaluate(sim::Workspace& ws, const Eigen::VectorXd& q, const std::vector<Eigen::Vector3d>& observed,
                        const std::vector<double>& reference) {
  system_.realizePosition(ws, q);
  const int nm = int(marker_tasks_.size());
  for (int i = 0; i < nm; ++i) {
    model_markers_[i] = system_.findStationLocation(ws, bodies_[i], stations_[i]);
    const double sw = std::sqrt(weights_[i]);
    if (sw > 0)
      r_.segment<3>(3 * i) = sw * (model_markers_[i] - observed[i]);
    else
      r_.segment<3>(3 * i).setZero();
  }
  for (size_t j = 0; j < coord_tasks_.size(); ++j)
    r_[3 * nm + j] = std::sqrt(coord_tasks_[j].weight) * (q[coord_tasks_[j].coordinate] - reference[j]);
  if (n_pen_ > 0) {
    evalConstraintStations(ws, false);
    r_.tail(n_pen_) = std::sqrt(options_.constraint_weight) * c_;
  }
  return r_.squaredNorm();
}

double Solver::projectOntoConstraints(sim::Workspace& ws, Eigen::VectorXd& z, Eigen::VectorXd& q) {
  const int nz = int(free_.size());
  double err = 0;
  for (int it = 0; it < 50; ++it) {
    system_.realizePosition(ws, q);
    if (!coupler_order_.empty()) buildExpansion(q);
    evalConstraintStations(ws, true);
    err = c_.cwiseAbs().maxCoeff();
    if (err <= options_.constraint_tolerance || nz == 0) break;
    // Least-norm Gauss-Newton step: dz = -C^T (C C^T + eps I)^-1 c; redundant equations (a
    // planar mechanism's out-of-plane rows) make C C^T singular, hence the small ridge.
    S_.noalias() = C_ * C_.transpose();
    S_.diagonal().array() += 1e-12 * std::max(1.0, S_.diagonal().maxCoeff());
    ldlt_s_.compute(S_);
    mu_ = c_;
    ldlt_s_.solveInPlace(mu_);
    y_.noalias() = C_.transpose() * mu_;
    for (int k = 0; k < nz; ++k) {
      z[k] = std::clamp(z[k] - y_[k], lower_[k], upper_[k]);
      q[free_[k]] = z[k];
    }
    applyConstraints(q);
  }
  return err;
}

void Solver::solveConstrainedStep() {
  // min |J dz + r|^2 + damping  s.t.  C dz = -c:  dz = y - A^-1 C^T mu,  y = -A^-1 g,
  // (C A^-1 C^T) mu = C y + c. Columns of variables held at a bound are zero in C.
  const int nz = int(free_.size());
  C_ = C_here_;
  for (int k = 0; k < nz; ++k)
    if (active_[k]) C_.col(k).setZero();
  AinvCt_ = C_.transpose();
  ldlt_.solveInPlace(AinvCt_);
  S_.noalias() = C_ * AinvCt_;
  S_.diagonal().array() += 1e-12 * std::max(1.0, S_.diagonal().maxCoeff());
  ldlt_s_.compute(S_);
  y_ = step_;  // step_ holds -A^-1 g on entry
  cy_.noalias() = C_ * y_;
  mu_ = cy_ + c_here_;
  ldlt_s_.solveInPlace(mu_);
  step_.noalias() = y_ - AinvCt_ * mu_;
}

FrameResult Solver::trackFrame(sim::Workspace& ws, const std::vector<Eigen::Vector3d>& observed,
                               const std::vector<double>& reference, Eigen::VectorXd& q) {
  KNEESIM_CHECK(q.size() == q_last_.size(), "IK coordinate vector size");
  if (tracked_ >= 2)
    q = 2.0 * q_last_ - q_before_;
  else if (tracked_ == 1)
    q = q_last_;
  const FrameResult r = solveFrame(ws, observed, reference, q);
  q_before_ = q_last_;
  q_last_ = q;
  tracked_ = std::min(tracked_ + 1, 2);
  return r;
}

double Solver::startFrame(sim::Workspace& ws, const std::vector<Eigen::Vector3d>& observed,
                          const std::vector<double>& reference, Eigen::VectorXd& q, FrameResult& res) {
  const int nm = int(marker_tasks_.size());
  const int nz = int(free_.size());
  // OpenSim's marker goal is the weighted mean over the markers present in the frame.
  double weight_sum = 0;
  for (int i = 0; i < nm; ++i) {
    const bool present = observed[i].allFinite();
    weights_[i] = present ? marker_tasks_[i].weight : 0.0;
    weight_sum += weights_[i];
    if (present && marker_tasks_[i].weight > 0) ++res.markers_used;
  }
  if (weight_sum > 0)
    for (int i = 0; i < nm; ++i) weights_[i] /= weight_sum;

  for (int k = 0; k < nz; ++k) z_[k] = std::clamp(q[free_[k]], lower_[k], upper_[k]);
  for (int k = 0; k < nz; ++k) q[free_[k]] = z_[k];
  applyConstraints(q);
  if (hardConstraints()) projectOntoConstraints(ws, z_, q);
  return evaluate(ws, q, observed, reference);
}

void Solver::formNormalEquations(sim::Workspace& ws, const Eigen::VectorXd& q) {
  const int nz = int(free_.size());
  calcResidualJacobian(ws, q);
  g_.setZero();
  H_.setZero();
  if (J_.rows() > 0) {  // no residual (assembly onto constraints alone): Eigen's product would divide by 0
    g_.noalias() = J_.transpose() * r_;
    H_.selfadjointView<Eigen::Lower>().rankUpdate(J_.transpose());
  }
  // Variables resting on a bound with the gradient pushing outwards stay there this step.
  for (int k = 0; k < nz; ++k)
    active_[k] = (z_[k] <= lower_[k] && g_[k] > 0) || (z_[k] >= upper_[k] && g_[k] < 0);
}

double Solver::solveDampedStep(double lambda) {
  const int nz = int(free_.size());
  A_.triangularView<Eigen::Lower>() = H_;
  for (int k = 0; k < nz; ++k) A_(k, k) += lambda * std::max(H_(k, k), 1e-9) + 1e-14;
  for (int k = 0; k < nz; ++k)
    if (active_[k]) {
      A_.row(k).setZero();
      A_.col(k).setZero();
      A_(k, k) = 1.0;
    }
  ldlt_.compute(A_);
  step_ = -g_;
  for (int k = 0; k < nz; ++k)
    if (active_[k]) step_[k] = 0.0;
  ldlt_.solveInPlace(step_);
  if (hardConstraints()) solveConstrainedStep();
  double step_size = 0;
  for (int k = 0; k < nz; ++k) {
    z_trial_[k] = std::clamp(z_[k] + step_[k], lower_[k], upper_[k]);
    step_[k] = z_trial_[k] - z_[k];
    step_size = std::max(step_size, std::abs(step_[k]));
  }
  return step_size;
}

double Solver::placeTrialPoint(sim::Workspace& ws, const Eigen::VectorXd& q, double step_size) {
  const int nz = int(free_.size());
  q_trial_ = q;
  for (int k = 0; k < nz; ++k) q_trial_[free_[k]] = z_trial_[k];
  applyConstraints(q_trial_);
  if (!hardConstraints()) return step_size;
  // Back onto the constraints (the linearised step leaves second-order errors); the step taken
  // is the projected one.
  projectOntoConstraints(ws, z_trial_, q_trial_);
  step_size = 0;
  for (int k = 0; k < nz; ++k) step_size = std::max(step_size, std::abs(z_trial_[k] - z_[k]));
  return step_size;
}

void Solver::finishFrame(sim::Workspace& ws, const std::vector<Eigen::Vector3d>& observed, FrameResult& res) {
  // Unweighted marker errors at the solution (the state and model_markers_ hold it).
  const int nm = int(marker_tasks_.size());
  for (int i = 0; i < nm; ++i) {
    if (observed[i].allFinite() && marker_tasks_[i].weight > 0) {
      const double e = (model_markers_[i] - observed[i]).norm();
      marker_errors_[i] = e;
      res.total_squared_error += e * e;
      if (e > res.max_error) {
        res.max_error = e;
        res.worst_marker = i;
      }
    } else {
      marker_errors_[i] = std::numeric_limits<double>::quiet_NaN();
    }
  }
  res.rms_error = res.markers_used > 0 ? std::sqrt(res.total_squared_error / res.markers_used) : 0.0;
  if (terms_.getNumConstraints() > 0) {
    evalConstraintStations(ws, false);  // the state holds the solution
    for (int k = 0; k < terms_.getNumConstraints(); ++k) {
      constraint_errors_[k] = terms_.calcViolation(k_points_, k);
      res.max_constraint_error = std::max(res.max_constraint_error, constraint_errors_[k]);
    }
  }
}

FrameResult Solver::solveFrame(sim::Workspace& ws, const std::vector<Eigen::Vector3d>& observed,
                               const std::vector<double>& reference, Eigen::VectorXd& q) {
  const int nz = int(free_.size());
  KNEESIM_CHECK(observed.size() == marker_tasks_.size() && reference.size() == coord_tasks_.size(), "IK input sizes");
  KNEESIM_CHECK(q.size() == system_.getNumCoordinates(), "IK coordinate vector size");
  FrameResult res;
  double cost = startFrame(ws, observed, reference, q, res);
  double lambda = 1e-6;
  double previous_step = kInf;

  // Gauss-Newton with Levenberg-Marquardt damping. Stopping rules (SolverOptions): the frame is
  // converged when the undamped step from the current point changes no coordinate by more than
  // step_tolerance (rad or m) or moves no tracked marker (m) and no coordinate of a coordinate
  // task (rad or m) by more than step_tolerance -- the
  // point is then that close to the minimum and the step is not taken --, when a step of a
  // linearly converging sequence predicts the remaining distance below it, or when the cost
  // stops decreasing. The marker test ends the slow tails of coordinates the markers barely
  // see (e.g. forearm pronation with one wrist marker on a model that does not fit the data).
  for (int it = 0; it < options_.max_iterations && nz > 0; ++it) {
    res.iterations = it + 1;
    formNormalEquations(ws, q);
    bool accepted = false, done = false, tried = false;
    double cost_trial = cost, step_size = 0, marker_motion = 0;
    while (!accepted) {
      step_size = solveDampedStep(lambda);
      marker_motion = calcMarkerMotion();
      if (lambda <= 1e-3 && (step_size <= options_.step_tolerance || marker_motion <= options_.step_tolerance)) {
        done = true;  // a (nearly) undamped step this small: we are at the minimum
        break;
      }
      step_size = placeTrialPoint(ws, q, step_size);
      cost_trial = evaluate(ws, q_trial_, observed, reference);
      tried = true;
      if (cost_trial <= cost) {
        accepted = true;
        lambda = std::max(lambda / 5.0, 1e-12);
      } else {
        lambda *= 4.0;
        if (lambda > 1e12) break;  // no descent possible: at the minimum to machine precision
      }
    }
    if (done) {
      if (tried) evaluate(ws, q, observed, reference);  // the state holds a rejected trial
      res.converged = true;
      break;
    }
    if (!accepted) {
      evaluate(ws, q, observed, reference);  // the state still holds the last rejected trial
      res.converged = true;
      break;
    }
    const double decrease = cost - cost_trial;
    z_ = z_trial_;
    q = q_trial_;
    cost = cost_trial;
    // Remaining distance of a linearly converging sequence with ratio rate: step rate / (1 - rate).
    const double rate = std::isfinite(previous_step) && previous_step > 0 ? step_size / previous_step : 1.0;
    previous_step = step_size;
    if (step_size <= options_.step_tolerance || marker_motion <= options_.step_tolerance ||
        (rate < 1 && step_size * rate / (1 - rate) <= options_.step_tolerance) ||
        decrease <= options_.cost_tolerance * std::max(cost, 1e-30)) {
      res.converged = true;
      break;
    }
  }
  if (nz == 0) res.converged = true;
  finishFrame(ws, observed, res);
  return res;
}

}  // namespace kneesim::ik
