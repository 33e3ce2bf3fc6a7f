#include "io/storage.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/strings.hpp"
#include "io/text_fields.hpp"

namespace kneesim::io {

int Storage::findColumn(const std::string& label) const {
  for (size_t i = 0; i < labels.size(); ++i)
    if (labels[i] == label) return int(i);
  return -1;
}

Eigen::VectorXd Storage::getColumn(const std::string& label) const {
  const int c = findColumn(label);
  if (c < 0) throw std::out_of_range("Storage '" + name + "' has no column '" + label + "'");
  return data.col(c);
}

namespace {

// The standard lines OpenSim writes in every storage header.
const char* const kUnitsLine = "Units are S.I. units (second, meters, Newtons, ...)";
const char* const kDegreesLine =
    "If the header above contains a line with 'inDegrees', this indicates whether rotational values are in degrees "
    "(yes) or radians (no).";

bool isReservedKey(const std::string& key) {
  return equalsIgnoreCase(key, "version") || equalsIgnoreCase(key, "nRows") || equalsIgnoreCase(key, "nColumns") ||
         equalsIgnoreCase(key, "inDegrees");
}

}  // namespace

Storage readStorage(const std::string& path) {
  const std::string text = readFileText(path);
  detail::LineReader lines(text);
  std::string_view line;
  Storage s;
  long n_rows = -1, n_columns = -1;
  bool saw_in_degrees = false, simm = false, saw_endheader = false, first = true;

  while (lines.next(line)) {
    const std::string_view t = trim(line);
    const SourceLocation at{path, lines.getLineNumber(), ""};
    if (t == "endheader") {
      saw_endheader = true;
      break;
    }
    if (first) {
      first = false;
      if (t.find('=') == std::string_view::npos) {
        s.name = std::string(t);
        continue;
      }
    }
    if (t.empty() || t == kUnitsLine || t == kDegreesLine) continue;
    const size_t eq = t.find('=');
    if (eq != std::string_view::npos) {
      const std::string key(trim(t.substr(0, eq)));
      const std::string value(trim(t.substr(eq + 1)));
      if (equalsIgnoreCase(key, "nRows")) {
        n_rows = parseInt(value, {path, at.line, "nRows"});
      } else if (equalsIgnoreCase(key, "nColumns")) {
        n_columns = parseInt(value, {path, at.line, "nColumns"});
      } else if (equalsIgnoreCase(key, "inDegrees")) {
        const std::string v = toLower(value);
        if (v == "yes" || v == "true") s.in_degrees = true;
        else if (v == "no" || v == "false") s.in_degrees = false;
        else throw InputError({path, at.line, "inDegrees"}, "expected yes or no, got '" + value + "'");
        saw_in_degrees = true;
      } else if (!equalsIgnoreCase(key, "version")) {
        s.header.emplace_back(key, value);
      }
      continue;
    }
    if (t[0] == '#') {
      if (t.find("SIMM") != std::string_view::npos) simm = true;
      s.header.emplace_back("#", std::string(trim(t.substr(1))));
      continue;
    }
    // SIMM style "key value..." line.
    size_t sp = 0;
    while (sp < t.size() && t[sp] != ' ' && t[sp] != '\t') ++sp;
    const std::string key(t.substr(0, sp));
    const std::string value(trim(t.substr(sp)));
    if (key == "datacolumns" || key == "datarows" || key == "otherdata" || key == "range") simm = true;
    if (key == "datarows" && n_rows < 0) n_rows = parseInt(value, {path, at.line, "datarows"});
    if (key == "datacolumns" && n_columns < 0) n_columns = parseInt(value, {path, at.line, "datacolumns"});
    s.header.emplace_back(key, value);
  }
  if (!saw_endheader)
    throw InputError({path, lines.getLineNumber(), ""}, "expected a header ending in 'endheader', not found");
  if (!saw_in_degrees && simm) s.in_degrees = true;

  // Column labels: first non-blank line after the header.
  bool have_labels = false;
  while (lines.next(line)) {
    if (detail::isBlank(line)) continue;
    std::vector<std::string_view> cells;
    if (line.find('\t') != std::string_view::npos)
      detail::splitKeepEmpty(line, '\t', cells);
    else
      detail::splitBlanks(line, cells);
    for (auto c : cells)
      if (!detail::isBlank(c)) s.labels.emplace_back(trim(c));
    have_labels = true;
    break;
  }
  if (!have_labels) throw InputError({path, lines.getLineNumber() + 1, ""}, "expected the column-label line after endheader, file ends");
  if (n_columns >= 0 && long(s.labels.size()) != n_columns)
    throw InputError({path, lines.getLineNumber(), ""}, "expected " + std::to_string(n_columns) +
                                                            " column labels (nColumns), got " +
                                                            std::to_string(s.labels.size()));
  const size_t nc = s.labels.size();

  std::vector<double> values;
  values.reserve(std::min(size_t(n_rows > 0 ? n_rows : 64) * nc, text.size() / 2 + 1));
  std::vector<std::string_view> cells;
  size_t rows = 0;
  while (lines.next(line)) {
    if (detail::isBlank(line)) continue;
    detail::splitBlanks(line, cells);
    if (cells.size() != nc)
      throw InputError({path, lines.getLineNumber(), ""},
                       "expected " + std::to_string(nc) + " values (one per column label), got " + std::to_string(cells.size()));
    for (size_t c = 0; c < nc; ++c) {
      double v;
      if (!detail::parseNumber(cells[c], v))
        throw InputError({path, lines.getLineNumber(), s.labels[c]}, "expected a number, got " + detail::quoteForMessage(cells[c]));
      values.push_back(v);
    }
    ++rows;
  }
  if (n_rows >= 0 && long(rows) != n_rows)
    throw InputError({path, lines.getLineNumber(), ""}, "expected " + std::to_string(n_rows) + " data rows (nRows), got " +
                                                            std::to_string(rows) + (long(rows) < n_rows ? " (truncated file?)" : ""));
  s.data.resize(Eigen::Index(rows), Eigen::Index(nc));
  for (size_t r = 0; r < rows; ++r)
    for (size_t c = 0; c < nc; ++c) s.data(Eigen::Index(r), Eigen::Index(c)) = values[r * nc + c];
  return s;
}

std::string formatStorage(const Storage& s) {
  KNEESIM_CHECK(s.data.cols() == Eigen::Index(s.labels.size()) || s.data.size() == 0,
                "Storage '" + s.name + "': data has a different number of columns than labels");
  std::string out;
  out.reserve(size_t(s.data.size()) * 14 + 512);
  out += (s.name.empty() ? "storage" : s.name) + "\n";
  out += "version=1\n";
  out += "nRows=" + std::to_string(s.data.rows()) + "\n";
  out += "nColumns=" + std::to_string(s.labels.size()) + "\n";
  out += std::string("inDegrees=") + (s.in_degrees ? "yes" : "no") + "\n";
  for (const auto& [k, v] : s.header) {
    if (isReservedKey(k) || k == "endheader") continue;
    if (k == "#")
      out += "# " + v + "\n";
    else
      out += k + "=" + v + "\n";
  }
  // OpenSim's Storage::print writes these two lines in every header.
  out += std::string("\n") + kUnitsLine + "\n" + kDegreesLine + "\n\n";
  out += "endheader\n";
  for (size_t c = 0; c < s.labels.size(); ++c) {
    if (c) out += '\t';
    out += s.labels[c];
  }
  out += '\n';
  char buf[64];
  for (Eigen::Index r = 0; r < s.data.rows(); ++r) {
    for (Eigen::Index c = 0; c < s.data.cols(); ++c) {
      if (c) out += '\t';
      const double v = s.data(r, c);
      int n;
      if (std::isnan(v))
        n = std::snprintf(buf, sizeof buf, "NaN");
      else if (v != 0 && std::fabs(v) < 1e-3)
        n = std::snprintf(buf, sizeof buf, "%.9g", v);  // %.8f would flatten small errors to zero
      else
        n = std::snprintf(buf, sizeof buf, "%.8f", v);
      out.append(buf, size_t(n));
    }
    out += '\n';
  }
  return out;
}

void writeStorage(const std::string& path, const Storage& s) {
  const std::string out = formatStorage(s);
  AtomicFile file(path);
  file.stream().write(out.data(), std::streamsize(out.size()));
  file.commit();
}

}  // namespace kneesim::io
