#pragma once
// The message of a user-input error, for tests that check what a bad input is told.

#include <gtest/gtest.h>

#include <exception>
#include <functional>
#include <string>

#include "core/error.hpp"

namespace kneesim::test {

/// The message of the InputError that fn throws, checked to be one line; fails the calling test
/// (and returns "") if fn throws something else or nothing.
inline std::string inputErrorOf(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "InputError must be one line: " << msg;
    return msg;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected InputError, got another exception: " << e.what();
    return {};
  }
  ADD_FAILURE() << "expected InputError, nothing was thrown";
  return {};
}

}  // namespace kneesim::test
