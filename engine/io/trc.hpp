#pragma once
// Motion Analysis / OpenSim TRC marker files.
//
// Layout (tab separated, LF, CRLF or CR line ends):
//   1  PathFileType  4  (X/Y/Z)  <name>
//   2  DataRate CameraRate NumFrames NumMarkers Units OrigDataRate OrigDataStartFrame OrigNumFrames
//   3  the values of line 2
//   4  Frame#  Time  <marker 1>  ""  ""  <marker 2>  ...     (empty cells between names are ignored)
//   5  ""  ""  X1 Y1 Z1 X2 Y2 Z2 ...
//   6  optional blank line
//      rows: <frame#> <time> x y z x y z ...                  (blank cell or NaN = marker missing)

#include <string>

#include "io/marker_table.hpp"

namespace kneesim::io {

/// Reads a TRC file. Coordinates are converted from the file's Units (mm, cm or m in any case
/// or spelling such as "millimeters") to metres. A blank or NaN cell makes that marker missing
/// (NaN) in that frame; gaps are data, not errors. Throws InputError naming the file and line
/// for: a missing header line, an unknown unit (line 3), a marker-name count different from
/// NumMarkers, a row with fewer cells than 2 + 3 NumMarkers, a cell that is not a number, or a
/// file that ends before NumFrames rows (truncated). Rows beyond NumFrames are read as well.
MarkerTable readTrc(const std::string& path);

/// Writes @p table as a TRC file with coordinates in @p units ("mm", "cm" or "m"), missing
/// markers as empty cells, atomically. Frame numbers are taken from the table (1, 2, ... if it
/// has none). Throws InputError for an unknown unit or an output that cannot be written.
void writeTrc(const std::string& path, const MarkerTable& table, const std::string& units = "mm");

}  // namespace kneesim::io
