#include "dynamics/coordinate_smoothing.hpp"

#include <cmath>
#include <stdexcept>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "dynamics/lowpass.hpp"

namespace kneesim::dynamics {

int findCoordinateColumn(const io::Storage& storage, const std::string& name) {
  const int exact = storage.findColumn(name);
  if (exact >= 0) return exact;
  const std::string suffix = "/" + name + "/value";
  for (size_t i = 0; i < storage.labels.size(); ++i)
    if (endsWith(storage.labels[i], suffix)) return int(i);
  return -1;
}

CoordinateTrajectories::CoordinateTrajectories(const model::Model& model, const io::Storage& coordinates,
                                               const std::string& file, const CoordinateSmoothingOptions& options) {
  const int n_rows = coordinates.getNumRows();
  const int time_col = coordinates.findColumn("time");
  if (time_col < 0) throw InputError({file, 0, "time"}, "expected a 'time' column, got none");
  if (n_rows < 6) throw InputError({file, 0, ""}, "expected at least 6 rows of coordinates, got " + std::to_string(n_rows));
  SampledTable table;
  std::vector<int> used;  // model coordinate -> column in table.columns, or -1
  for (int r = 0; r < n_rows; ++r) table.time.push_back(coordinates.data(r, time_col));
  for (size_t c = 0; c < model.coordinates.size(); ++c) {
    const model::Coordinate& co = model.coordinates[c];
    const int col = findCoordinateColumn(coordinates, co.name);
    if (col < 0) {
      used.push_back(-1);
      missing_.push_back(co.name);
      continue;
    }
    std::vector<double> v(static_cast<size_t>(n_rows));
    for (int r = 0; r < n_rows; ++r) {
      v[r] = coordinates.data(r, col);
      if (!std::isfinite(v[r]))
        throw InputError({file, 0, coordinates.labels[col]},
                         "expected a finite value at t = " + formatSignificant(table.time[r], 6) + " s, got " +
                             formatSignificant(v[r], 6));
    }
    used.push_back(int(table.columns.size()));
    table.columns.push_back(std::move(v));
  }
  for (int r = 0; r < n_rows; ++r)
    if (!std::isfinite(table.time[r]) || (r > 0 && !(table.time[r] > table.time[r - 1])))
      throw InputError({file, 0, "time"}, "expected strictly increasing times, got " + formatSignificant(table.time[r], 6) +
                                              " after " + formatSignificant(r > 0 ? table.time[r - 1] : 0.0, 6));
  start_ = table.time.front();
  end_ = table.time.back();
  try {
    if (options.cutoff_hz >= 0) {
      padTable(table, n_rows / 2);
      lowpassTable(table, options.cutoff_hz);
    }
  } catch (const std::invalid_argument& e) {
    throw InputError({file, 0, ""}, e.what());
  }
  times_ = table.time;
  const double to_si = options.in_degrees ? M_PI / 180.0 : 1.0;
  std::unique_ptr<NaturalSplineFitter> fitter;
  try {
    fitter = std::make_unique<NaturalSplineFitter>(table.time, 5);
  } catch (const std::invalid_argument& e) {
    throw InputError({file, 0, "time"}, e.what());
  }
  splines_.resize(model.coordinates.size());
  constant_.resize(model.coordinates.size());
  for (size_t c = 0; c < model.coordinates.size(); ++c) {
    const model::Coordinate& co = model.coordinates[c];
    constant_[c] = co.default_value;
    if (used[c] < 0) continue;
    std::vector<double>& v = table.columns[used[c]];
    if (co.motion_type == model::MotionType::Rotational)
      for (double& x : v) x *= to_si;
    splines_[c] = fitter->fit(v);
  }
}

void CoordinateTrajectories::calcAt(double t, Eigen::VectorXd& q, Eigen::VectorXd& qdot, Eigen::VectorXd& qddot) const {
  KNEESIM_ASSERT(q.size() == int(splines_.size()) && qdot.size() == q.size() && qddot.size() == q.size());
  for (size_t c = 0; c < splines_.size(); ++c) {
    if (splines_[c].getDegree() < 0) {
      q[c] = constant_[c];
      qdot[c] = qddot[c] = 0.0;
      continue;
    }
    double d[3];
    splines_[c].calcDerivatives(t, 2, d);
    q[c] = d[0];
    qdot[c] = d[1];
    qddot[c] = d[2];
  }
}

}  // namespace kneesim::dynamics
