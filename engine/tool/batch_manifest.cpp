// Reads batch manifests (CSV or TOML) into rows of column -> text, with the line of every cell.
#include "tool/batch_manifest.hpp"

#include <cpptoml.h>

#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/strings.hpp"

namespace kneesim::tool {

const std::vector<ManifestColumn>& getManifestColumns() {
  static const std::vector<ManifestColumn> columns = {
      {"subject", "subject name (letters, digits, . _ -): the trial's folder and file names"},
      {"trial", "trial name (letters, digits, . _ -)"},
      {"tools", "steps to run, separated by spaces, ';' or '+': ik, contact, workflow"},
      {"model", "model file (.osim or .urdf)"},
      {"markers", "marker file (.c3d or .trc) for ik"},
      {"ik_tasks", "IKTaskSet file (default: every model marker found in the data, weight 1)"},
      {"time_range", "first and last time (s) for ik"},
      {"accuracy", "ik convergence tolerance (default 1e-5)"},
      {"marker_rotation", "body-fixed X Y Z angles (deg) rotating the marker data into the model's ground"},
      {"motion", "an existing motion (.mot/.sto) for contact and workflow when ik is not run"},
      {"activity", "gait, stairs, chair, ...: the workflow's window (stance for gait and stairs, else the trial)"},
      {"window", "the workflow's window: stance, cycle, trial or 'begin end' in s (overrides activity)"},
      {"knee_forces", "measured knee forces (eKnee CSV, load cells in lbf) for workflow"},
      {"c3d", "C3D with force plates for the gait events (default: markers when it is a .c3d)"},
      {"femoral_component", "femoral component STL (m) for contact and workflow"},
      {"insert", "tibial insert STL (m) for contact and workflow"},
      {"femoral_body", "model body carrying the femoral component (default femoral_component)"},
      {"insert_body", "model body carrying the insert (default tibial_component)"},
      {"femoral_mesh", "mesh of femoral_body placing the STL (default: the STL is in the body frame)"},
      {"insert_mesh", "mesh of insert_body placing the STL (default: the STL is in the body frame)"},
      {"threshold", "contact-area threshold (m, default 0.004)"},
      {"distance_provider", "fcl (default), fcl_sdf or MeshDistance"},
      {"body_mass", "body mass (kg): force errors also in body weights"},
      {"plots", "true: the workflow draws its plots (default false)"},
  };
  return columns;
}

const ManifestValue* ManifestRow::find(const std::string& column) const {
  const auto it = values.find(column);
  return it == values.end() ? nullptr : &it->second;
}

namespace {

bool isKnownColumn(const std::string& name) {
  for (const ManifestColumn& c : getManifestColumns())
    if (c.name == name) return true;
  return false;
}

std::string knownColumnList() {
  std::string s;
  for (const ManifestColumn& c : getManifestColumns()) s += (s.empty() ? "" : ", ") + c.name;
  return s;
}

// ---- CSV ----

// Splits one CSV line into cells (RFC 4180 quoting within the line).
std::vector<std::string> splitCsvLine(std::string_view line, const SourceLocation& where) {
  std::vector<std::string> cells(1);
  bool quoted = false, was_quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        cells.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        cells.back() += c;
      }
    } else if (c == '"' && trim(cells.back()).empty() && !was_quoted) {
      cells.back().clear();
      quoted = was_quoted = true;
    } else if (c == ',') {
      cells.emplace_back();
      was_quoted = false;
    } else if (was_quoted && c != ' ' && c != '\t') {
      throw InputError(where, "expected ',' after a quoted cell, got '" + std::string(1, c) + "'");
    } else {
      cells.back() += c;
    }
  }
  if (quoted) throw InputError(where, "expected a closing '\"', got the end of the line (a cell cannot span lines)");
  for (std::string& s : cells) s = std::string(trim(s));
  return cells;
}

Manifest readCsvManifest(const std::string& path, const std::string& text) {
  Manifest m{path, {}};
  std::vector<std::string> header;
  int line_no = 0;
  for (std::string_view line : splitLines(text)) {
    ++line_no;
    const std::string_view t = trim(line);
    if (t.empty() || t.front() == '#') continue;
    const SourceLocation at{path, line_no, header.empty() ? "header" : "row " + std::to_string(m.rows.size() + 1)};
    std::vector<std::string> cells = splitCsvLine(line, at);
    if (header.empty()) {
      for (std::string& c : cells) {
        c = toLower(c);
        const SourceLocation col{path, line_no, "header/" + c};
        if (c.empty()) throw InputError(col, "expected a column name, got an empty cell");
        if (!isKnownColumn(c)) throw InputError(col, "unknown column '" + c + "' (expected " + knownColumnList() + ")");
        for (const std::string& prev : header)
          if (prev == c) throw InputError(col, "column '" + c + "' appears twice");
        header.push_back(c);
      }
      continue;
    }
    if (cells.size() != header.size())
      throw InputError(at, "expected " + std::to_string(header.size()) + " cells as in the header, got " +
                               std::to_string(cells.size()));
    ManifestRow row;
    row.where = at;
    for (size_t i = 0; i < cells.size(); ++i)
      if (!cells[i].empty())
        row.values[header[i]] = {cells[i], {path, line_no, row.where.element + "/" + header[i]}};
    m.rows.push_back(std::move(row));
  }
  if (header.empty()) throw InputError({path, 0, ""}, "expected a header row naming the columns, got an empty file");
  return m;
}

