#pragma once
// Paths to test data. Real data (../shared/data) may be absent in a fresh clone: tests that need
// it call KNEESIM_REQUIRE_DATA and skip with a message naming the missing file.

#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <string>

namespace kneesim::test {

/// Path of @p rel under the shared data folder (kgc4-jw/..., opensim-ik-tests/...).
inline std::string dataPath(const std::string& rel) { return std::string(KNEESIM_DATA_DIR) + "/" + rel; }
/// Path of @p rel under the current test folder (fixtures beside the tests).
inline std::string fixturePath(const std::string& rel) { return std::string(KNEESIM_TEST_DIR) + "/" + rel; }
/// Path of @p rel under the repository root.
inline std::string sourcePath(const std::string& rel) { return std::string(KNEESIM_SOURCE_DIR) + "/" + rel; }
/// A fresh empty scratch folder for one test. Its name carries a hash of the source folder so
/// that test runs of different checkouts on one machine do not share folders.
inline std::string scratchDir(const std::string& name) {
  namespace fs = std::filesystem;
  const std::string tag = std::to_string(std::hash<std::string>{}(KNEESIM_SOURCE_DIR) % 100000);
  fs::path p = fs::temp_directory_path() / ("kneesim_test_" + tag + "_" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

}  // namespace kneesim::test

/// Skips the current test when the shared data file @p rel is not present.
#define KNEESIM_REQUIRE_DATA(rel)                                                          \
  do {                                                                                     \
    if (!std::filesystem::exists(::kneesim::test::dataPath(rel)))                          \
      GTEST_SKIP() << "real data not available: " << ::kneesim::test::dataPath(rel)        \
                   << " (set -DKNEESIM_DATA_DIR=... to run this test)";                    \
  } while (0)
