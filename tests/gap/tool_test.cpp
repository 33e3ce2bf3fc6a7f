#include "gap/tool.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "core/strings.hpp"
#include "gap/jw_sources.hpp"
#include "io/storage.hpp"

namespace kneesim::gap {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

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
  <alternative_baselines>knee_muscle_total</alternative_baselines>
  <compared_effects>rate</compared_effects>
  <trials>
    <Trial name="walk" activity="gait">
      <knee_forces>data/walk.csv</knee_forces>
      <contact_area>areas/walk.sto</contact_area>
      <time_range>1 3</time_range>
      <gon_calibration>1.2 -4</gon_calibration>
      <grf_from_knee_forces>2000</grf_from_knee_forces>
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
  EXPECT_EQ(s.options.alternative_baselines, std::vector<std::string>{"knee_muscle_total"});
  EXPECT_EQ(s.options.compared_effects, std::vector<std::string>{"rate"});
  ASSERT_EQ(s.trials.size(), 1u);
  EXPECT_EQ(s.trials[0].knee_forces, dir + "/data/walk.csv");
  EXPECT_EQ(s.trials[0].time_range.begin, 1.0);
  EXPECT_EQ(s.trials[0].goniometer.gain, 1.2);
  EXPECT_EQ(s.trials[0].goniometer.offset_deg, -4.0);
  EXPECT_EQ(s.trials[0].goniometer.volts_gain, io::kJwGoniometerDegreesPerVolt);  // step 1 unchanged
  EXPECT_EQ(s.trials[0].knee_forces_grf_scale, 2000.0);
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
  expectError("<GapTool><prewhiten_order>12</prewhiten_order><trials/></GapTool>",
              "expected -1 (by BIC), 0 (none) or an order up to 10, got 12");
  expectError("<GapTool><prewhiten_order>-2</prewhiten_order><trials/></GapTool>", "expected an integer from -1 to 2147483647, got '-2'");
  expectError("<GapTool><targets>total patellar</targets><trials/></GapTool>",
              "targets: expected total, medial or lateral, got 'patellar'");
  expectError("<GapTool><cv_folds>1</cv_folds><trials/></GapTool>",
              "cv_folds: expected 0 (leave one cycle out) or at least 2 folds, got 1");
  // 2^32 + 2 once wrapped to 2 folds when narrowed to int; it is refused.
  expectError("<GapTool><cv_folds>4294967298</cv_folds><trials/></GapTool>",
              "cv_folds: expected an integer from 0 to 2147483647, got '4294967298'");
  expectError("<GapTool><assumed_values>nu</assumed_values><trials/></GapTool>", "expected pairs of a parameter name");
  expectError("<GapTool><trials><Trial name='a'><knee_forces>x.csv</knee_forces></Trial></trials></GapTool>",
              "missing <contact_area> (the contact-area tool's .sto for this trial) and no <workflow_results>");
  expectError("<GapTool><trials><Trial name='a'><knee_forces>x.csv</knee_forces><contact_area>a.sto</contact_area>"
              "<grf_from_knee_forces>-1</grf_from_knee_forces></Trial></trials></GapTool>",
              "expected newtons per unit of the GRFz column (> 0; JW: 2000), got -1");
  expectError("<IKTool/>", "expected a <GapTool> element, got <IKTool>");
}

