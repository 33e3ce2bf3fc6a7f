#pragma once
// OpenSim storage files (.sto, .mot): a header ending in "endheader", a line of column labels
// (time first) and rows of numbers.
//
// Two header styles are read:
//   modern OpenSim:  <name> / version=1 / nRows=N / nColumns=M / inDegrees=yes|no / endheader
//   old SIMM motion: <name> / nRows=N / nColumns=M / # SIMM Motion File Header: / name ... /
//                    datacolumns M / datarows N / otherdata 1 / range t0 t1 / endheader
// Values are separated by tabs or spaces; LF, CRLF and CR line ends are accepted.

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace kneesim::io {

/// A table of time histories as OpenSim stores it. Angles stay in the file's unit; in_degrees
/// says which (callers convert rotational coordinates to radians themselves).
struct Storage {
  std::string name;                 ///< First header line (the table's name).
  std::vector<std::string> labels;  ///< Column labels, "time" first.
  Eigen::MatrixXd data;             ///< Rows = frames, columns = labels; NaN where the file says NaN.
  bool in_degrees = false;          ///< True if rotational columns are in degrees.
  /// Other header lines, in order: "key=value" lines as (key, value); SIMM-style "key value"
  /// lines as (key, rest of the line); comment lines as ("#", text).
  std::vector<std::pair<std::string, std::string>> header;

  /// Index of the column labelled @p label, or -1.
  int findColumn(const std::string& label) const;
  /// The column labelled @p label. Throws std::out_of_range naming the label if absent.
  Eigen::VectorXd getColumn(const std::string& label) const;
  /// Number of rows.
  int getNumRows() const { return int(data.rows()); }
};

/// Reads a .sto or .mot file. SIMM motion files (no inDegrees key) are in degrees, as SIMM
/// always wrote angles; modern files without inDegrees are taken as radians (OpenSim's default).
/// Throws InputError naming the file and line for a missing endheader or label line, a row
/// with the wrong number of values, a non-number, or a row count different from nRows.
Storage readStorage(const std::string& path);

/// Writes @p storage in the modern OpenSim format as OpenSim's Storage::print writes it (name,
/// version=1, nRows, nColumns, inDegrees, the other header pairs as key=value, OpenSim's two
/// lines on units and inDegrees, endheader), tab separated, numbers like OpenSim's "%.8f"
/// (values below 1e-3 in magnitude keep 9 significant digits instead), NaN as "NaN", atomically.
void writeStorage(const std::string& path, const Storage& storage);

/// The text writeStorage() writes, for callers that commit several files together.
std::string formatStorage(const Storage& storage);

}  // namespace kneesim::io
