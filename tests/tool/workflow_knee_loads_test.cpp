// The knee's net loads of a workflow trial beside the measured forces: correlations and the time
// shift on series whose relation is known by construction; the setup's bad inputs.
#include "tool/workflow_knee_loads.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim::tool {
namespace {

namespace fs = std::filesystem;

const KneeLoadAgreement& find(const TrialKneeLoads& k, const std::string& load, const std::string& measured) {
  for (const auto& a : k.agreement)
    if (a.load == load && a.measured == measured) return a;
  throw std::runtime_error("no " + load + " vs " + measured);
}

// 120 Hz; the load a smooth pulse train. The measured total is 2 x the load 25 ms (3 frames) later
// plus 100 N, the medial force minus the load, the lateral force a load of its own inside a window.
TEST(WorkflowKneeLoads, CorrelationsAndTheShiftOfTheMeasuredForce) {
  const double dt = 1.0 / 120;
  const auto load = [](double t) { return 400 * std::pow(std::sin(2.1 * t), 2) + 50 * std::sin(7.3 * t); };
  TrialKneeLoads k;
  k.table.labels = {"time", "knee_axial_force"};
  const int rows = 400;
  k.table.data.resize(rows, 2);
  for (int i = 0; i < rows; ++i) k.table.data.row(i) << i * dt, load(i * dt);
  std::vector<double> time;
  io::KneeForces f;
  for (int i = 40; i < 360; ++i) {  // the workflow's frames: inside the table's
    const double t = i * dt;
    time.push_back(t);
    f.total.push_back(100 + 2 * load(t - 3 * dt));
    f.medial.push_back(-load(t));
    f.lateral.push_back(i >= 180 && i <= 300 ? load(t) : std::cos(11 * t));  // 1.5-2.5 s
  }
  compareKneeLoads(k, time, f, 1.5, 2.5, 0.1);
  ASSERT_EQ(k.at_frames.size(), 1u);
  EXPECT_EQ(k.at_frames[0].first, "knee_axial_force");
  EXPECT_NEAR(k.at_frames[0].second[10], load(50 * dt), 1e-9);
  ASSERT_EQ(k.agreement.size(), 3u);
  const KneeLoadAgreement& total = find(k, "knee_axial_force", "total");
  EXPECT_LT(total.r_trial, 0.999);                  // 3 frames apart
  EXPECT_NEAR(total.lag, 3 * dt, 1e-9);             // the measured force follows 25 ms later
  EXPECT_NEAR(total.r_at_lag, 1.0, 1e-12);
  const KneeLoadAgreement& medial = find(k, "knee_axial_force", "medial");
  EXPECT_NEAR(medial.r_trial, -1.0, 1e-12);
  EXPECT_NEAR(medial.lag, 0.0, 1e-12);
  EXPECT_NEAR(medial.r_at_lag, -1.0, 1e-12);  // the largest |r| keeps its sign
  const KneeLoadAgreement& lateral = find(k, "knee_axial_force", "lateral");
  EXPECT_NEAR(lateral.r_window, 1.0, 1e-12);  // the window's frames only
  EXPECT_LT(lateral.r_trial, 0.9);
  const nlohmann::json j = toJson(k, false);
  EXPECT_FALSE(j.contains("seconds"));
  EXPECT_EQ(j["agreement"].size(), 3u);
  EXPECT_NEAR(j["agreement"][0]["best_lag_s"].get<double>(), 3 * dt, 1e-9);
}

TEST(WorkflowKneeLoads, BadSetupsAreOneLineErrors) {
  const std::string dir = test::scratchDir("workflow_knee_loads_bad");
  AtomicFileSet stage;
  std::vector<std::string> notes;
  const SourceLocation where{"workflow.xml", 12, "Trial"};
  const io::Storage motion;
  EXPECT_EQ(test::inputErrorOf([&] {
              runTrialKneeLoads(dir + "/none.xml", motion, "m.mot", "t", dir, where, stage, notes);
            }),
            "workflow.xml:12: Trial: inverse dynamics setup file not found: " + dir + "/none.xml");
  // OpenSim's own setup has no <KneeLoads>: nothing to compare with the measured forces.
  const std::string setup = test::dataPath("opensim-dynamics-tests/id/subject01_Setup_InverseDynamics.xml");
  ASSERT_TRUE(fs::exists(setup));
  EXPECT_THAT(test::inputErrorOf([&] { runTrialKneeLoads(setup, motion, "m.mot", "t", dir, where, stage, notes); }),
              testing::HasSubstr("subject01_Setup_InverseDynamics.xml:3: OpenSimDocument/InverseDynamicsTool[subject01]: expected <KneeLoads>"));
  EXPECT_TRUE(stage.getPaths().empty());
}

}  // namespace
}  // namespace kneesim::tool