// A workflow's results folder: trials without <contact_area> read <dir>/<name>/<name>_contact_area.sto,
// and trials without <knee_loads> the <name>_knee_loads.sto its inverse dynamics wrote, where it did
// (issue 18: `kneesim gap --workflow-results DIR` read the areas only).
TEST(GapTool, ReadsTheWorkflowsResultsFolder) {
  const std::string dir = ::kneesim::test::scratchDir("gap_tool_workflow");
  auto touch = [](const std::string& path) {
    fs::create_directories(fs::path(path).parent_path());
    std::ofstream(path) << "\n";
  };
  touch(dir + "/wf/walk/walk_knee_loads.sto");
  touch(dir + "/run/stairs/stairs_knee_loads.sto");
  touch(dir + "/run/hop/hop_knee_loads.sto");
  GapSetup s = readGapSetup(writeSetup(dir, R"(<GapTool name="demo">
  <workflow_results>wf</workflow_results>
  <trials>
    <Trial name="walk"><knee_forces>walk.csv</knee_forces></Trial>
    <Trial name="stairs" activity="stair"><knee_forces>s.csv</knee_forces><contact_area>own.sto</contact_area></Trial>
    <Trial name="hop"><knee_forces>h.csv</knee_forces><knee_loads>mine.sto</knee_loads></Trial>
  </trials>
</GapTool>)"));
  EXPECT_EQ(s.workflow_results, dir + "/wf");
  EXPECT_EQ(s.trials[0].contact_area, dir + "/wf/walk/walk_contact_area.sto");
  EXPECT_EQ(s.trials[1].contact_area, dir + "/own.sto");
  EXPECT_EQ(s.trials[0].knee_loads, dir + "/wf/walk/walk_knee_loads.sto");
  EXPECT_EQ(s.trials[1].knee_loads, "");  // the workflow wrote none for it
  EXPECT_EQ(s.trials[2].knee_loads, dir + "/mine.sto");
  setWorkflowResults(s, dir + "/run");  // as kneesim gap --workflow-results does
  EXPECT_EQ(s.trials[1].contact_area, dir + "/run/stairs/stairs_contact_area.sto");
  EXPECT_EQ(s.trials[0].knee_loads, "");  // the setup's folder's file no longer applies
  EXPECT_EQ(s.trials[1].knee_loads, dir + "/run/stairs/stairs_knee_loads.sto");
  EXPECT_EQ(s.trials[2].knee_loads, dir + "/mine.sto");  // the setup's own file stays
}

// The whole tool on JW's gait and stair trials with the workflow's real areas (fixtures): every
// output file, no interim or synthetic warning, a verdict per target.
TEST(GapTool, RunsEndToEndAndWritesTheReport) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  const std::string dir = ::kneesim::test::scratchDir("gap_tool_run");
  GapSetup s;
  s.setup_file = "(test)";
  s.results_directory = dir + "/out";
  s.trials = {test::jwSource("ngait_og3", "gait"), test::jwSource("stairupf1", "stair")};
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
  EXPECT_FALSE(j["interim_inputs"].get<bool>());
  ASSERT_EQ(j["targets"].size(), 2u);
  EXPECT_FALSE(j["targets"][0]["verdict"].get<std::string>().empty());
  EXPECT_EQ(j["anchors"]["jw_body_mass_kg"].get<double>(), 66.7);
  EXPECT_EQ(j["targets"][0]["baseline"]["parameters"][1]["status"].get<std::string>(), "fixed: not identifiable");
  // The prewhitening filter (AR order by BIC on the baseline's residuals) and each candidate's
  // prewhitened reduction are reported.
  EXPECT_GE(j["targets"][0]["prewhitening_ar"].size(), 1u);
  EXPECT_LE(j["targets"][0]["prewhitening_ar"].size(), 10u);
  ASSERT_GE(j["targets"][0]["candidates"].size(), 1u);
  EXPECT_TRUE(j["targets"][0]["candidates"][0].contains("prewhitened_relative_mse_reduction"));
  EXPECT_TRUE(j["targets"][0]["candidates"][0].contains("prewhitened_relative_mse_reduction_one_sided_lower"));
  // Both significance tests, and which made the candidate significant.
  const auto& c0 = j["targets"][0]["candidates"][0];
  EXPECT_EQ(c0["significant"].get<bool>(),
            c0["relative_mse_reduction_one_sided_lower"].get<double>() > 0 ||
                c0["cross_fitted_score_t"].get<double>() > c0["cross_fitted_score_critical_t"].get<double>());
  EXPECT_GT(c0["cross_fitted_score_critical_t"].get<double>(), 2);  // a Bonferroni Student t over the screened effects
  EXPECT_TRUE(j["targets"][0].contains("undecided"));  // null when no candidate was left undecided
  const std::string md = readFileText(dir + "/out/gap_report.md");
  EXPECT_THAT(md, ::testing::Not(HasSubstr("INTERIM")));
  EXPECT_THAT(md, HasSubstr("winners' RMS errors 229-326 N per compartment"));
  EXPECT_THAT(md, HasSubstr("Prewhitening filter: AR("));
  EXPECT_THAT(md, HasSubstr("| cross-fitted score t (needed) |"));
  EXPECT_EQ(r.report.targets.size(), 2u);

  // kneesim gap --predict: gap_model.json applied to the trials, one of them without knee forces. The
  // prediction reads no force: the stair trial's is the same with and without its forces; where the
  // forces are there, the selected law fitted on all cycles misses them by less than the baseline's
  // withheld error.
  ASSERT_TRUE(std::filesystem::exists(dir + "/out/gap_model.json"));
  GapSetup ps = s;
  ps.results_directory = dir + "/predicted";
  const PredictRunResult with = runPredict(ps, dir + "/out/gap_model.json");
  ps.trials[1].knee_forces.clear();
  const PredictRunResult without = runPredict(ps, dir + "/out/gap_model.json");
  ASSERT_EQ(without.predictions.size(), 2u);
  EXPECT_EQ(without.model.targets.size(), 2u);
  EXPECT_EQ(without.model.targets[0].effects, r.report.targets[0].selected);
  // Without forces the frames are the contact-area file's, with them the CSV's: compared where both have a frame.
  const TrialPrediction &a = without.predictions[1], &b = with.predictions[1];
  int same = 0;
  for (size_t i = 0, k = 0; i < a.time.size(); ++i) {
    while (k < b.time.size() && b.time[k] < a.time[i] - 1e-6) ++k;
    if (k < b.time.size() && std::abs(b.time[k] - a.time[i]) < 1e-6) {
      EXPECT_NEAR(a.predicted.at("total")[i], b.predicted.at("total")[k], 1e-3) << a.time[i];
      ++same;
    }
  }
  EXPECT_GT(same, 500);
  EXPECT_TRUE(without.predictions[1].rmse.empty());
  EXPECT_LT(without.predictions[0].rmse.at("total"), r.report.targets[0].baseline_rmse_heldout);
  const io::Storage sto = io::readStorage(dir + "/predicted/stairupf1_predicted.sto");
  EXPECT_THAT(sto.labels, ::testing::ElementsAre("time", "cycle_phase", "medial", "total"));
  ASSERT_EQ(sto.data.rows(), static_cast<Eigen::Index>(without.predictions[1].time.size()));
  EXPECT_NEAR(sto.data(10, 3), without.predictions[1].predicted.at("total")[10], 1e-6 * std::abs(sto.data(10, 3)) + 1e-9);
  const io::Storage gait = io::readStorage(dir + "/predicted/ngait_og3_predicted.sto");
  EXPECT_THAT(gait.labels, ::testing::ElementsAre("time", "cycle_phase", "medial", "medial_measured", "total",
                                                  "total_measured"));
}

}  // namespace
}  // namespace kneesim::gap
