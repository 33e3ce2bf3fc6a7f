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
    : system_(system), marker_tasks_(std::move(markers)), coord_tasks_(std::move(coordinates)), options_(options) {
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
  Jq_.setZero(3 * nm, nq);
  E_.setZero(nq, nz);
  J_.setZero(3 * nm + nc, nz);
  r_.setZero(3 * nm + nc);
  H_.setZero(nz, nz);
  A_.setZero(nz, nz);
  g_.setZero(nz);
  step_.setZero(nz);
  z_.setZero(nz);
  z_trial_.setZero(nz);
  q_trial_.setZero(nq);
  ldlt_ = Eigen::LDLT<Eigen::MatrixXd>(nz);
  active_.assign(nz, 0);
  marker_errors_.assign(nm, 0.0);
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
  const model::Model& m = system_.getModel();
  E_.setZero();
  for (size_t k = 0; k < free_.size(); ++k) E_(free_[k], k) = 1.0;
  double x[6];
  int comp[1];
  for (int i : coupler_order_) {
    const auto& cc = m.couplers[i];
    for (size_t k = 0; k < cc.independents.size(); ++k) x[k] = q[cc.independents[k]];
    for (size_t k = 0; k < cc.independents.size(); ++k) {
      comp[0] = int(k);
      const double d = cc.scale_factor * cc.function->calcDerivative(x, comp, 1);
      E_.row(cc.dependent) += d * E_.row(cc.independents[k]);
    }
  }
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
  return r_.squaredNorm();
}

FrameResult Solver::solveFrame(sim::Workspace& ws, const std::vector<Eigen::Vector3d>& observed,
                               const std::vector<double>& reference, Eigen::VectorXd& q) {
  const int nm = int(marker_tasks_.size());
  const int nz = int(free_.size());
  KNEESIM_CHECK(int(observed.size()) == nm && reference.size() == coord_tasks_.size(), "IK input sizes");
  FrameResult res;
  for (int i = 0; i < nm; ++i) {
    const bool present = observed[i].allFinite();
    weights_[i] = present ? marker_tasks_[i].weight : 0.0;
    if (present && marker_tasks_[i].weight > 0) ++res.markers_used;
  }

  for (int k = 0; k < nz; ++k) z_[k] = std::clamp(q[free_[k]], lower_[k], upper_[k]);
  for (int k = 0; k < nz; ++k) q[free_[k]] = z_[k];
  applyConstraints(q);
  double cost = evaluate(ws, q, observed, reference);
  double lambda = 1e-6;

  for (int it = 0; it < options_.max_iterations && nz > 0; ++it) {
    res.iterations = it + 1;
    system_.calcStationJacobian(ws, bodies_, stations_, Jq_);
    buildExpansion(q);
    J_.topRows(3 * nm).noalias() = Jq_ * E_;
    for (int i = 0; i < nm; ++i) J_.middleRows<3>(3 * i) *= std::sqrt(weights_[i]);
    for (size_t j = 0; j < coord_tasks_.size(); ++j)
      J_.row(3 * nm + j) = std::sqrt(coord_tasks_[j].weight) * E_.row(coord_tasks_[j].coordinate);
    g_.noalias() = J_.transpose() * r_;
    H_.noalias() = J_.transpose() * J_;
    // Variables resting on a bound with the gradient pushing outwards stay there this step.
    for (int k = 0; k < nz; ++k)
      active_[k] = (z_[k] <= lower_[k] && g_[k] > 0) || (z_[k] >= upper_[k] && g_[k] < 0);

    bool accepted = false;
    double cost_trial = cost;
    while (!accepted && lambda < 1e12) {
      A_ = H_;
      Eigen::MatrixXd& A = A_;
      for (int k = 0; k < nz; ++k) A(k, k) += lambda * std::max(A(k, k), 1e-9);
      for (int k = 0; k < nz; ++k)
        if (active_[k]) {
          A.row(k).setZero();
          A.col(k).setZero();
          A(k, k) = 1.0;
        }
      ldlt_.compute(A);
      step_ = -g_;
      for (int k = 0; k < nz; ++k)
        if (active_[k]) step_[k] = 0.0;
      ldlt_.solveInPlace(step_);

      for (int k = 0; k < nz; ++k) z_trial_[k] = std::clamp(z_[k] + step_[k], lower_[k], upper_[k]);
      q_trial_ = q;
      for (int k = 0; k < nz; ++k) q_trial_[free_[k]] = z_trial_[k];
      applyConstraints(q_trial_);
      cost_trial = evaluate(ws, q_trial_, observed, reference);
      if (cost_trial <= cost) {
        accepted = true;
        lambda = std::max(lambda / 5.0, 1e-12);
      } else {
        lambda *= 4.0;
      }
    }
    if (!accepted) {  // no descent possible: we are at the minimum to machine precision
      evaluate(ws, q, observed, reference);
      res.converged = true;
      break;
    }
    const double max_step = (z_trial_ - z_).cwiseAbs().maxCoeff();
    const double decrease = cost - cost_trial;
    z_ = z_trial_;
    q = q_trial_;
    cost = cost_trial;
    if (max_step < options_.step_tolerance || decrease <= options_.cost_tolerance * std::max(cost, 1e-30)) {
      res.converged = true;
      break;
    }
  }
  if (nz == 0) res.converged = true;

  // Unweighted marker errors at the solution.
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
  return res;
}

}  // namespace kneesim::ik
