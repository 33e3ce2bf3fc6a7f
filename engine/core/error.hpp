#pragma once
// Errors for user input (tier 3 of the error model, see DEVELOPERS.md).
//
// Every problem with a user's file becomes an InputError whose what() is a single line:
//   "<file>:<line>: <element path>: <message>"
// with the parts that are unknown left out. Messages say "expected X, got Y" where they can.
// Internal invariants use KNEESIM_CHECK (always on) and KNEESIM_ASSERT (debug builds only).

#include <cassert>
#include <stdexcept>
#include <string>

namespace kneesim {

/// Where in a user's input something was found. Any field may be empty/zero when unknown.
struct SourceLocation {
  std::string file;     ///< Path of the file as the user named it.
  int line = 0;         ///< 1-based line number, 0 when unknown.
  std::string element;  ///< Element path such as "Model/BodySet/objects/Body[femur]/mass".
};

/// An error in user input: a missing or malformed file, an unknown element, a bad value.
class InputError : public std::runtime_error {
 public:
  /// Creates an error for @p where with the message @p message.
  InputError(SourceLocation where, const std::string& message);

  /// The location the error refers to.
  const SourceLocation& getLocation() const { return where_; }
  /// The message without the location prefix.
  const std::string& getMessage() const { return message_; }

 private:
  SourceLocation where_;
  std::string message_;
};

/// Formats "<file>:<line>: <element>: <message>" leaving out unknown parts.
std::string formatLocated(const SourceLocation& where, const std::string& message);

/// Thrown when an always-on internal check fails: a bug in kneesim, not in the user's input.
class InternalError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

[[noreturn]] void failCheck(const char* expr, const char* file, int line, const std::string& msg);

}  // namespace kneesim

/// Always-on invariant check (tier 2). Throws kneesim::InternalError.
#define KNEESIM_CHECK(cond, msg)                                        \
  do {                                                                  \
    if (!(cond)) ::kneesim::failCheck(#cond, __FILE__, __LINE__, (msg)); \
  } while (0)

/// Debug-only assertion of an internal assumption (tier 1).
#define KNEESIM_ASSERT(cond) assert(cond)
