#include "io/trc.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/strings.hpp"
#include "io/text_fields.hpp"

namespace kneesim::io {

namespace {

using detail::LineReader;

// Splits a header or data line: on tabs if it has any, else on blanks (some writers use spaces).
void splitCells(std::string_view line, std::vector<std::string_view>& out) {
  if (line.find('\t') != std::string_view::npos)
    detail::splitKeepEmpty(line, '\t', out);
  else
    detail::splitBlanks(line, out);
}

std::vector<std::string> nonEmptyCells(std::string_view line) {
  std::vector<std::string_view> cells;
  splitCells(line, cells);
  std::vector<std::string> out;
  for (auto c : cells)
    if (!detail::isBlank(c)) out.emplace_back(trim(c));
  return out;
}

// The lines of a TRC file being read, and where errors are.
struct TrcLines {
  const std::string& path;
  LineReader lines;
  std::string_view line;

  SourceLocation at(const std::string& element) const { return {path, lines.getLineNumber(), element}; }
  // Fetches the next line; "file ends early" naming what was expected at the end.
  void need(const char* what) {
    if (!lines.next(line))
      throw InputError({path, lines.getLineNumber() + 1, ""}, std::string("file ends early: expected ") + what);
  }
};

// What the header lines say.
struct TrcHeader {
  int num_frames = 0, num_markers = 0;
  double scale = 1.0;  // to metres
};

// A header count: a whole number in 0..max.
int readCount(const TrcLines& in, const std::string& value, const char* key, double max) {
  const double v = parseDouble(value, in.at(key));
  if (v < 0 || v != std::floor(v) || v > max)
    throw InputError(in.at(key), "expected a non-negative whole number, got '" + value + "'");
  return int(v);
}

// Lines 1-3: PathFileType, the header keys and their values (DataRate, NumFrames, NumMarkers, Units).
TrcHeader readHeader(TrcLines& in, MarkerTable& table) {
  in.need("the PathFileType line");
  if (!startsWith(trim(in.line), "PathFileType"))
    throw InputError(in.at(""), "expected a TRC file starting with 'PathFileType', got " + detail::quoteForMessage(in.line));
  in.need("the header keys (DataRate CameraRate NumFrames NumMarkers Units ...)");
  const std::vector<std::string> keys = nonEmptyCells(in.line);
  const int keys_line = in.lines.getLineNumber();
  in.need("the header values");
  const std::vector<std::string> values = nonEmptyCells(in.line);
  if (values.size() != keys.size())
    throw InputError(in.at(""), "expected " + std::to_string(keys.size()) + " header values for the keys of line " +
                                    std::to_string(keys_line) + ", got " + std::to_string(values.size()));
  auto findValue = [&](const char* key) -> const std::string* {
    for (size_t i = 0; i < keys.size(); ++i)
      if (equalsIgnoreCase(keys[i], key)) return &values[i];
    return nullptr;
  };
  for (const char* k : {"DataRate", "NumFrames", "NumMarkers", "Units"})
    if (!findValue(k))
      throw InputError({in.path, keys_line, k}, std::string("expected the header key ") + k + " on line " +
                                                    std::to_string(keys_line) + ", not found");
  TrcHeader h;
  table.rate = parseDouble(*findValue("DataRate"), in.at("DataRate"));
  h.num_frames = readCount(in, *findValue("NumFrames"), "NumFrames", 1e8);
  h.num_markers = readCount(in, *findValue("NumMarkers"), "NumMarkers", 1e6);
  const std::string& units = *findValue("Units");
  h.scale = detail::findLengthUnitScale(units);
  if (h.scale == 0) throw InputError(in.at("Units"), "expected a length unit mm, cm or m, got '" + units + "'");
  table.original_units = toLower(units);
  if (h.scale == 1e-3) table.original_units = "mm";
  if (h.scale == 1e-2) table.original_units = "cm";
  if (h.scale == 1.0) table.original_units = "m";
  return h;
}

// Lines 4-5: the marker names (Frame# Time <markers>) and the X1 Y1 Z1 ... labels.
void readMarkerNames(TrcLines& in, int num_markers, MarkerTable& table) {
  in.need("the marker-name line (Frame# Time <markers>)");
  std::vector<std::string> names = nonEmptyCells(in.line);
  if (names.size() < 2 || !equalsIgnoreCase(names[0], "Frame#") || !equalsIgnoreCase(names[1], "Time"))
    throw InputError(in.at(""), "expected the marker-name line to start with 'Frame#' and 'Time', got " +
                                    detail::quoteForMessage(in.line));
  names.erase(names.begin(), names.begin() + 2);
  if (int(names.size()) != num_markers)
    throw InputError(in.at(""), "expected " + std::to_string(num_markers) + " marker names (NumMarkers), got " +
                                    std::to_string(names.size()));
  table.labels = std::move(names);
  in.need("the X1 Y1 Z1 ... line");
  const std::vector<std::string> xyz = nonEmptyCells(in.line);
  if (num_markers > 0 && (xyz.empty() || (xyz[0] != "X1" && xyz[0] != "x1")))
    throw InputError(in.at(""), "expected the coordinate-label line 'X1 Y1 Z1 ...', got " + detail::quoteForMessage(in.line));
}

// One data row already split into @p cells (Frame#, Time, X Y Z per marker), appended to @p table.
void readFrame(const TrcLines& in, const TrcHeader& h, const std::vector<std::string_view>& cells, MarkerTable& table) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  double v;
  // A frame number is a whole number an int holds (converting 1e10 or inf is undefined behaviour).
  if (!detail::parseNumber(cells[0], v) || v != std::floor(v) || !truncatesToInt(v))
    throw InputError(in.at("Frame#"), "expected a frame number, got " + detail::quoteForMessage(cells[0]));
  table.frame_numbers.push_back(int(v));
  if (!detail::parseNumber(cells[1], v) || !std::isfinite(v))
    throw InputError(in.at("Time"), "expected a time in s, got " + detail::quoteForMessage(cells[1]));
  table.time.push_back(v);
  for (int m = 0; m < h.num_markers; ++m) {
    Eigen::Vector3d p;
    bool missing = false;
    for (int k = 0; k < 3; ++k) {
      const std::string_view c = cells[2 + 3 * size_t(m) + size_t(k)];
      if (detail::isBlank(c)) {
        missing = true;
        continue;
      }
      if (!detail::parseNumber(c, p[k]))
        throw InputError(in.at(table.labels[size_t(m)] + "/" + "XYZ"[k]), "expected a number, got " + detail::quoteForMessage(c));
      if (std::isnan(p[k])) missing = true;
    }
    // A marker with any coordinate missing is missing as a whole (as OpenSim reads it).
    table.positions.push_back(missing ? Eigen::Vector3d(nan, nan, nan) : Eigen::Vector3d(p * h.scale));
  }
}

// The data rows after the header, NumFrames of them at least.
void readFrames(TrcLines& in, const TrcHeader& h, size_t text_size, MarkerTable& table) {
  const size_t expected_cells = 2 + 3 * size_t(h.num_markers);
  // Reserve from the header but never beyond what the text can hold (a corrupt NumFrames must
  // not allocate gigabytes): each row takes at least 2 bytes, each coordinate at least 1.
  const size_t max_rows = std::min(size_t(h.num_frames), text_size / 2 + 1);
  table.time.reserve(max_rows);
  table.frame_numbers.reserve(max_rows);
  table.positions.reserve(std::min(max_rows * size_t(h.num_markers), text_size / 3 + 1));
  std::vector<std::string_view> cells;
  while (in.lines.next(in.line)) {
    if (detail::isBlank(in.line)) continue;
    splitCells(in.line, cells);
    while (cells.size() > expected_cells && detail::isBlank(cells.back())) cells.pop_back();
    if (cells.size() != expected_cells)
      throw InputError(in.at(""), "expected " + std::to_string(expected_cells) + " cells (Frame#, Time and X Y Z for " +
                                      std::to_string(h.num_markers) + " markers), got " + std::to_string(cells.size()));
    readFrame(in, h, cells, table);
  }
  if (int(table.time.size()) < h.num_frames)
    throw InputError({in.path, in.lines.getLineNumber() + 1, ""},
                     "truncated TRC file: header promises NumFrames=" + std::to_string(h.num_frames) + " rows, got " +
                         std::to_string(table.time.size()));
}

}  // namespace

