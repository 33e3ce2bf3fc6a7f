#pragma once
// Column-by-column comparison of two motions (.mot/.sto), as OpenSim's regression tests compare
// a result with a stored standard: rows matched by time, RMS and maximum difference per column.

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
  int rows_matched = 0;                    ///< Rows of the first motion with a row of the second at the same time.
  int rows_first = 0, rows_second = 0;
  /// The column with the largest RMS ("" when no column is shared).
  const ColumnDifference* findWorst() const;
};

/// Compares @p a and @p b: each row of @p a is matched with the row of @p b whose time is within
/// @p time_tolerance (s); columns with the same label are compared over the matched rows. Both
/// must store angles in the same unit (inDegrees); throws InputError naming @p b_label otherwise,
/// or when no row matches.
MotionComparison compareMotions(const Storage& a, const Storage& b, const std::string& b_label,
                                double time_tolerance = 1e-6);

}  // namespace kneesim::io
