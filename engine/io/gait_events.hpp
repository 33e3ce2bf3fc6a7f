#pragma once
// Gait events from force plates: when a foot strikes a plate and leaves it, and the gait cycle and
// phases they define (heel strike to the next heel strike of the same foot).

#include <limits>
#include <string>
#include <vector>

#include "io/c3d.hpp"

namespace kneesim::io {

/// Settings of findFootContacts.
struct FootContactOptions {
  /// Marker on the foot's heel (C3D label); the contact is the foot's when it lies over the plate.
  std::string heel_marker = "RHeel";
  /// Vertical force (N) a plate must rise through for a strike and fall back through for a toe-off.
  double threshold = 20.0;
  /// Runs above the threshold shorter than this (s) are spikes, not contacts, and a drop below it
  /// shorter than this does not end a contact (the JW plates show 1-ms spikes at 20 N).
  double min_duration = 0.02;
};

/// One foot's contact with one force plate.
struct FootContact {
  int plate = -1;  ///< 0-based plate index.
  /// Time (s, on the analog clock of the C3D file) of the first sample above the threshold.
  double strike = std::numeric_limits<double>::quiet_NaN();
  /// First sample at or below the threshold after the strike; NaN if the foot is still on the
  /// plate at the end of the recording.
  double off = std::numeric_limits<double>::quiet_NaN();
};

/// Contacts of the foot carrying @p options.heel_marker with the force plates of @p c3d, sorted by
/// strike time. On each plate, the vertical force's runs above the threshold (runs shorter than
/// min_duration dropped, runs separated by less than min_duration merged) are candidate contacts;
/// the first whose first sample finds the heel marker within the plate's corners (horizontal x and
/// y of the laboratory, z up) is the foot's: strike at its first sample above the threshold, off at
/// the first sample after it at or below. At most one contact per plate.
/// Throws InputError naming the file if the heel marker is not in the file.
std::vector<FootContact> findFootContacts(const C3dFile& c3d, const FootContactOptions& options = {});

/// A gait cycle of one foot: heel strike, toe-off and the next heel strike (s).
struct GaitCycle {
  double strike = std::numeric_limits<double>::quiet_NaN();
  double toe_off = std::numeric_limits<double>::quiet_NaN();  ///< NaN if not seen.
  double next_strike = std::numeric_limits<double>::quiet_NaN();
  /// Whether strike and next_strike are both known.
  bool isComplete() const { return strike == strike && next_strike == next_strike && next_strike > strike; }
  /// Time at @p percent of the cycle (0 = strike, 100 = next strike).
  double getTime(double percent) const { return strike + percent / 100.0 * (next_strike - strike); }
  /// Percent of the cycle at time @p t.
  double getPercent(double t) const { return 100.0 * (t - strike) / (next_strike - strike); }
  /// Toe-off in percent of the cycle (NaN if unknown).
  double getToeOffPercent() const { return getPercent(toe_off); }
};

/// The first gait cycle of @p contacts (sorted, as findFootContacts returns them): the first
/// strike, its toe-off and the second strike. Incomplete (NaN fields) when fewer than two
/// contacts exist.
GaitCycle findGaitCycle(const std::vector<FootContact>& contacts);

}  // namespace kneesim::io
