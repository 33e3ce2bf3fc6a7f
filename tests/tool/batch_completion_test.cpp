// Completion markers: a trial counts as finished only while its marker names the current setup
// hash and every output it lists is unchanged.
#include "tool/batch_completion.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/strings.hpp"
#include "support/test_data.hpp"

namespace kneesim::tool {
namespace {

namespace fs = std::filesystem;

struct Finished {
  std::string dir, marker, out_a, out_b;
};

Finished finishTrial(const std::string& name) {
  Finished f;
  f.dir = test::scratchDir(name);
  f.marker = f.dir + "/t.done";
  f.out_a = f.dir + "/t_ik.mot";
  f.out_b = f.dir + "/sub/t_area.sto";
  fs::create_directories(f.dir + "/sub");
  std::ofstream(f.out_a) << "motion\n1 2 3\n";
  std::ofstream(f.out_b) << "area\n";
  writeCompletionMarker(f.marker, "0123456789abcdef", {f.out_a, f.out_b}, 2.5);
  return f;
}

TEST(BatchCompletion, AFinishedTrialCountsAsFinished) {
  const Finished f = finishTrial("completion_ok");
  std::string why = "unchanged";
  EXPECT_TRUE(isTrialComplete(f.marker, "0123456789abcdef", &why));
  EXPECT_EQ(why, "unchanged");
  EXPECT_DOUBLE_EQ(readCompletionSeconds(f.marker), 2.5);
  const std::string text = readFileText(f.marker);
  EXPECT_NE(text.find("\"file\": \"sub/t_area.sto\""), std::string::npos) << "outputs relative to the marker:\n" << text;
  EXPECT_NE(text.find("\"bytes\": 13"), std::string::npos) << text;
}

TEST(BatchCompletion, NoMarkerAnotherSetupOrADamagedOutputIsNotFinished) {
  const Finished f = finishTrial("completion_not");
  std::string why;
  EXPECT_FALSE(isTrialComplete(f.marker, "fedcba9876543210", &why));
  EXPECT_EQ(why, "its setup files changed since it finished");
  EXPECT_FALSE(isTrialComplete(f.dir + "/other.done", "0123456789abcdef", &why));
  EXPECT_EQ(why, "no completion marker");
  EXPECT_TRUE(std::isnan(readCompletionSeconds(f.dir + "/other.done")));

  std::ofstream(f.out_a) << "motion\n1 2 4\n";  // same size, other contents
  EXPECT_FALSE(isTrialComplete(f.marker, "0123456789abcdef", &why));
  EXPECT_EQ(why, "output " + f.out_a + " changed since it finished");
  std::ofstream(f.out_a) << "motion\n1 2 3\n";
  EXPECT_TRUE(isTrialComplete(f.marker, "0123456789abcdef"));
  fs::remove(f.out_b);
  EXPECT_FALSE(isTrialComplete(f.marker, "0123456789abcdef", &why));
  EXPECT_EQ(why, "output " + f.out_b + " is missing");

  std::ofstream(f.marker) << "{\"setup_hash\": \"0123";  // not JSON: as if edited by hand
  EXPECT_FALSE(isTrialComplete(f.marker, "0123456789abcdef", &why));
  EXPECT_EQ(why, "no completion marker");
}

}  // namespace
}  // namespace kneesim::tool
