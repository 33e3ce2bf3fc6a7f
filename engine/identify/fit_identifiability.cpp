// Identifiability in a fit: which combinations of the free parameters the forces determine (the
// weighted, scaled sensitivities at a point), whether a derived quantity is determined, and which
// parameters to hold when the data cannot determine them all.

#include <algorithm>

#include "identify/fit_detail.hpp"

namespace kneesim::identify::detail {

IdentifiabilityReport analyze(Dataset& data, const ContactLaw& law, const Eigen::VectorXd& full,
                              const std::vector<int>& cols, const std::vector<double>& w, const FitOptions& o,
                              const std::string& label) {
  Eigen::MatrixXd s = data.calcJacobian(full, cols);
  for (Eigen::Index i = 0; i < s.rows(); ++i) s.row(i) *= std::sqrt(w[i]);
  std::vector<std::string> names;
  std::vector<double> values;
  for (size_t k = 0; k < cols.size(); ++k) {
    s.col(k) *= sensitivityScale(law, full, cols[k]);
    names.push_back(law.getParameter(cols[k]).name);
    values.push_back(full[cols[k]]);
  }
  return analyzeSensitivity(s, names, values, o.identifiability_tolerance, o.weak_identifiability_tolerance, label);
}

Eigen::MatrixXd derivedGradient(const ContactLaw& law, const Eigen::VectorXd& full, const std::vector<int>& cols,
                                const std::vector<double>& lower, const std::vector<double>& upper, bool scaled) {
  Eigen::MatrixXd g(law.getNumDerived(), cols.size());
  if (law.getNumDerived() == 0) return g;
  for (size_t k = 0; k < cols.size(); ++k) {
    const int j = cols[k];
    const double sc = sensitivityScale(law, full, j);
    double h = 1e-6 * sc;
    double up = std::min(full[j] + h, upper[j]), lo = std::max(full[j] - h, lower[j]);
    if (!(up > lo)) {
      up = full[j] + h;
      lo = full[j] - h;
    }
    Eigen::VectorXd p = full;
    p[j] = up;
    const Eigen::VectorXd dp = law.calcDerived(p);
    p[j] = lo;
    const Eigen::VectorXd dm = law.calcDerived(p);
    g.col(k) = (dp - dm) / (up - lo) * (scaled ? sc : 1.0);
  }
  return g;
}

std::vector<int> fixUnidentifiable(Dataset& data, const ContactLaw& law, const FitOptions& o, FitParameters& p,
                                   const std::vector<double>& w0, FitReport& rep, std::vector<ParameterStatus>& status,
                                   std::vector<std::string>& value_source) {
  const std::string lawq = "contact law '" + law.getName() + "'";
  Eigen::VectorXd& full = p.full;
  const std::vector<double>& lower = p.lower;
  const std::vector<double>& upper = p.upper;
  const std::vector<std::string>& source = p.source;
  std::vector<int> free = p.freed;
  IdentifiabilityReport current = rep.identifiability_start;
  // Best weighted SSE with free[c] held at its assumed (or start) value and the rest of `f` solved.
  auto sseHolding = [&](const std::vector<int>& f, int c) {
    Eigen::VectorXd q = full;
    const std::string& name = law.getParameter(f[c]).name;
    if (auto it = o.assumed_values.find(name); it != o.assumed_values.end()) q[f[c]] = it->second;
    std::vector<int> rest;
    std::vector<double> y0;
    LeastSquaresOptions lo;
    holdOneOut(law, f, c, q, lower, upper, rest, y0, lo);
    lo.weights = w0;
    lo.max_iterations = o.max_iterations;
    lo.tolerance = o.tolerance;
    data.setFull(q);
    data.setFree(rest);
    return solveLeastSquares(data, y0, lo).sse;
  };
  while (!current.isIdentifiable()) {
    const SensitivityDirection& worst = current.null_directions.front();
    if (!o.fix_unidentifiable)
      throw InputError(o.where, lawq + ": parameters not identifiable from these data: the forces do not change along " +
                                    current.describe(worst) + " (relative singular value " + fmt(worst.relative, 3) +
                                    "); fix one of them or allow fixing unidentifiable parameters");
    // Which parameter of the null direction to hold: the data cannot say, so this is a modelling
    // choice, made in this order among the parameters with a real share of the null space:
    //  1. one the setup states an assumed value for;  2. one the law fixes by default (a geometric
    //  constant);  3. the one whose fixing leaves the best fit (holding E of Hertz at its default
    //  would force nu out of its bounds, holding nu does not);  4. the largest share.
    const std::vector<double> lev = current.calcNullSpaceLeverage();
    const double top = *std::max_element(lev.begin(), lev.end());
    std::vector<int> cand;
    for (int c = 0; c < static_cast<int>(free.size()); ++c)
      if (lev[c] >= 0.1 * top) cand.push_back(c);
    auto prefer = [&](int c) {
      const LawParameter& lp = law.getParameter(free[c]);
      return std::make_pair(o.assumed_values.count(lp.name) > 0, lp.fixed_by_default);
    };
    const auto best_pref = prefer(*std::max_element(cand.begin(), cand.end(),
                                                    [&](int a, int b) { return prefer(a) < prefer(b); }));
    cand.erase(std::remove_if(cand.begin(), cand.end(), [&](int c) { return prefer(c) != best_pref; }), cand.end());
    std::vector<double> cost(free.size(), 0.0);
    if (cand.size() > 1) {
      for (int c : cand) cost[c] = sseHolding(free, c);
      data.setFull(full);
    }
    int pick = cand.front();
    for (int c : cand) {
      const double tie = 1e-6 * std::max(cost[c], cost[pick]) + 1e-300;
      if (cost[c] < cost[pick] - tie || (std::abs(cost[c] - cost[pick]) <= tie && lev[c] > lev[pick])) pick = c;
    }
    const int j = free[pick];
    const std::string& name = law.getParameter(j).name;
    FixedByIdentifiability f;
    f.name = name;
    if (auto it = o.assumed_values.find(name); it != o.assumed_values.end()) {
      full[j] = it->second;
      f.value_source = "assumed value";
    } else {
      f.value_source = source[j];
    }
    f.value = full[j];
    f.direction = current.describe(worst);
    f.relative_singular_value = worst.relative;
    rep.fixed_by_identifiability.push_back(f);
    status[j] = ParameterStatus::FixedUnidentifiable;
    value_source[j] = f.value_source;
    free.erase(free.begin() + pick);
    data.setFull(full);
    current = analyze(data, law, full, free, w0, o, "start point, after fixing " + name);
  }
  return free;
}

}  // namespace kneesim::identify::detail
