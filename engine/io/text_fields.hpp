#pragma once
// Internal helpers shared by the text-table readers of the io module (TRC, storage, CSV).
// Not part of the public API: the readers parse megabytes of numbers, so these work on
// string_views into one buffer and never allocate per value.

#include <string>
#include <string_view>
#include <vector>

namespace kneesim::io::detail {

/// Parses a whole field as a double, accepting surrounding blanks, a leading '+', and the NaN
/// and infinity spellings written by C, OpenSim and Windows ("nan", "NaN", "-nan(ind)",
/// "1.#QNAN", "inf", "Infinity"). Returns false for anything else, including an empty field.
bool parseNumber(std::string_view field, double& out);

/// True if @p field is empty or blank.
bool isBlank(std::string_view field);

/// Splits @p line on @p sep into @p out (cleared first), keeping empty fields.
void splitKeepEmpty(std::string_view line, char sep, std::vector<std::string_view>& out);

/// Splits @p line on runs of spaces and tabs into @p out (cleared first); no empty fields.
void splitBlanks(std::string_view line, std::vector<std::string_view>& out);

/// Lines of a text with their 1-based line numbers; accepts LF, CRLF and lone CR line ends.
class LineReader {
 public:
  explicit LineReader(std::string_view text) : text_(text) {}
  /// Fetches the next line into @p line (without its line end); false at the end of the text.
  bool next(std::string_view& line);
  /// Line number of the line last returned by next() (1-based; 0 before the first call).
  int getLineNumber() const { return line_no_; }
  /// True when every line has been returned.
  bool atEnd() const { return pos_ >= text_.size(); }

 private:
  std::string_view text_;
  size_t pos_ = 0;
  int line_no_ = 0;
};

/// Conversion factor to metres for a length unit name ("mm", "millimeters", "CM", "m",
/// "metre", ...). Returns 0 for an unknown unit.
double findLengthUnitScale(std::string_view unit);

/// Formats @p v like printf("%.*g") into @p out (appended); NaN is written as "NaN".
void appendNumber(std::string& out, double v, int significant_digits);

/// Quotes @p s for display in an error message, shortened to a readable length.
std::string quoteForMessage(std::string_view s);

}  // namespace kneesim::io::detail
