#include "core/error.hpp"

namespace kneesim {

std::string formatLocated(const SourceLocation& where, const std::string& message) {
  std::string out;
  if (!where.file.empty()) {
    out += where.file;
    if (where.line > 0) out += ":" + std::to_string(where.line);
    out += ": ";
  }
  if (!where.element.empty()) out += where.element + ": ";
  out += message;
  // One line, always: multi-line messages from libraries are folded.
  for (char& c : out)
    if (c == '\n' || c == '\r') c = ' ';
  return out;
}

InputError::InputError(SourceLocation where, const std::string& message)
    : std::runtime_error(formatLocated(where, message)), where_(std::move(where)), message_(message) {}

void failCheck(const char* expr, const char* file, int line, const std::string& msg) {
  throw InternalError(std::string("internal check failed: ") + expr + " at " + file + ":" +
                      std::to_string(line) + ": " + msg);
}

}  // namespace kneesim
