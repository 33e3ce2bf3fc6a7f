#pragma once
// OpenSim's filtering of coordinate data before inverse dynamics, step by step as
// InverseDynamicsTool::run() does it: pad each column by half its length with an odd reflection
// about the end samples (Signal::Pad), resample to the smallest time step with interpolating
// quintic splines if the steps are not uniform to machine precision (Storage::lowpassIIR calls
// Storage::resample), then a third-order Butterworth low-pass run forwards and backwards
// (Signal::LowpassIIR; the first three samples of each pass are copied, not filtered).

#include <string>
#include <vector>

namespace kneesim::dynamics {

/// Columns sampled at common times.
struct SampledTable {
  std::vector<double> time;
  std::vector<std::vector<double>> columns;  ///< Each as long as time.
};

/// @p x with @p pad samples before and after, reflected about the end samples and negated
/// (2 x_0 - x_j), which keeps the value and slope at the ends (Signal::Pad). @p pad must not
/// exceed x.size() - 1.
std::vector<double> padOddReflection(const std::vector<double>& x, int pad);

/// OpenSim's third-order low-pass Butterworth (bilinear transform with pre-warping) applied
/// forwards then backwards to @p x sampled every @p dt seconds (Signal::LowpassIIR). A cut-off
/// at or above half the sampling rate is lowered to 0.49 times the sampling rate, as OpenSim does.
std::vector<double> lowpassIIR(const std::vector<double>& x, double dt, double cutoff_hz);

/// Pads the times and every column of @p table by @p pad samples (Storage::pad).
void padTable(SampledTable& table, int pad);

/// Storage::lowpassIIR: resamples @p table at its smallest time step with interpolating quintic
/// splines when its mean step exceeds the smallest by more than machine epsilon (the new times
/// run from the first time by repeated addition of that step), then low-passes every column.
/// Throws std::invalid_argument when the times are not strictly increasing or too few to filter.
void lowpassTable(SampledTable& table, double cutoff_hz);

}  // namespace kneesim::dynamics
