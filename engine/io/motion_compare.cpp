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
  // Each row of a: the row of b at its time (j1 = j0), or the two rows around it and the weight
  // of the later one (both files are in time order; a two-pointer walk).
  struct Sample {
    int i, j0, j1;
    double w;
  };
  std::vector<Sample> rows;
  const int nb = b.getNumRows();
  for (int i = 0, j = 0; i < a.getNumRows(); ++i) {
    const double t = a.data(i, ta);
    while (j + 1 < nb && b.data(j + 1, tb) <= t + time_tolerance) ++j;
    if (nb == 0) break;
    if (std::abs(b.data(j, tb) - t) <= time_tolerance) {
      rows.push_back({i, j, j, 0.0});
      ++out.rows_matched;
    } else if (j + 1 < nb && b.data(j, tb) < t && t < b.data(j + 1, tb)) {
      const double w = (t - b.data(j, tb)) / (b.data(j + 1, tb) - b.data(j, tb));
      rows.push_back({i, j, j + 1, w});
      ++out.rows_interpolated;
    } else {
      ++out.rows_outside;
    }
  }
  if (rows.empty())
    throw InputError({b_label, 0, ""}, "expected rows at or around the times of the first motion, got none within " +
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
    for (const Sample& r : rows) {
      const double vb = (1 - r.w) * b.data(r.j0, cb) + r.w * b.data(r.j1, cb);
      const double e = a.data(r.i, Eigen::Index(c)) - vb;
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
