#include "identify/identifiability.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/SVD>

#include "core/error.hpp"

namespace kneesim::identify {

IdentifiabilityReport analyzeSensitivity(const Eigen::MatrixXd& s, const std::vector<std::string>& names,
                                         const std::vector<double>& values, double tolerance, double weak_tolerance,
                                         const std::string& label) {
  const int np = static_cast<int>(s.cols());
  KNEESIM_CHECK(static_cast<int>(names.size()) == np && static_cast<int>(values.size()) == np,
                "names/values do not match the sensitivity matrix");
  IdentifiabilityReport r;
  r.label = label;
  r.parameters = names;
  r.values = values;
  r.tolerance = tolerance;
  r.weak_tolerance = weak_tolerance;
  if (np == 0) return r;
  const double rows = std::max<double>(1.0, static_cast<double>(s.rows()));
  const double norm = 1.0 / std::sqrt(rows);
  for (int j = 0; j < np; ++j) r.column_rms.push_back(s.col(j).norm() * norm);

  Eigen::VectorXd sv = Eigen::VectorXd::Zero(np);
  Eigen::MatrixXd v = Eigen::MatrixXd::Identity(np, np);
  if (s.rows() > 0) {
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(s, Eigen::ComputeFullV);
    sv.head(svd.singularValues().size()) = svd.singularValues() * norm;
    v = svd.matrixV();
  }
  r.singular_values.assign(sv.data(), sv.data() + np);
  const double smax = sv[0];
  r.condition_number = sv[np - 1] > 0 ? smax / sv[np - 1] : std::numeric_limits<double>::infinity();
  for (int k = np - 1; k >= 0; --k) {  // smallest first
    SensitivityDirection d;
    d.singular_value = sv[k];
    d.relative = smax > 0 ? sv[k] / smax : 0.0;
    Eigen::VectorXd c = v.col(k);
    Eigen::Index big = 0;
    c.cwiseAbs().maxCoeff(&big);
    if (c[big] < 0) c = -c;
    d.components.assign(c.data(), c.data() + np);
    if (d.relative < tolerance)
      r.null_directions.push_back(d);
    else if (d.relative < weak_tolerance)
      r.weak_directions.push_back(d);
  }
  return r;
}

std::vector<double> IdentifiabilityReport::calcNullSpaceLeverage() const {
  std::vector<double> lev(parameters.size(), 0.0);
  for (const auto& d : null_directions)
    for (size_t j = 0; j < lev.size(); ++j) lev[j] += d.components[j] * d.components[j];
  for (double& x : lev) x = std::sqrt(x);
  return lev;
}

std::string IdentifiabilityReport::describe(const SensitivityDirection& d) const {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(3);
  bool first = true;
  for (size_t j = 0; j < parameters.size(); ++j) {
    const double c = d.components[j];
    if (std::abs(c) < 5e-4) continue;
    if (first)
      s << (c < 0 ? "-" : "") << std::abs(c) << " " << parameters[j];
    else
      s << (c < 0 ? " - " : " + ") << std::abs(c) << " " << parameters[j];
    first = false;
  }
  return s.str();
}

}  // namespace kneesim::identify
