#pragma once
// A model's coordinates over time, smoothed and differentiated the way OpenSim's
// InverseDynamicsTool does it: optional low-pass (dynamics/lowpass.hpp: pad, resample,
// third-order Butterworth forwards and backwards), degrees to radians for rotational
// coordinates, then an interpolating quintic natural spline per coordinate (OpenSim's
// GCVSplineSet(5, ...) with error variance 0) whose derivatives give qdot and qddot.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "dynamics/natural_spline.hpp"
#include "io/storage.hpp"
#include "model/model.hpp"

namespace kneesim::dynamics {

/// How to read a coordinate file.
struct CoordinateSmoothingOptions {
  /// Low-pass cut-off in Hz; negative for none (OpenSim's lowpass_cutoff_frequency_for_coordinates).
  double cutoff_hz = -1.0;
  /// Whether rotational coordinates in the file are in degrees.
  bool in_degrees = true;
};

/// Coordinate trajectories q(t) with derivatives, immutable once built; evaluation allocates
/// nothing, so one object serves every thread.
class CoordinateTrajectories {
 public:
  /// Builds the trajectories of @p model's coordinates from @p coordinates (a .mot/.sto read
  /// from @p file, named in errors). A column matches a coordinate by name, or by an OpenSim 4
  /// state path ".../<coordinate>/value". Coordinates without a column keep their default value
  /// (as OpenSim does; listed by getMissing()). Throws InputError for NaN values, non-increasing
  /// times, or too few rows.
  CoordinateTrajectories(const model::Model& model, const io::Storage& coordinates, const std::string& file,
                         const CoordinateSmoothingOptions& options);

  /// The sample times after filtering (resampled times when the file's steps were not uniform,
  /// padding included): the times OpenSim evaluates inverse dynamics at.
  const std::vector<double>& getTimes() const { return times_; }
  /// First and last time of the file's own rows.
  double getStartTime() const { return start_; }
  double getEndTime() const { return end_; }
  /// Names of the model coordinates the file did not have.
  const std::vector<std::string>& getMissing() const { return missing_; }

  /// q, qdot and qddot at time @p t (model order, SI units) into vectors already sized to the
  /// model's coordinate count. No allocation.
  void calcAt(double t, Eigen::VectorXd& q, Eigen::VectorXd& qdot, Eigen::VectorXd& qddot) const;

 private:
  std::vector<double> times_;
  double start_ = 0, end_ = 0;
  std::vector<NaturalSpline> splines_;  // per model coordinate; empty spline = constant
  std::vector<double> constant_;        // per model coordinate: value when no spline
  std::vector<std::string> missing_;
};

/// Index of the column of @p storage that holds coordinate @p name (by name or by a state
/// path ending in "/<name>/value"), or -1.
int findCoordinateColumn(const io::Storage& storage, const std::string& name);

}  // namespace kneesim::dynamics
