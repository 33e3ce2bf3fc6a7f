// <BatchTrial>: runs a trial's setups in order, writes its summary and completion marker last, and
// on failure a one-line failure note instead. With JW's data: one trial through IK, contact area
// and the workflow, its figures checked against the output files and the stored IK result.
#include "tool/batch_trial.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "core/strings.hpp"
#include "io/storage.hpp"
#include "support/input_error.hpp"
#include "support/test_data.hpp"
#include "tool/batch_completion.hpp"
#include "tool/batch_plan.hpp"

namespace kneesim::tool {
namespace {

namespace fs = std::filesystem;

std::string writeText(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

TEST(BatchTrial, BadSetupsAreOneLineErrors) {
  const std::string dir = test::scratchDir("batch_trial_setup");
  const auto error = [&](const std::string& xml) {
    const std::string path = writeText(dir + "/t_batch.xml", xml);
    return test::inputErrorOf([&] { readBatchTrialSetup(path); });
  };
  const std::string f = dir + "/t_batch.xml";
  EXPECT_EQ(error("<BatchTrial><setup_files>a.xml</setup_files></BatchTrial>"),
            f + ":1: BatchTrial: expected a name=\"...\" attribute (the prefix of the trial's files), got none");
  EXPECT_EQ(error("<BatchTrial name=\"t\"><setup_files>a.xml</setup_files></BatchTrial>"),
            f + ":1: BatchTrial[t]/setup_files: setup file not found: " + dir + "/a.xml");
  EXPECT_EQ(error("<BatchTrial name=\"t\"><setup_files/></BatchTrial>"),
            f + ":1: BatchTrial[t]/setup_files: expected at least one setup file, got none");
  EXPECT_EQ(error("<BatchTrial name=\"t\"><steps/></BatchTrial>"),
            f + ":1: BatchTrial[t]/steps: unknown element <steps> in <BatchTrial> (expected one of activity, "
                "setup_files, subject, trial)");
}

// Found by fuzzing (fuzz/, docs/fuzzing.md): a setup file whose name is longer than the system
// allows made std::filesystem throw a filesystem_error ("File name too long") out of the reader
// instead of the one-line "not found". The reproducer is the fuzzer's input.
TEST(BatchTrialFuzz, ASetupFileNameTooLongIsNotFound) {
  const std::string path = test::fixturePath("fixtures/fuzz/batch_trial/setup-file-name-too-long.xml");
  const std::string msg = test::inputErrorOf([&] { readBatchTrialSetup(path); });
  EXPECT_EQ(msg.rfind(path + ":1: ", 0), 0u) << msg;
  EXPECT_NE(msg.find("/setup_files: setup file not found: " + test::fixturePath("fixtures/fuzz/batch_trial/inpzzz")),
            std::string::npos)
      << msg;
}

TEST(BatchTrial, AFailureLeavesANoteAndNoMarker) {
  const std::string dir = test::scratchDir("batch_trial_fail");
  writeText(dir + "/t_ik.xml",
            "<InverseKinematicsTool name=\"t\"><model_file>m.osim</model_file><marker_file>missing.trc</marker_file>"
            "<output_motion_file>t_ik.mot</output_motion_file></InverseKinematicsTool>");
  writeText(dir + "/t_model.xml", "<KneeModelTool name=\"t\"/>");
  writeText(dir + "/t.done", "{\"setup_hash\": \"stale\"}");
  writeText(dir + "/.t_ik.mot.tmp4242", "half a motion from a killed run");
  writeText(dir + "/t_batch.xml", "<BatchTrial name=\"t\"><setup_files>t_ik.xml</setup_files></BatchTrial>");
  const std::string msg = test::inputErrorOf([&] { runBatchTrial(readBatchTrialSetup(dir + "/t_batch.xml")); });
  EXPECT_NE(msg.find("m.osim"), std::string::npos) << msg;
  EXPECT_EQ(readFileText(dir + "/t.failed"), "error: " + msg + "\n");
  EXPECT_FALSE(fs::exists(dir + "/t.done")) << "a stale marker must not outlive a new run";
  EXPECT_FALSE(fs::exists(dir + "/.t_ik.mot.tmp4242")) << "a killed run's temporary is removed";
  EXPECT_FALSE(fs::exists(dir + "/t_summary.json"));

  writeText(dir + "/t_batch.xml", "<BatchTrial name=\"t\"><setup_files>t_model.xml</setup_files></BatchTrial>");
  EXPECT_EQ(test::inputErrorOf([&] { runBatchTrial(readBatchTrialSetup(dir + "/t_batch.xml")); }),
            dir + "/t_batch.xml: BatchTrial/setup_files: expected InverseKinematicsTool, ContactAreaTool or "
                  "KneeContactWorkflow setups, got a knee-model setup: " + dir + "/t_model.xml");
}

// The largest value of column @p label of a storage file.
double columnMax(const io::Storage& s, const std::string& label) {
  const int c = s.findColumn(label);
  EXPECT_GE(c, 0) << label;
  return c < 0 ? NAN : s.data.col(c).maxCoeff();
}

TEST(BatchTrial, JwGaitTrialThroughEveryTool) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_ngait_og3.c3d");
  const std::string dir = test::scratchDir("batch_trial_jw");
  const std::string models = test::sourcePath("models/jw-knee24/");
  const std::string data = test::dataPath("kgc4-jw/");
  writeText(dir + "/m.csv",
            "subject,trial,activity,tools,model,ik_tasks,markers,knee_forces,femoral_component,insert,femoral_mesh,"
            "insert_mesh,body_mass\n"
            "jw,ngait_og3,gait,ik contact workflow," + models + "jw_knee24.osim," + models + "jw_knee24_ik_tasks.xml," +
                data + "markers/jw_ngait_og3.c3d," + data + "knee-forces/jw_ngait_og3_knee_forces.csv," + data +
                "implant/femoral_component.stl," + data + "implant/tibial_insert.stl,femoral_component,tibial_insert,66.7\n");
  const BatchTrialPlan p = planBatch(readManifest(dir + "/m.csv"), dir + "/out").at(0);
  writeTrialSetups(p);
  const BatchTrialReport r = runBatchTrial(readBatchTrialSetup(p.setup_file));
  EXPECT_EQ(r.tools, (std::vector<std::string>{"ik", "contact-area", "knee-contact-workflow"}));
  EXPECT_TRUE(isTrialComplete(p.completion_file, p.setup_hash));
  EXPECT_FALSE(fs::exists(p.failure_file));
  const std::string f = p.folder + "/jw_ngait_og3";

  // The IK motion is the stored ngait_og3 result (tests/models/reference: the model's own IK setup).
  const io::Storage motion = io::readStorage(f + "_ik.mot");
  const io::Storage ref = io::readStorage(test::sourcePath("tests/models/reference/jw_ngait_og3_ik.sto"));
  ASSERT_EQ(motion.getNumRows(), 291);
  double worst_deg = 0;
  for (size_t c = 1; c < motion.labels.size(); ++c) {
    const std::string& n = motion.labels[c];
    if (n.find("_t") != std::string::npos) continue;  // translations
    const int rc = ref.findColumn(n);
    ASSERT_GE(rc, 0) << n;
    for (int k = 0; k < ref.getNumRows(); ++k) worst_deg = std::max(worst_deg, std::abs(ref.data(k, rc) - motion.data(3 * k, int(c))));
  }
  EXPECT_LT(worst_deg, 0.05) << "the stored test's tolerance";

  // The figures are those of the output files.
  const TrialFigures& fig = r.figures;
  const io::Storage errors = io::readStorage(f + "_ik_marker_errors.sto");
  const int rms = errors.findColumn("marker_error_RMS");
  ASSERT_GE(rms, 0) << join(errors.labels, " ");
  EXPECT_EQ(fig.ik_frames, 291);
  EXPECT_NEAR(fig.marker_rms_mm, 1e3 * errors.data.col(rms).mean(), 1e-6);
  EXPECT_NEAR(fig.marker_rms_mm, 5.32, 0.01) << "README: ngait_og3's whole-trial mean";
  const io::Storage area = io::readStorage(f + "_contact_area.sto");
  EXPECT_NEAR(fig.contact_peak_mm2, 1e6 * columnMax(area, "S"), 0.01) << "the file holds 1e-8 m^2";
  EXPECT_NEAR(fig.contact_peak_mm2, 2742, 1) << "README: JW's peak area with the model's kinematics";
  const io::Storage wf_area = io::readStorage(f + "_workflow/jw_ngait_og3/jw_ngait_og3_contact_area.sto");
  EXPECT_DOUBLE_EQ(columnMax(wf_area, "S"), columnMax(area, "S")) << "the workflow and the contact tool agree";
  const auto summary = nlohmann::json::parse(readFileText(f + "_workflow/summary.json"));
  EXPECT_FALSE(summary.contains("seconds")) << "a batch's workflow writes no timings";
  const auto& t = summary["trials"][0];
  EXPECT_DOUBLE_EQ(fig.force_rmse_n, t["window_metrics"]["rmse_N"].get<double>());
  EXPECT_NEAR(fig.force_rmse_n, 383.4, 0.5) << "README: the paper's Hertz fit on ngait_og3's stance";
  EXPECT_NEAR(fig.force_rmse_bw, fig.force_rmse_n / (66.7 * 9.80665), 1e-3);
  EXPECT_EQ(fig.force_window, "stance");

  // What the summary file says is what the run returned.
  const TrialFigures back = readTrialFigures(p.summary_file);
  EXPECT_DOUBLE_EQ(back.marker_rms_mm, fig.marker_rms_mm);
  EXPECT_DOUBLE_EQ(back.contact_peak_mm2, fig.contact_peak_mm2);
  EXPECT_DOUBLE_EQ(back.force_rmse_n, fig.force_rmse_n);
  EXPECT_DOUBLE_EQ(back.force_r2, fig.force_r2);
  ASSERT_FALSE(back.law.empty());
  EXPECT_EQ(back.law[0].first, "K");
  EXPECT_NEAR(back.law[0].second, 2.50e6, 0.01e6) << "README: K = 2.50 MPa";
}

}  // namespace
}  // namespace kneesim::tool