// ---- TOML ----

// cpptoml keeps no positions, so lines are found in the text: the n-th "[[trial]]" header and the
// first line after it that assigns the key.
struct TomlLines {
  std::vector<std::string_view> lines;
  int findTable(const std::string& header, int n) const {
    int seen = 0;
    for (size_t i = 0; i < lines.size(); ++i)
      if (startsWith(trim(lines[i]), header) && seen++ == n) return int(i) + 1;
    return 0;
  }
  int findKey(int table_line, const std::string& key) const {
    for (size_t i = size_t(std::max(table_line, 0)); i < lines.size(); ++i) {
      const std::string_view t = trim(lines[i]);
      if (startsWith(t, "[")) break;
      if (startsWith(t, key) && trim(t.substr(key.size())).substr(0, 1) == "=") return int(i) + 1;
    }
    return table_line;
  }
};

// The text of a TOML value: strings as they are, numbers in full precision, booleans as
// true/false, arrays of those separated by spaces.
std::string tomlText(const std::shared_ptr<cpptoml::base>& v, const SourceLocation& where) {
  if (auto s = v->as<std::string>()) return s->get();
  if (auto i = v->as<int64_t>()) return std::to_string(i->get());
  if (auto d = v->as<double>()) return formatRoundTrip(d->get());
  if (auto b = v->as<bool>()) return b->get() ? "true" : "false";
  if (v->is_array()) {
    std::string s;
    for (const auto& e : v->as_array()->get()) s += (s.empty() ? "" : " ") + tomlText(e, where);
    return s;
  }
  throw InputError(where, "expected a string, number, boolean or array, got a table or date");
}

void readTomlTable(const cpptoml::table& table, const std::string& path, const TomlLines& lines, int table_line,
                   const std::string& element, std::map<std::string, ManifestValue>& out) {
  for (const auto& [key, value] : table) {
    const std::string column = toLower(key);
    const SourceLocation at{path, lines.findKey(table_line, key), element + "/" + key};
    if (!isKnownColumn(column))
      throw InputError(at, "unknown key '" + key + "' (expected " + knownColumnList() + ")");
    const std::string text(trim(tomlText(value, at)));
    if (!text.empty()) out[column] = {text, at};
  }
}

Manifest readTomlManifest(const std::string& path, const std::string& text) {
  std::shared_ptr<cpptoml::table> root;
  try {
    std::istringstream in(text);
    cpptoml::parser parser(in);
    root = parser.parse();
  } catch (const cpptoml::parse_exception& e) {
    // cpptoml says "... at line N": move the line into the location.
    std::string msg = e.what();
    int line = 0;
    const size_t at = msg.rfind(" at line ");
    if (at != std::string::npos) {
      line = std::atoi(msg.c_str() + at + 9);
      msg.erase(at);
    }
    throw InputError({path, line, ""}, "TOML: " + msg);
  }
  TomlLines lines{splitLines(text)};
  for (const auto& [key, value] : *root)
    if (key != "trial" && key != "defaults")
      throw InputError({path, lines.findKey(0, key), key},
                       "expected [[trial]] tables and an optional [defaults] table, got '" + key + "'");
  std::map<std::string, ManifestValue> defaults;
  if (root->contains("defaults")) {
    auto d = root->get_table("defaults");
    if (!d) throw InputError({path, lines.findKey(0, "defaults"), "defaults"}, "expected a [defaults] table");
    readTomlTable(*d, path, lines, lines.findTable("[defaults]", 0), "defaults", defaults);
  }
  Manifest m{path, {}};
  auto trials = root->get_table_array("trial");
  if (root->contains("trial") && !trials)
    throw InputError({path, lines.findKey(0, "trial"), "trial"}, "expected [[trial]] tables, got another kind of value");
  if (trials) {
    for (const auto& t : *trials) {
      const int n = int(m.rows.size());
      ManifestRow row;
      row.where = {path, lines.findTable("[[trial]]", n), "trial[" + std::to_string(n + 1) + "]"};
      row.values = defaults;
      readTomlTable(*t, path, lines, row.where.line, row.where.element, row.values);
      m.rows.push_back(std::move(row));
    }
  }
  return m;
}

}  // namespace

Manifest readManifest(const std::string& path) {
  const std::string text = readFileText(path);
  Manifest m = endsWith(toLower(path), ".toml") ? readTomlManifest(path, text) : readCsvManifest(path, text);
  if (m.rows.empty()) throw InputError({path, 0, ""}, "expected at least one trial, got none");
  return m;
}

}  // namespace kneesim::tool
