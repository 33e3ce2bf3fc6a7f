#pragma once
// Agreement between predicted and measured force over a set of frames.

#include <limits>
#include <string>
#include <vector>

namespace kneesim::identify {

/// Standard gravity, m/s^2, for errors in body weights.
constexpr double kStandardGravity = 9.80665;

/// Error statistics of predicted against measured force (unweighted, over the frames given).
/// Residuals are predicted - measured.
struct FitMetrics {
  static constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  int n_frames = 0;
  double rmse = nan;            ///< Root mean square error, N.
  double rmse_bw = nan;         ///< RMSE in body weights (NaN without a body mass).
  double r2 = nan;              ///< Coefficient of determination 1 - SSE/SST (NaN if SST = 0).
  double max_abs_error = nan;   ///< Largest |residual|, N.
  double time_of_max_error = nan;  ///< Time of that frame, s.
  std::string trial_of_max_error;  ///< Trial of that frame.
  double bias = nan;            ///< Mean residual, N (> 0: the law over-predicts).
  double mean_measured = nan;   ///< Mean measured force, N.
  double peak_measured = nan;   ///< Largest measured force, N.
  double nrmse_peak = nan;      ///< RMSE / peak measured force (NaN if the peak is not positive).
};

/// Accumulates frames (possibly from several trials) and computes FitMetrics.
class MetricsAccumulator {
 public:
  /// @p body_mass in kg; 0 or less leaves rmse_bw NaN.
  explicit MetricsAccumulator(double body_mass = 0) : body_mass_(body_mass) {}
  /// Adds frames @p frames of one trial.
  void add(const std::string& trial, const std::vector<double>& time, const double* predicted,
           const double* measured, const std::vector<int>& frames);
  /// The statistics of everything added so far (all NaN and n_frames = 0 if nothing was added).
  FitMetrics calc() const;

 private:
  double body_mass_;
  std::vector<double> pred_, meas_;
  std::vector<double> time_;
  std::vector<int> trial_index_;
  std::vector<std::string> trials_;
};

}  // namespace kneesim::identify
