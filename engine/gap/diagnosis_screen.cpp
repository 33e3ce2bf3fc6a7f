// The screening step of the gap diagnosis: the score (Lagrange multiplier) test of adding one effect
// to the current model, from one Gauss-Newton step at its optimum, and what the data can see of
// each effect (its visible basis).

#include <algorithm>
#include <cmath>

#include <Eigen/QR>
#include <Eigen/SVD>

#include "gap/diagnosis_detail.hpp"

namespace kneesim::gap::detail {

namespace {

// The current model's residuals r over the units' frames (and per trial in resid) and the scaled
// sensitivity columns a of the parameters @p cols of @p law at @p p0, rows by trial, unit, frame.
void fillSensitivities(const Context& c, const identify::ContactLaw& law, const Eigen::VectorXd& p0,
                       const std::vector<int>& cols, Eigen::MatrixXd& a, Eigen::VectorXd& r,
                       std::vector<std::vector<double>>& resid) {
  int row = 0;
  for (size_t t = 0; t < c.trials.size(); ++t) {
    const identify::LawInputs in(law, c.trials[t].channels, c.trials[t].time, c.trials[t].name);
    Eigen::VectorXd f;
    Eigen::MatrixXd j;
    law.calcForce(p0, in, f, &j);
    resid[t].assign(f.size(), 0.0);
    for (int i = 0; i < f.size(); ++i) resid[t][i] = c.trials[t].measured_force[i] - f[i];
    for (const auto& u : c.units) {
      if (u.trial != static_cast<int>(t)) continue;
      for (int i : u.frames) {
        r[row] = resid[t][i];
        for (size_t k = 0; k < cols.size(); ++k) {
          const double sc = std::max(std::abs(p0[cols[k]]), law.getParameter(cols[k]).typical_scale);
          a(row, k) = j(i, cols[k]) * sc;
        }
        ++row;
      }
    }
  }
}

// |Q^T r|^2 over the column space of x, and its rank.
double projectedSquaredNorm(const Eigen::MatrixXd& x, const Eigen::VectorXd& r, int& rank) {
  if (x.cols() == 0) {
    rank = 0;
    return 0.0;
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(x);
  qr.setThreshold(1e-10);
  rank = static_cast<int>(qr.rank());
  const Eigen::VectorXd qtr = qr.householderQ().transpose() * r;
  return qtr.head(rank).squaredNorm();
}

// The visible basis of the effect columns of a (after the first k_m, the current model's): their span
// with the current model's columns projected out, orthonormalised.
VisibleBasis visibleBasisOf(const Eigen::MatrixXd& a, int k_m) {
  Eigen::MatrixXd ex = a.rightCols(a.cols() - k_m);
  if (k_m > 0) {
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qm(a.leftCols(k_m));
    qm.setThreshold(1e-10);
    // Thin Q only: the full one is frames x frames.
    const Eigen::MatrixXd q = qm.householderQ() * Eigen::MatrixXd::Identity(ex.rows(), qm.rank());
    ex -= q * (q.transpose() * ex);
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qe(ex);
  qe.setThreshold(1e-8);
  return qe.householderQ() * Eigen::MatrixXd::Identity(ex.rows(), qe.rank());
}

}  // namespace

// Effects (names) usable on every target trial, and the reasons of the others.
bool testable(const Context& c, const Effect& e, std::string& reason) {
  for (const auto& t : c.trials) {
    const auto miss = e.findMissingInputs(t.channels);
    if (!miss.empty()) {
      reason = "trial '" + t.name + "' lacks channel '" + miss.front() + "'";
      return false;
    }
  }
  return true;
}

Screening screen(const Context& c, const Model& m, const Effect& e, VisibleBasis* visible) {
  Screening s;
  s.effect = e.getName();
  if (!testable(c, e, s.reason)) {
    s.testable = false;
    return s;
  }
  std::vector<Effect> effs = m.effects;
  effs.push_back(e);
  const identify::ContactLaw law = makeExtendedLaw(*c.base, effs);
  Eigen::VectorXd p0 = law.getDefaultValues();
  p0.head(m.params.size()) = m.params;
  std::vector<int> cols;
  for (const auto& f : m.free) cols.push_back(law.getParameterIndex(f));
  const int k_m = static_cast<int>(cols.size());
  std::vector<int> ecols;
  for (int j = m.law.getNumParameters(); j < law.getNumParameters(); ++j)
    if (!law.getParameter(j).fixed_by_default) ecols.push_back(j);
  cols.insert(cols.end(), ecols.begin(), ecols.end());
  int n = 0;
  for (const auto& u : c.units) n += static_cast<int>(u.frames.size());
  Eigen::MatrixXd a(n, cols.size());
  Eigen::VectorXd r(n);
  std::vector<std::vector<double>> resid(c.trials.size());
  fillSensitivities(c, law, p0, cols, a, r, resid);
  if (!a.allFinite() || !r.allFinite()) {
    s.testable = false;
    s.reason = "non-finite force or sensitivity at the current model";
    return s;
  }
  auto projected = [&](const Eigen::MatrixXd& x, int& rank) { return projectedSquaredNorm(x, r, rank); };
  int rank_m = 0, rank_full = 0;
  const double proj_m = projected(a.leftCols(k_m), rank_m);
  const double proj_full = projected(a, rank_full);
  s.dof = rank_full - rank_m;
  if (s.dof <= 0) {
    s.testable = false;
    s.reason = "its parameters do not change the force at the current model (no sensitivity)";
    return s;
  }
  const double sse = r.squaredNorm();
  const double sigma2 = sse / std::max(1, n - rank_m);
  const double delta = std::max(0.0, proj_full - proj_m);
  // One Gauss-Newton step: the least-squares solution of a x = r in the scaled parameters.
  const Eigen::VectorXd x = a.colPivHouseholderQr().solve(r);
  // Serial correlation of what the step leaves: the current model's residuals carry the very
  // structure being looked for, so their lag-1 correlation is near 1 for every effect and the
  // discount erased the ranking; after the effect's own step, the right effect leaves noise.
  {
    const Eigen::VectorXd left = r - a * x;
    int k = 0;  // rows of a are ordered as they were filled: by trial, then unit, then frame
    for (size_t t = 0; t < c.trials.size(); ++t)
      for (const auto& u : c.units)
        if (u.trial == static_cast<int>(t))
          for (int i : u.frames) resid[t][i] = left[k++];
  }
  const double rho = std::clamp(pooledLag1(c, resid), 0.0, 0.99);
  s.statistic = delta / sigma2 * (1 - rho) / (1 + rho);
  s.predicted_reduction = sse > 0 ? delta / sse : 0.0;
  bool outside = false;
  for (size_t k = 0; k < ecols.size(); ++k) {
    const int j = ecols[k];
    const double sc = std::max(std::abs(p0[j]), law.getParameter(j).typical_scale);
    const double v = p0[j] + x[k_m + k] * sc;
    s.one_step.emplace_back(law.getParameter(j).name, v);
    const auto& lp = law.getParameter(j);
    if ((p0[j] <= lp.lower && v < lp.lower) || (p0[j] >= lp.upper && v > lp.upper)) outside = true;
  }
  if (outside && ecols.size() == 1) {
    // At a bound the score test is one-sided: a step out of the bounds improves nothing allowed.
    s.statistic = 0;
    s.predicted_reduction = 0;
    s.reason = "the data push its parameter out of its bounds";
  }
  s.p_value = chiSquareSurvival(s.statistic, s.dof);
  s.z = (s.statistic - s.dof) / std::sqrt(2.0 * s.dof);
  if (visible) *visible = visibleBasisOf(a, k_m);
  return s;
}

// Largest canonical correlation between two visible bases (1: one effect's visible force change
// lies in the other's span).
double canonicalCorrelation(const VisibleBasis& a, const VisibleBasis& b) {
  if (a.cols() == 0 || b.cols() == 0 || a.rows() != b.rows()) return 0;
  const Eigen::MatrixXd m = a.transpose() * b;
  return std::min(1.0, Eigen::JacobiSVD<Eigen::MatrixXd>(m).singularValues()(0));
}

}  // namespace kneesim::gap::detail
