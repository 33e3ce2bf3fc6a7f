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

}  // namespace

MarkerTable readTrc(const std::string& path) {
  const std::string text = readFileText(path);
  LineReader lines(text);
  std::string_view line;
  auto at = [&](const std::string& element) { return SourceLocation{path, lines.getLineNumber(), element}; };
  auto need = [&](const char* what) {
    if (!lines.next(line))
      throw InputError({path, lines.getLineNumber() + 1, ""}, std::string("file ends early: expected ") + what);
  };

  need("the PathFileType line");
  if (!startsWith(trim(line), "PathFileType"))
    throw InputError(at(""), "expected a TRC file starting with 'PathFileType', got " + detail::quoteForMessage(line));

  need("the header keys (DataRate CameraRate NumFrames NumMarkers Units ...)");
  const std::vector<std::string> keys = nonEmptyCells(line);
  const int keys_line = lines.getLineNumber();
  need("the header values");
  const std::vector<std::string> values = nonEmptyCells(line);
  if (values.size() != keys.size())
    throw InputError(at(""), "expected " + std::to_string(keys.size()) + " header values for the keys of line " +
                                 std::to_string(keys_line) + ", got " + std::to_string(values.size()));
  auto findValue = [&](const char* key) -> const std::string* {
    for (size_t i = 0; i < keys.size(); ++i)
      if (equalsIgnoreCase(keys[i], key)) return &values[i];
    return nullptr;
  };
  for (const char* k : {"DataRate", "NumFrames", "NumMarkers", "Units"})
    if (!findValue(k))
      throw InputError({path, keys_line, k}, std::string("expected the header key ") + k + " on line " +
                                                 std::to_string(keys_line) + ", not found");

  MarkerTable table;
  table.source_file = path;
  table.rate = parseDouble(*findValue("DataRate"), at("DataRate"));
  const double frames_d = parseDouble(*findValue("NumFrames"), at("NumFrames"));
  const double markers_d = parseDouble(*findValue("NumMarkers"), at("NumMarkers"));
  if (frames_d < 0 || frames_d != std::floor(frames_d) || frames_d > 1e8)
    throw InputError(at("NumFrames"), "expected a non-negative whole number, got '" + *findValue("NumFrames") + "'");
  if (markers_d < 0 || markers_d != std::floor(markers_d) || markers_d > 1e6)
    throw InputError(at("NumMarkers"), "expected a non-negative whole number, got '" + *findValue("NumMarkers") + "'");
  const int num_frames = int(frames_d);
  const int num_markers = int(markers_d);
  const std::string& units = *findValue("Units");
  const double scale = detail::findLengthUnitScale(units);
  if (scale == 0)
    throw InputError(at("Units"), "expected a length unit mm, cm or m, got '" + units + "'");
  table.original_units = toLower(units);
  if (scale == 1e-3) table.original_units = "mm";
  if (scale == 1e-2) table.original_units = "cm";
  if (scale == 1.0) table.original_units = "m";

  need("the marker-name line (Frame# Time <markers>)");
  std::vector<std::string> names = nonEmptyCells(line);
  if (names.size() < 2 || !equalsIgnoreCase(names[0], "Frame#") || !equalsIgnoreCase(names[1], "Time"))
    throw InputError(at(""), "expected the marker-name line to start with 'Frame#' and 'Time', got " +
                                 detail::quoteForMessage(line));
  names.erase(names.begin(), names.begin() + 2);
  if (int(names.size()) != num_markers)
    throw InputError(at(""), "expected " + std::to_string(num_markers) + " marker names (NumMarkers), got " +
                                 std::to_string(names.size()));
  table.labels = std::move(names);

  need("the X1 Y1 Z1 ... line");
  {
    const std::vector<std::string> xyz = nonEmptyCells(line);
    if (num_markers > 0 && (xyz.empty() || (xyz[0] != "X1" && xyz[0] != "x1")))
      throw InputError(at(""), "expected the coordinate-label line 'X1 Y1 Z1 ...', got " + detail::quoteForMessage(line));
  }

  const size_t expected_cells = 2 + 3 * size_t(num_markers);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // Reserve from the header but never beyond what the text can hold (a corrupt NumFrames must
  // not allocate gigabytes): each row takes at least 2 bytes, each coordinate at least 1.
  const size_t max_rows = std::min(size_t(num_frames), text.size() / 2 + 1);
  table.time.reserve(max_rows);
  table.frame_numbers.reserve(max_rows);
  table.positions.reserve(std::min(max_rows * size_t(num_markers), text.size() / 3 + 1));
  std::vector<std::string_view> cells;
  while (lines.next(line)) {
    if (detail::isBlank(line)) continue;
    splitCells(line, cells);
    while (cells.size() > expected_cells && detail::isBlank(cells.back())) cells.pop_back();
    if (cells.size() != expected_cells)
      throw InputError(at(""), "expected " + std::to_string(expected_cells) + " cells (Frame#, Time and X Y Z for " +
                                   std::to_string(num_markers) + " markers), got " + std::to_string(cells.size()));
    double v;
    if (!detail::parseNumber(cells[0], v) || v != std::floor(v))
      throw InputError(at("Frame#"), "expected a frame number, got " + detail::quoteForMessage(cells[0]));
    table.frame_numbers.push_back(int(v));
    if (!detail::parseNumber(cells[1], v) || !std::isfinite(v))
      throw InputError(at("Time"), "expected a time in s, got " + detail::quoteForMessage(cells[1]));
    table.time.push_back(v);
    for (int m = 0; m < num_markers; ++m) {
      Eigen::Vector3d p;
      bool missing = false;
      for (int k = 0; k < 3; ++k) {
        const std::string_view c = cells[2 + 3 * size_t(m) + size_t(k)];
        if (detail::isBlank(c)) {
          missing = true;
          continue;
        }
        if (!detail::parseNumber(c, p[k]))
          throw InputError(at(table.labels[size_t(m)] + "/" + "XYZ"[k]),
                           "expected a number, got " + detail::quoteForMessage(c));
        if (std::isnan(p[k])) missing = true;
      }
      // A marker with any coordinate missing is missing as a whole (as OpenSim reads it).
      table.positions.push_back(missing ? Eigen::Vector3d(nan, nan, nan) : Eigen::Vector3d(p * scale));
    }
  }
  if (int(table.time.size()) < num_frames)
    throw InputError({path, lines.getLineNumber() + 1, ""},
                     "truncated TRC file: header promises NumFrames=" + std::to_string(num_frames) + " rows, got " +
                         std::to_string(table.time.size()));
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
