#include "io/motion_compare.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace kneesim::io {

const ColumnDifference* MotionComparison::findWorst() const {
  const ColumnDifference* worst = nullptr;
  for (const ColumnDifference& c : columns)
    if (!worst || c.rms > worst->rms) worst = &c;
  return worst;
}

MotionComparison compareMotions(const Storage& a, const Storage& b, const std::string& b_label,
                                double time_tolerance) {
  if (a.in_degrees != b.in_degrees)
    throw InputError({b_label, 0, "inDegrees"},
                     std::string("expected angles in ") + (a.in_degrees ? "degrees" : "radians") +
                         " like the first motion, got " + (b.in_degrees ? "degrees" : "radians"));
  const int ta = a.findColumn("time"), tb = b.findColumn("time");
  if (ta < 0 || tb < 0) throw InputError({ta < 0 ? std::string("first motion") : b_label, 0, ""}, "expected a time column, got none");
  MotionComparison out;
  out.rows_first = a.getNumRows();
  out.rows_second = b.getNumRows();
  // Row pairs by time (both files are in time order; a two-pointer walk).
  std::vector<std::pair<int, int>> rows;
  for (int i = 0, j = 0; i < a.getNumRows() && j < b.getNumRows();) {
    const double d = a.data(i, ta) - b.data(j, tb);
    if (std::abs(d) <= time_tolerance) {
      rows.emplace_back(i, j);
      ++i;
      ++j;
    } else if (d < 0) {
      ++i;
    } else {
      ++j;
    }
  }
  out.rows_matched = int(rows.size());
  if (rows.empty())
    throw InputError({b_label, 0, ""}, "expected rows at the times of the first motion, got none within " +
                                           std::to_string(time_tolerance) + " s");
  for (size_t c = 0; c < a.labels.size(); ++c) {
    if (int(c) == ta) continue;
    const int cb = b.findColumn(a.labels[c]);
    if (cb < 0) {
      out.only_in_first.push_back(a.labels[c]);
      continue;
    }
    ColumnDifference d;
    d.label = a.labels[c];
    double sum2 = 0;
    for (const auto& [i, j] : rows) {
      const double e = a.data(i, Eigen::Index(c)) - b.data(j, cb);
      sum2 += e * e;
      d.max = std::max(d.max, std::abs(e));
    }
    d.rms = std::sqrt(sum2 / rows.size());
    out.columns.push_back(d);
  }
  for (size_t c = 0; c < b.labels.size(); ++c)
    if (int(c) != tb && a.findColumn(b.labels[c]) < 0) out.only_in_second.push_back(b.labels[c]);
  return out;
}

}  // namespace kneesim::io