MarkerTable readTrc(const std::string& path) {
  const std::string text = readFileText(path);
  TrcLines in{path, LineReader(text), {}};
  MarkerTable table;
  table.source_file = path;
  const TrcHeader h = readHeader(in, table);
  readMarkerNames(in, h.num_markers, table);
  readFrames(in, h, text.size(), table);
  return table;
}

void writeTrc(const std::string& path, const MarkerTable& table, const std::string& units) {
  const double scale = detail::findLengthUnitScale(units);
  if (scale == 0) throw InputError({path, 0, "units"}, "expected a length unit mm, cm or m, got '" + units + "'");
  const int nf = table.getNumFrames();
  const int nm = table.getNumMarkers();
  KNEESIM_CHECK(table.positions.size() == size_t(nf) * size_t(nm), "MarkerTable positions size mismatch");
  const double inv = 1.0 / scale;

  std::string out;
  out.reserve(size_t(nf) * size_t(nm) * 36 + 1024);
  auto num = [&](double v, int digits) { detail::appendNumber(out, v, digits); };
  const std::string file_name = std::filesystem::path(path).filename().string();
  const int first_frame = table.frame_numbers.empty() ? 1 : table.frame_numbers.front();
  out += "PathFileType\t4\t(X/Y/Z)\t" + file_name + "\n";
  out += "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames\n";
  num(table.rate, 10); out += '\t';
  num(table.rate, 10); out += '\t';
  out += std::to_string(nf) + "\t" + std::to_string(nm) + "\t" + units + "\t";
  num(table.rate, 10); out += '\t';
  out += std::to_string(first_frame) + "\t" + std::to_string(nf) + "\n";
  out += "Frame#\tTime";
  for (const auto& l : table.labels) out += "\t" + l + "\t\t";
  out += "\n\t";
  for (int m = 1; m <= nm; ++m) {
    const std::string i = std::to_string(m);
    out += "\tX" + i + "\tY" + i + "\tZ" + i;
  }
  out += "\n\n";
  for (int f = 0; f < nf; ++f) {
    out += std::to_string(table.frame_numbers.size() == size_t(nf) ? table.frame_numbers[size_t(f)] : f + 1);
    out += '\t';
    num(table.time[size_t(f)], 12);
    for (int m = 0; m < nm; ++m) {
      if (table.isMissing(f, m)) {
        out += "\t\t\t";
        continue;
      }
      const Eigen::Vector3d& p = table.getPosition(f, m);
      for (int k = 0; k < 3; ++k) {
        out += '\t';
        num(p[k] * inv, 10);
      }
    }
    out += '\n';
  }
  AtomicFile file(path);
  file.stream().write(out.data(), std::streamsize(out.size()));
  file.commit();
}

}  // namespace kneesim::io
