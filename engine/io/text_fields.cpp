#include "io/text_fields.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/strings.hpp"

namespace kneesim::io::detail {

namespace {
bool isBlankChar(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }
char lowerAscii(char c) { return (c >= 'A' && c <= 'Z') ? char(c - 'A' + 'a') : c; }
bool containsIgnoreCase(std::string_view s, std::string_view what) {
  if (what.size() > s.size()) return false;
  for (size_t i = 0; i + what.size() <= s.size(); ++i) {
    size_t k = 0;
    while (k < what.size() && lowerAscii(s[i + k]) == what[k]) ++k;
    if (k == what.size()) return true;
  }
  return false;
}
}  // namespace

bool isBlank(std::string_view field) {
  for (char c : field)
    if (!isBlankChar(c)) return false;
  return true;
}

bool parseNumber(std::string_view s, double& out) {
  size_t b = 0, e = s.size();
  while (b < e && isBlankChar(s[b])) ++b;
  while (e > b && isBlankChar(s[e - 1])) --e;
  if (b == e) return false;
  const char* first = s.data() + b;
  const char* last = s.data() + e;
  if (*first == '+') ++first;
  if (first == last) return false;
  const auto r = std::from_chars(first, last, out);
  if (r.ec == std::errc() && r.ptr == last) return true;
  if (r.ec == std::errc::result_out_of_range && r.ptr == last) {
    // Denormal underflow or overflow: strtod gives the nearest representable value.
    out = std::strtod(std::string(first, last).c_str(), nullptr);
    return true;
  }
  // Spellings of NaN that from_chars does not accept: "-nan(ind)" (MSVC), "1.#QNAN", "1.#IND".
  const std::string_view rest(first, size_t(last - first));
  if (containsIgnoreCase(rest, "nan") || containsIgnoreCase(rest, "#ind")) {
    out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  if (containsIgnoreCase(rest, "#inf")) {
    out = (s[b] == '-') ? -HUGE_VAL : HUGE_VAL;
    return true;
  }
  return false;
}

void splitKeepEmpty(std::string_view line, char sep, std::vector<std::string_view>& out) {
  out.clear();
  size_t start = 0;
  for (size_t i = 0; i < line.size(); ++i) {
    if (line[i] == sep) {
      out.push_back(line.substr(start, i - start));
      start = i + 1;
    }
  }
  out.push_back(line.substr(start));
}

void splitBlanks(std::string_view line, std::vector<std::string_view>& out) {
  out.clear();
  size_t i = 0;
  const size_t n = line.size();
  while (i < n) {
    while (i < n && (line[i] == ' ' || line[i] == '\t')) ++i;
    size_t j = i;
    while (j < n && line[j] != ' ' && line[j] != '\t') ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
}

bool LineReader::next(std::string_view& line) {
  if (pos_ >= text_.size()) return false;
  const size_t start = pos_;
  size_t i = start;
  while (i < text_.size() && text_[i] != '\n' && text_[i] != '\r') ++i;
  line = text_.substr(start, i - start);
  if (i < text_.size()) {
    if (text_[i] == '\r' && i + 1 < text_.size() && text_[i + 1] == '\n') ++i;
    ++i;
  }
  pos_ = i;
  ++line_no_;
  return true;
}

double findLengthUnitScale(std::string_view unit) {
  const std::string u = toLower(trim(unit));
  if (u == "mm" || u == "millimeter" || u == "millimeters" || u == "millimetre" || u == "millimetres") return 1e-3;
  if (u == "cm" || u == "centimeter" || u == "centimeters" || u == "centimetre" || u == "centimetres") return 1e-2;
  if (u == "m" || u == "meter" || u == "meters" || u == "metre" || u == "metres") return 1.0;
  return 0.0;
}

void appendNumber(std::string& out, double v, int digits) {
  if (std::isnan(v)) {
    out += "NaN";
    return;
  }
  char buf[64];
  const int n = std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  out.append(buf, size_t(n));
}

std::string quoteForMessage(std::string_view s) {
  std::string t(trim(s));
  if (t.size() > 40) t = t.substr(0, 37) + "...";
  return "'" + t + "'";
}

}  // namespace kneesim::io::detail
