// The batch summary: one CSV row per trial with its figures or its error; finished, failed and
// not-run trials counted in the printed table.
#include "tool/batch_summary.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "core/strings.hpp"
#include "support/test_data.hpp"

namespace kneesim::tool {
namespace {

TEST(BatchSummary, OneRowPerTrialWithItsFiguresOrItsError) {
  const std::string dir = test::scratchDir("batch_summary");
  std::ofstream(dir + "/m.osim") << "";
  std::ofstream(dir + "/a.trc") << "";
  std::ofstream(dir + "/m.csv") << "subject,trial,activity,tools,model,markers\n"
                                << "jw,walk,gait,ik,m.osim,a.trc\njw,stairs,\"stairs, up\",ik,m.osim,a.trc\n"
                                << "jw,chair,chair,ik,m.osim,a.trc\n";
  const auto plans = planBatch(readManifest(dir + "/m.csv"), dir + "/out");
  writeTrialSetups(plans[0]);
  std::ofstream(plans[0].summary_file)
      << R"({"ik": {"frames": 291, "marker_rms_mean_mm": 5.324, "marker_error_max_mm": 37.9},
            "contact_area": {"peak_mm2": 2741.64, "peak_time_s": 1.99},
            "force": {"window": "stance", "rmse_N": 383.375, "rmse_bw": 0.586, "r2": 0.137, "peak_measured_N": 1600.5,
                      "whole_trial_rmse_N": 483.4, "law": {"K": 2504309.75, "K_over_R": 67684047.4}}})";
  const std::vector<TrialOutcome> outcomes = {{TrialOutcome::Status::done, "", 4.25},
                                              {TrialOutcome::Status::failed, "error: jw_stairs.c3d: truncated, \"header\"", 0.5},
                                              {}};
  const auto rows = collectBatchSummary(plans, outcomes);
  writeBatchSummaryCsv(dir + "/summary.csv", rows);
  EXPECT_EQ(readFileText(dir + "/summary.csv"),
            "subject,trial,activity,status,seconds,ik_frames,marker_rms_mm,marker_max_mm,contact_peak_mm2,"
            "contact_peak_time_s,force_window,force_rmse_N,force_rmse_bw,force_r2,force_peak_measured_N,"
            "force_trial_rmse_N,law,error\n"
            "jw,walk,gait,done,4.250,291,5.324,37.9,2741.64,1.99,stance,383.375,0.586,0.137,1600.5,483.4,"
            "K=2504309.75;K_over_R=67684047.4,\n"
            "jw,stairs,\"stairs, up\",failed,0.500,,,,,,,,,,,,,\"error: jw_stairs.c3d: truncated, \"\"header\"\"\"\n"
            "jw,chair,chair,not-run,,,,,,,,,,,,,,\n");
  std::ostringstream os;
  printBatchSummary(rows, os);
  const std::string text = os.str();
  EXPECT_NE(text.find("jw           walk           done              4.2       5.32         2742        383.4     0.137"),
            std::string::npos) << text;
  EXPECT_NE(text.find("1 of 3 trials finished, 1 failed, 1 not run\n"), std::string::npos) << text;
  EXPECT_NE(text.find("  jw/stairs: error: jw_stairs.c3d: truncated"), std::string::npos) << text;
}

TEST(BatchSummary, AFinishedTrialWithoutItsSummarySaysSo) {
  const std::string dir = test::scratchDir("batch_summary_missing");
  std::ofstream(dir + "/m.osim") << "";
  std::ofstream(dir + "/a.trc") << "";
  std::ofstream(dir + "/m.csv") << "subject,trial,tools,model,markers\njw,walk,ik,m.osim,a.trc\n";
  const auto plans = planBatch(readManifest(dir + "/m.csv"), dir + "/out");
  const auto rows = collectBatchSummary(plans, {{TrialOutcome::Status::done_earlier, "", 1.0}});
  EXPECT_EQ(rows[0].outcome.message, plans[0].summary_file + ": cannot open file: No such file or directory");
}

}  // namespace
}  // namespace kneesim::tool
