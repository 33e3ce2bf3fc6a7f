#include "gap/tool.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "core/strings.hpp"
#include "gap/jw_sources.hpp"

namespace kneesim::gap {
namespace {

using ::testing::HasSubstr;

std::string writeSetup(const std::string& dir, const std::string& body) {
  const std::string path = dir + "/gap.xml";
  std::ofstream(path) << body;
  return path;
}

TEST(GapTool, ReadsTheSetupWithPathsRelativeToIt) {
  const std::string dir = ::kneesim::test::scratchDir("gap_tool_read");
  const std::string path = writeSetup(dir, R"(<GapTool name="demo">
  <plugins>hertz gap_effects</plugins>
  <law>hertz</law>
  <free_parameters>E nu</free_parameters>
  <assumed_values>nu 0.45</assumed_values>
  <effects>time_delay rate</effects>
  <targets>total medial</targets>
  <body_mass>66.7</body_mass>
  <cv_folds>5</cv_folds>
  <alpha>0.01</alpha>
  <trials>
    <Trial name="walk" activity="gait">
      <knee_forces>data/walk.csv</knee_forces>
      <contact_area>areas/walk.sto</contact_area>
      <time_range>1 3</time_range>
      <gon_calibration>40 -210</gon_calibration>
    </Trial>
  </trials>
</GapTool>)");
  GapSetup s = readGapSetup(path);
  EXPECT_EQ(s.name, "demo");
  EXPECT_EQ(s.results_directory, dir + "/demo_results");
  EXPECT_EQ(s.effects, (std::vector<std::string>{"time_delay", "rate"}));
  EXPECT_EQ(s.options.targets, (std::vector<std::string>{"total", "medial"}));
  EXPECT_EQ(s.options.fit.assumed_values.at("nu"), 0.45);
  EXPECT_EQ(s.options.cv_folds, 5);
  EXPECT_EQ(s.options.alpha, 0.01);
  ASSERT_EQ(s.trials.size(), 1u);
  EXPECT_EQ(s.trials[0].knee_forces, dir + "/data/walk.csv");
  EXPECT_EQ(s.trials[0].time_range.begin, 1.0);
  EXPECT_EQ(s.trials[0].gon_scale, 40.0);
  setContactAreaDirectory(s, "/elsewhere");
  EXPECT_EQ(s.trials[0].contact_area, "/elsewhere/walk.sto");
}

TEST(GapTool, SetupErrorsNameTheFileAndElement) {
  const std::string dir = ::kneesim::test::scratchDir("gap_tool_bad");
  auto expectError = [&](const std::string& body, const std::string& what) {
    try {
      readGapSetup(writeSetup(dir, body));
      FAIL() << what;
    } catch (const InputError& e) {
      EXPECT_THAT(e.what(), HasSubstr(what));
      EXPECT_THAT(e.what(), HasSubstr("gap.xml:"));
    }
  };
  expectError("<GapTool><lawz>hertz</lawz><trials/></GapTool>", "unknown element <lawz> in GapTool");
  expectError("<GapTool><trials/></GapTool>", "expected at least one <Trial>, got none");
  expectError("<GapTool><alpha>2</alpha><trials/></GapTool>", "expected a value in (0, 1), got 2");
  expectError("<GapTool><assumed_values>nu</assumed_values><trials/></GapTool>", "expected pairs of a parameter name");
  expectError("<GapTool><trials><Trial name='a'><knee_forces>x.csv</knee_forces></Trial></trials></GapTool>",
              "missing <contact_area>");
  expectError("<IKTool/>", "expected a <GapTool> element, got <IKTool>");
}

// The whole tool on JW's gait and stair trials with INTERIM areas: every output file, the interim
// warning in both reports, and a verdict per target.
TEST(GapTool, RunsEndToEndAndWritesTheReport) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  const std::string dir = ::kneesim::test::scratchDir("gap_tool_run");
  GapSetup s;
  s.setup_file = "(test)";
  s.results_directory = dir + "/out";
  s.trials = {test::interimSource("ngait_og3", "gait", true, dir), test::interimSource("stairupf1", "stair", true, dir)};
  s.options.fit.free_parameters = {"E", "nu"};
  s.options.fit.assumed_values = {{"nu", 0.45}};
  s.options.fit.confidence.bootstrap_samples = 20;
  s.options.fit.body_mass = 66.7;
  s.options.targets = {"total", "medial"};
  s.options.max_effects = 1;
  s.options.screen_top = 2;
  const GapRunResult r = runGap(s);
  for (const std::string f : {"gap_report.json", "gap_report.md", "total_series.dat", "total_bands.gp",
                              "medial_ranking.dat"})
    EXPECT_TRUE(std::filesystem::exists(dir + "/out/" + f)) << f;
  if (std::system("gnuplot --version > /dev/null 2>&1") == 0) {
    for (const std::string f : {"total_bands.png", "total_fits.png", "total_ranking.png", "medial_bands.png"})
      EXPECT_GT(std::filesystem::file_size(dir + "/out/" + f), 1000u) << f;
  }
  const auto j = nlohmann::json::parse(readFileText(dir + "/out/gap_report.json"));
  EXPECT_TRUE(j["interim_inputs"].get<bool>());
  EXPECT_THAT(j["warning"].get<std::string>(), HasSubstr("INTERIM"));
  ASSERT_EQ(j["targets"].size(), 2u);
  EXPECT_FALSE(j["targets"][0]["verdict"].get<std::string>().empty());
  EXPECT_EQ(j["anchors"]["jw_body_mass_kg"].get<double>(), 66.7);
  EXPECT_EQ(j["targets"][0]["baseline"]["parameters"][1]["status"].get<std::string>(), "fixed: not identifiable");
  const std::string md = readFileText(dir + "/out/gap_report.md");
  EXPECT_THAT(md, HasSubstr("INTERIM INPUTS - NOT A REAL-DATA RESULT"));
  EXPECT_THAT(md, HasSubstr("winners' RMS errors 229-326 N per compartment"));
  EXPECT_EQ(r.report.targets.size(), 2u);
}

}  // namespace
}  // namespace kneesim::gap
