#include "identify/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace kneesim::identify {

void MetricsAccumulator::add(const std::string& trial, const std::vector<double>& time, const double* predicted,
                             const double* measured, const std::vector<int>& frames) {
  trials_.push_back(trial);
  for (int i : frames) {
    pred_.push_back(predicted[i]);
    meas_.push_back(measured[i]);
    time_.push_back(time[i]);
    trial_index_.push_back(static_cast<int>(trials_.size()) - 1);
  }
}

FitMetrics MetricsAccumulator::calc() const {
  FitMetrics m;
  const size_t n = pred_.size();
  m.n_frames = static_cast<int>(n);
  if (n == 0) return m;
  double sum_meas = 0, sum_res = 0, sse = 0, peak = -std::numeric_limits<double>::infinity(), worst = -1;
  size_t worst_i = 0;
  for (size_t i = 0; i < n; ++i) {
    const double r = pred_[i] - meas_[i];
    sum_meas += meas_[i];
    sum_res += r;
    sse += r * r;
    peak = std::max(peak, meas_[i]);
    if (std::abs(r) > worst) {
      worst = std::abs(r);
      worst_i = i;
    }
  }
  m.mean_measured = sum_meas / n;
  double sst = 0;
  for (size_t i = 0; i < n; ++i) sst += (meas_[i] - m.mean_measured) * (meas_[i] - m.mean_measured);
  m.rmse = std::sqrt(sse / n);
  if (body_mass_ > 0) m.rmse_bw = m.rmse / (body_mass_ * kStandardGravity);
  m.r2 = sst > 0 ? 1.0 - sse / sst : FitMetrics::nan;
  m.max_abs_error = worst;
  m.time_of_max_error = time_[worst_i];
  m.trial_of_max_error = trials_[trial_index_[worst_i]];
  m.bias = sum_res / n;
  m.peak_measured = peak;
  m.nrmse_peak = peak > 0 ? m.rmse / peak : FitMetrics::nan;
  return m;
}

}  // namespace kneesim::identify
