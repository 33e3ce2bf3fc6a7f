#pragma once
// Paths to test data: the repository's data/ (or the folder CMake's KNEESIM_DATA_DIR names, with the
// same layout) and the fixtures beside the tests. A test that needs a data file never skips: a
// missing file fails it with a message naming the file (KNEESIM_REQUIRE_DATA).

#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <string>

namespace kneesim::test {

/// Path of @p rel under the data folder KNEESIM_DATA_DIR (kgc4-jw/..., opensim-ik-tests/...,
/// opensim-dynamics-tests/...); by default the repository's data/.
inline std::string dataPath(const std::string& rel) { return std::string(KNEESIM_DATA_DIR) + "/" + rel; }
/// Path of @p rel under the current test folder (fixtures beside the tests).
inline std::string fixturePath(const std::string& rel) { return std::string(KNEESIM_TEST_DIR) + "/" + rel; }
/// Path of @p rel under the repository root.
inline std::string sourcePath(const std::string& rel) { return std::string(KNEESIM_SOURCE_DIR) + "/" + rel; }
/// Path of @p rel under the repository's own data/, which the setup files of models/ and share/ name
/// relative to themselves whatever KNEESIM_DATA_DIR is.
inline std::string bundledDataPath(const std::string& rel) { return sourcePath("data/" + rel); }
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

/// Fails the current test (and returns from it) when the data file @p path is missing: tests that
/// need data run on the bundled data and never skip.
#define KNEESIM_REQUIRE_FILE_(path)                                                                  \
  do {                                                                                                \
    if (const std::string kneesim_required_ = (path); !std::filesystem::exists(kneesim_required_))   \
      GTEST_FAIL() << "missing test data file " << kneesim_required_                                  \
                   << " (data/ of the repository, or -DKNEESIM_DATA_DIR=...: see docs/data.md)";      \
  } while (0)
/// Fails the current test when the data file @p rel is not under KNEESIM_DATA_DIR.
#define KNEESIM_REQUIRE_DATA(rel) KNEESIM_REQUIRE_FILE_(::kneesim::test::dataPath(rel))
/// Fails the current test when the data file @p rel is not in the repository's data/ (read by the
/// setup files of models/ and share/).
#define KNEESIM_REQUIRE_BUNDLED_DATA(rel) KNEESIM_REQUIRE_FILE_(::kneesim::test::bundledDataPath(rel))
