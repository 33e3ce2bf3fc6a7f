#pragma once
// The message of a user-input error, for tests that check what a bad input is told.

#include <gtest/gtest.h>

#include <string>

#include "core/error.hpp"

namespace kneesim::test {

/// The message of the InputError that f throws; fails the calling test (and returns "") if f
/// throws none.
template <class F>
std::string inputErrorOf(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError thrown";
  return "";
}

}  // namespace kneesim::test
