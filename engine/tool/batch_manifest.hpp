#pragma once
// Reading a batch manifest: the table of trials `kneesim batch` runs, one row per trial, as CSV
// (a header row naming the columns) or TOML (a [[trial]] table per trial, optional [defaults]).
// This file only reads and checks the table's shape; batch_plan.hpp gives the columns meaning.

#include <map>
#include <string>
#include <vector>

#include "core/error.hpp"

namespace kneesim::tool {

/// One column a manifest may have.
struct ManifestColumn {
  std::string name;         ///< Lower case, e.g. "markers".
  std::string description;  ///< One line for the documentation and for error messages.
};

/// The columns a manifest may have, in the order the documentation lists them.
const std::vector<ManifestColumn>& getManifestColumns();

/// One cell of a manifest: its text and where it was written (file, line, "row 3/markers").
struct ManifestValue {
  std::string text;
  SourceLocation where;
};

/// One row (trial) of a manifest.
struct ManifestRow {
  std::map<std::string, ManifestValue> values;  ///< Column -> value; empty cells are left out.
  SourceLocation where;                         ///< The row.
  /// The value of @p column, or nullptr when the row leaves it empty.
  const ManifestValue* find(const std::string& column) const;
};

/// A manifest as read.
struct Manifest {
  std::string file;               ///< The path as given.
  std::vector<ManifestRow> rows;  ///< In file order.
};

/// Reads a manifest: `.toml` as TOML, anything else as CSV. CSV: the first line that is neither
/// blank nor a comment (`#`) names the columns (any case, surrounding blanks ignored); cells may
/// be double-quoted ("" for a quote inside), LF, CRLF or CR line ends. TOML: [[trial]] tables of
/// string, number, boolean or array values (arrays become space-separated text) and an optional
/// [defaults] table whose values every trial takes unless it gives its own. Throws InputError
/// naming the file and line for an unknown or doubled column, a row with another number of cells
/// than the header, an unterminated quote, TOML syntax, a nested table, or no rows.
Manifest readManifest(const std::string& path);

}  // namespace kneesim::tool
