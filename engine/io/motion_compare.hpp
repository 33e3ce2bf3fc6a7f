#pragma once
// Column-by-column comparison of two motions (.mot/.sto), as OpenSim's regression tests compare
// a result with a stored standard: the second motion taken at the first one's times (the row at
// that time, else linear interpolation between its neighbours), RMS and maximum difference per
// column.

#include <string>
#include <vector>

#include "io/storage.hpp"

namespace kneesim::io {

/// Difference of one column present in both motions, over the matched rows.
struct ColumnDifference {
  std::string label;
  double rms = 0;  ///< Root mean square of (a - b), in the files' unit.
  double max = 0;  ///< Largest |a - b|.
};

/// Result of compareMotions().
struct MotionComparison {
  std::vector<ColumnDifference> columns;   ///< Columns in both, in the order of the first motion (time excluded).
  std::vector<std::string> only_in_first;  ///< Labels the second motion lacks.
  std::vector<std::string> only_in_second;
  int rows_matched = 0;       ///< Rows of the first motion compared with a row of the second at the same time.
  int rows_interpolated = 0;  ///< Rows compared with the second motion interpolated at their time.
  int rows_outside = 0;       ///< Rows of the first motion outside the second's time span, not compared.
  int rows_first = 0, rows_second = 0;
  /// Rows compared (matched + interpolated).
  int getRowsCompared() const { return rows_matched + rows_interpolated; }
  /// The column with the largest RMS ("" when no column is shared).
  const ColumnDifference* findWorst() const;
};

/// Compares @p a and @p b: each row of @p a is compared with the row of @p b whose time is within
/// @p time_tolerance (s) of it, else with @p b interpolated linearly at its time between the two
/// rows around it; rows of @p a outside @p b's time span are left out. Columns with the same
/// label are compared. Both must store angles in the same unit (inDegrees); throws InputError
/// naming @p b_label otherwise, or when no row of @p a lies within @p b's time span.
MotionComparison compareMotions(const Storage& a, const Storage& b, const std::string& b_label,
                                double time_tolerance = 1e-6);

}  // namespace kneesim::io
