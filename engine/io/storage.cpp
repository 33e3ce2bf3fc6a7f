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

namespace {

// What the header says beyond the Storage's own fields.
struct StorageHeader {
  long n_rows = -1, n_columns = -1;  // -1: not given
};

// One "key=value" header line (nRows, nColumns, inDegrees or any other key).
void readKeyValue(const SourceLocation& at, std::string_view t, size_t eq, Storage& s, StorageHeader& h,
                  bool& saw_in_degrees) {
  const std::string key(trim(t.substr(0, eq)));
  const std::string value(trim(t.substr(eq + 1)));
  if (equalsIgnoreCase(key, "nRows")) {
    h.n_rows = parseInt(value, {at.file, at.line, "nRows"});
  } else if (equalsIgnoreCase(key, "nColumns")) {
    h.n_columns = parseInt(value, {at.file, at.line, "nColumns"});
  } else if (equalsIgnoreCase(key, "inDegrees")) {
    const std::string v = toLower(value);
    if (v == "yes" || v == "true") s.in_degrees = true;
    else if (v == "no" || v == "false") s.in_degrees = false;
    else throw InputError({at.file, at.line, "inDegrees"}, "expected yes or no, got '" + value + "'");
    saw_in_degrees = true;
  } else if (!equalsIgnoreCase(key, "version")) {
    s.header.emplace_back(key, value);
  }
}

// The header, up to and including "endheader": OpenSim's key=value lines, comments and SIMM's
// "key value" lines (a SIMM file's angles are in degrees unless it says otherwise).
StorageHeader readHeader(const std::string& path, detail::LineReader& lines, Storage& s) {
  std::string_view line;
  StorageHeader h;
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
    if (const size_t eq = t.find('='); eq != std::string_view::npos) {
      readKeyValue(at, t, eq, s, h, saw_in_degrees);
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
    if (key == "datarows" && h.n_rows < 0) h.n_rows = parseInt(value, {path, at.line, "datarows"});
    if (key == "datacolumns" && h.n_columns < 0) h.n_columns = parseInt(value, {path, at.line, "datacolumns"});
    s.header.emplace_back(key, value);
  }
  if (!saw_endheader)
    throw InputError({path, lines.getLineNumber(), ""}, "expected a header ending in 'endheader', not found");
  if (!saw_in_degrees && simm) s.in_degrees = true;
  return h;
}

// The column labels: the first non-blank line after the header (nColumns of them, if given).
void readLabels(const std::string& path, detail::LineReader& lines, const StorageHeader& h, Storage& s) {
  std::string_view line;
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
  if (h.n_columns >= 0 && long(s.labels.size()) != h.n_columns)
    throw InputError({path, lines.getLineNumber(), ""}, "expected " + std::to_string(h.n_columns) +
                                                            " column labels (nColumns), got " +
                                                            std::to_string(s.labels.size()));
}

// The data rows (one value per label each; nRows of them, if given) into s.data.
void readRows(const std::string& path, detail::LineReader& lines, const StorageHeader& h, size_t text_size, Storage& s) {
  const size_t nc = s.labels.size();
  std::vector<double> values;
  // Reserved from nRows but never beyond what the text can hold: a corrupt count must not allocate.
  values.reserve(std::min(size_t(h.n_rows > 0 ? h.n_rows : 64) * nc, text_size / 2 + 1));
  std::vector<std::string_view> cells;
  std::string_view line;
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
  if (h.n_rows >= 0 && long(rows) != h.n_rows)
    throw InputError({path, lines.getLineNumber(), ""}, "expected " + std::to_string(h.n_rows) + " data rows (nRows), got " +
                                                            std::to_string(rows) + (long(rows) < h.n_rows ? " (truncated file?)" : ""));
  s.data.resize(Eigen::Index(rows), Eigen::Index(nc));
  for (size_t r = 0; r < rows; ++r)
    for (size_t c = 0; c < nc; ++c) s.data(Eigen::Index(r), Eigen::Index(c)) = values[r * nc + c];
}

}  // namespace

Storage readStorage(const std::string& path) {
  const std::string text = readFileText(path);
  detail::LineReader lines(text);
  Storage s;
  const StorageHeader h = readHeader(path, lines, s);
  readLabels(path, lines, h, s);
  readRows(path, lines, h, text.size(), s);
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
