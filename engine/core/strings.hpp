#pragma once
// Small text helpers shared by the file readers.

#include <string>
#include <string_view>
#include <vector>

#include "core/error.hpp"

namespace kneesim {

/// Returns @p s without leading and trailing whitespace (space, tab, CR, LF).
std::string_view trim(std::string_view s);
/// Splits @p s on runs of whitespace; no empty fields.
std::vector<std::string_view> splitWhitespace(std::string_view s);
/// Splits @p s on every @p sep; keeps empty fields (a CSV row "a,,b" has three fields).
std::vector<std::string_view> splitOn(std::string_view s, char sep);
/// Lower-case ASCII copy.
std::string toLower(std::string_view s);
bool startsWith(std::string_view s, std::string_view prefix);
bool endsWith(std::string_view s, std::string_view suffix);
/// Case-insensitive ASCII equality.
bool equalsIgnoreCase(std::string_view a, std::string_view b);

/// Parses a whole field as a double ("nan", "inf", "Infinity" accepted). Returns false on
/// anything else, including trailing garbage.
bool tryParseDouble(std::string_view s, double& out);
/// Parses a double or throws InputError at @p where: "expected a number, got 'abc'".
double parseDouble(std::string_view s, const SourceLocation& where);
/// Parses an integer or throws InputError at @p where.
long parseInt(std::string_view s, const SourceLocation& where);
/// Parses "true"/"false" (any case) or throws InputError at @p where.
bool parseBool(std::string_view s, const SourceLocation& where);
/// True when @p v converts to an int (truncated): converting NaN, inf or 1e10 is undefined behaviour,
/// so a reader checks a number from a file with this before the conversion.
inline bool truncatesToInt(double v) { return v > -2147483649.0 && v < 2147483648.0; }

/// @p v with @p digits significant digits, as an ostream with that precision prints it ("0.25",
/// "1.5e+06", "nan"): for messages and reports.
std::string formatSignificant(double v, int digits);

/// The shortest text that reads back as exactly @p v (std::to_chars: "0.004", "66.7", "-90",
/// "1e-05", "nan"): for numbers written into files that are read again.
std::string formatRoundTrip(double v);

/// @p s as one word for the POSIX shell: in single quotes, a quote inside written '\''.
std::string shellQuote(const std::string& s);

/// The elements of @p parts (strings or string views, in iteration order) separated by @p sep:
/// join({"a", "b"}, ", ") is "a, b"; empty for no elements.
template <class Range>
std::string join(const Range& parts, std::string_view sep) {
  std::string s;
  bool first = true;
  for (const auto& x : parts) {
    if (!first) s += sep;
    s += x;
    first = false;
  }
  return s;
}

/// Reads a whole file into a string; throws InputError naming the file if it cannot be read.
std::string readFileText(const std::string& path);

/// Splits text into lines accepting LF, CRLF and lone CR line ends.
std::vector<std::string_view> splitLines(std::string_view text);

}  // namespace kneesim
