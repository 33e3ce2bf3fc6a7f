#include "io/csv.hpp"

#include <cmath>
#include <limits>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/strings.hpp"
#include "io/text_fields.hpp"

namespace kneesim::io {

int CsvTable::findColumn(const std::string& label) const {
  for (size_t i = 0; i < labels.size(); ++i)
    if (labels[i] == label) return int(i);
  return -1;
}

int CsvTable::findColumnIgnoreCase(const std::string& label) const {
  for (size_t i = 0; i < labels.size(); ++i)
    if (equalsIgnoreCase(trim(labels[i]), trim(label))) return int(i);
  return -1;
}

namespace {

// Splits one CSV line honouring double quotes ("a,b" is one cell, "" inside quotes is a quote).
// Cells are returned unquoted; @p scratch holds unescaped copies when a cell needed one.
void splitCsvLine(std::string_view line, std::vector<std::string_view>& cells, std::vector<std::string>& scratch,
                  const SourceLocation& at) {
  cells.clear();
  scratch.clear();
  if (line.find('"') == std::string_view::npos) {
    detail::splitKeepEmpty(line, ',', cells);
    return;
  }
  // Rare path (quoted names): build unescaped copies, then point the views at them.
  std::vector<std::string> parts;
  std::string cur;
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"') {
        if (i + 1 < line.size() && line[i + 1] == '"') {
          cur += '"';
          ++i;
        } else {
          quoted = false;
        }
      } else {
        cur += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      parts.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (quoted) throw InputError(at, "expected a closing double quote before the end of the line");
  parts.push_back(cur);
  scratch = std::move(parts);
  for (const auto& p : scratch) cells.emplace_back(p);
}

}  // namespace

CsvTable readCsv(const std::string& path) {
  const std::string text = readFileText(path);
  detail::LineReader lines(text);
  std::string_view line;
  CsvTable t;
  t.source_file = path;
  std::vector<std::string_view> cells;
  std::vector<std::string> scratch;

  bool have_header = false;
  while (lines.next(line)) {
    if (detail::isBlank(line)) continue;
    const SourceLocation at{path, lines.getLineNumber(), ""};
    splitCsvLine(line, cells, scratch, at);
    while (!cells.empty() && detail::isBlank(cells.back())) cells.pop_back();  // trailing comma(s)
    for (size_t i = 0; i < cells.size(); ++i) {
      const std::string name(trim(cells[i]));
      if (name.empty())
        throw InputError(at, "expected a name for column " + std::to_string(i + 1) + " in the header row, got an empty cell");
      for (const auto& prev : t.labels)
        if (prev == name) throw InputError(at, "expected unique column names, got '" + name + "' twice");
      t.labels.push_back(name);
    }
    have_header = true;
    break;
  }
  if (!have_header) throw InputError({path, 0, ""}, "expected a header row of column names, the file is empty");
  const size_t nc = t.labels.size();

  std::vector<double> values;
  values.reserve(text.size() / 8);
  size_t rows = 0;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  while (lines.next(line)) {
    if (detail::isBlank(line)) continue;
    const SourceLocation at{path, lines.getLineNumber(), ""};
    splitCsvLine(line, cells, scratch, at);
    while (cells.size() > nc && detail::isBlank(cells.back())) cells.pop_back();
    if (cells.size() != nc)
      throw InputError(at, "expected " + std::to_string(nc) + " cells (one per header column), got " + std::to_string(cells.size()));
    for (size_t c = 0; c < nc; ++c) {
      double v = nan;
      if (!detail::isBlank(cells[c]) && !detail::parseNumber(cells[c], v))
        throw InputError({path, at.line, t.labels[c]}, "expected a number, got " + detail::quoteForMessage(cells[c]));
      values.push_back(v);
    }
    ++rows;
  }
  t.data.resize(Eigen::Index(rows), Eigen::Index(nc));
  for (size_t r = 0; r < rows; ++r)
    for (size_t c = 0; c < nc; ++c) t.data(Eigen::Index(r), Eigen::Index(c)) = values[r * nc + c];
  return t;
}

void writeCsv(const std::string& path, const CsvTable& table) {
  KNEESIM_CHECK(table.data.cols() == Eigen::Index(table.labels.size()) || table.data.size() == 0,
                "CsvTable: data has a different number of columns than labels");
  std::string out;
  out.reserve(size_t(table.data.size()) * 14 + 256);
  for (size_t c = 0; c < table.labels.size(); ++c) {
    if (c) out += ',';
    const std::string& l = table.labels[c];
    if (l.find_first_of(",\"\r\n") != std::string::npos) {
      out += '"';
      for (char ch : l) {
        if (ch == '"') out += '"';
        out += ch;
      }
      out += '"';
    } else {
      out += l;
    }
  }
  out += '\n';
  for (Eigen::Index r = 0; r < table.data.rows(); ++r) {
    for (Eigen::Index c = 0; c < table.data.cols(); ++c) {
      if (c) out += ',';
      const double v = table.data(r, c);
      if (!std::isnan(v)) detail::appendNumber(out, v, 12);
    }
    out += '\n';
  }
  AtomicFile file(path);
  file.stream().write(out.data(), std::streamsize(out.size()));
  file.commit();
}

}  // namespace kneesim::io
