#include "dynamics/knee_loads.hpp"

#include <stdexcept>

#include "core/strings.hpp"

namespace kneesim::dynamics {

KneeAxes parseKneeAxes(const std::string& words) {
  const std::vector<std::string_view> w = splitWhitespace(words);
  if (w.size() != 3) throw std::invalid_argument("expected 3 words (the x, y and z axes' directions), got '" + words + "'");
  Eigen::Vector3d anterior = Eigen::Vector3d::Zero(), superior = anterior, medial = anterior;
  for (int k = 0; k < 3; ++k) {
    const std::string d = toLower(w[k]);
    const Eigen::Vector3d e = Eigen::Vector3d::Unit(k);
    if (d == "anterior") anterior = e;
    else if (d == "posterior") anterior = -e;
    else if (d == "superior") superior = e;
    else if (d == "inferior") superior = -e;
    else if (d == "medial") medial = e;
    else if (d == "lateral") medial = -e;
    else throw std::invalid_argument("expected anterior, posterior, superior, inferior, medial or lateral, got '" + d + "'");
  }
  if (anterior.isZero() || superior.isZero() || medial.isZero())
    throw std::invalid_argument("expected one anteroposterior, one superoinferior and one mediolateral axis, got '" + words + "'");
  return {anterior, superior, medial};
}

const std::vector<std::string>& getKneeLoadColumns() {
  static const std::vector<std::string> c = {"knee_axial_force",     "knee_ap_force",         "knee_ml_force",
                                             "knee_flexion_moment", "knee_adduction_moment", "knee_rotation_moment"};
  return c;
}

io::Storage makeKneeLoadTable(const std::vector<double>& time, const Eigen::MatrixX3d& force, const Eigen::MatrixX3d& moment,
                              const KneeAxes& axes) {
  io::Storage s;
  s.name = "Knee Loads";
  s.labels = {"time"};
  for (const std::string& c : getKneeLoadColumns()) s.labels.push_back(c);
  s.data.resize(Eigen::Index(time.size()), 7);
  for (Eigen::Index r = 0; r < s.data.rows(); ++r) {
    const Eigen::Vector3d F = force.row(r).transpose(), M = moment.row(r).transpose();
    s.data.row(r) << time[size_t(r)], -F.dot(axes.superior), F.dot(axes.anterior), F.dot(axes.medial), M.dot(axes.medial),
        M.dot(axes.anterior), M.dot(axes.superior);
  }
  return s;
}

}  // namespace kneesim::dynamics
