#pragma once
// Helpers for the io tests: writing fixture text byte-exactly; checking InputError messages
// (support/input_error.hpp).

#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "support/input_error.hpp"

namespace kneesim::io::test_util {

/// Writes @p bytes to @p path exactly (binary, so CR and CRLF line ends survive).
inline void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), std::streamsize(bytes.size()));
}

/// Reads a whole file as bytes.
inline std::string readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

using kneesim::test::inputErrorOf;

/// Replaces every "\n" in @p text by @p eol.
inline std::string withLineEnds(const std::string& text, const std::string& eol) {
  std::string out;
  for (char c : text) {
    if (c == '\n')
      out += eol;
    else
      out += c;
  }
  return out;
}

}  // namespace kneesim::io::test_util
