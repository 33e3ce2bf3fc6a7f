#pragma once
// Numeric CSV tables with one header row of column names.

#include <string>
#include <vector>

#include <Eigen/Core>

namespace kneesim::io {

/// A numeric table read from or written to CSV.
struct CsvTable {
  std::string source_file;          ///< Path the table was read from (empty if built in memory).
  std::vector<std::string> labels;  ///< Column names from the header row, quotes removed.
  Eigen::MatrixXd data;             ///< Rows = data lines, columns = labels; NaN for empty cells.

  /// Index of the column named @p label (exact match), or -1.
  int findColumn(const std::string& label) const;
  /// Index of the first column whose name equals @p label ignoring case and surrounding blanks, or -1.
  int findColumnIgnoreCase(const std::string& label) const;
};

/// Reads a comma-separated file whose first non-blank line names the columns. Accepts LF, CRLF
/// and CR-only line ends, a trailing comma on any line, empty cells (NaN), names and numbers in
/// double quotes, and blank lines (skipped). Throws InputError naming the file and line for a
/// missing header, a duplicated or empty column name, a row with more or fewer cells than the
/// header, or a cell that is not a number.
CsvTable readCsv(const std::string& path);

/// Writes @p table as CSV (names quoted when they contain a comma or quote, numbers with 12
/// significant digits, NaN as an empty cell, LF line ends), atomically.
void writeCsv(const std::string& path, const CsvTable& table);

}  // namespace kneesim::io
