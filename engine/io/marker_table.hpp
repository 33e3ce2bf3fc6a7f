#pragma once
// The marker trajectories that inverse kinematics consumes, whatever file they came from.

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace kneesim::io {

/// Marker trajectories sampled at a fixed rate: one position per marker per frame, in metres,
/// NaN where the marker was not seen. Readers convert the file's length unit on the way in.
struct MarkerTable {
  std::string source_file;                 ///< Path the table was read from (empty if built in memory).
  std::vector<std::string> labels;         ///< Marker names as in the file.
  std::vector<double> time;                ///< Time of each frame, s.
  std::vector<int> frame_numbers;          ///< Frame numbers as numbered in the file.
  double rate = 0;                         ///< Sampling rate, Hz.
  std::string original_units;              ///< Length unit of the file as read ("mm", "cm", "m").
  std::vector<Eigen::Vector3d> positions;  ///< Metres; index frame * labels.size() + marker; NaN = missing.

  /// Number of frames (rows).
  int getNumFrames() const { return int(time.size()); }
  /// Number of markers (columns).
  int getNumMarkers() const { return int(labels.size()); }
  /// Position of @p marker in @p frame, metres (NaN components when missing).
  const Eigen::Vector3d& getPosition(int frame, int marker) const {
    return positions[size_t(frame) * labels.size() + size_t(marker)];
  }
  /// Writable position of @p marker in @p frame.
  Eigen::Vector3d& updPosition(int frame, int marker) { return positions[size_t(frame) * labels.size() + size_t(marker)]; }
  /// True if any coordinate of @p marker in @p frame is NaN.
  bool isMissing(int frame, int marker) const;
  /// Index of the marker called @p name, or -1 if absent. An exact match wins; otherwise a
  /// label of the form "<subject prefix>:<name>" (as Vicon writes for subjects with prefixes,
  /// e.g. "JW:RAsis") matches @p name when exactly one label does.
  int findMarker(const std::string& name) const;
  /// For each marker (in label order): its name and the number of frames in which it is missing.
  std::vector<std::pair<std::string, int>> calcGapCounts() const;
  /// Resizes to @p frames x @p markers, filling positions with NaN (time/frame numbers zeroed).
  void resize(int frames, int markers);
};

/// Reads a marker file chosen by its extension: ".trc" (readTrc) or ".c3d" (readC3d), any case.
/// Throws InputError naming the file for another extension or any problem of the file.
MarkerTable readMarkerFile(const std::string& path);

}  // namespace kneesim::io
