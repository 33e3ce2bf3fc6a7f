// The setup files a batch writes for a trial are read back by the tools' own readers and say what
// the manifest row said; outputs land in the trial's folder under the trial's name.
#include "tool/batch_setups.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "ik/tool.hpp"
#include "support/test_data.hpp"
#include "tool/batch_trial.hpp"
#include "tool/contact_area_tool.hpp"
#include "tool/knee_contact_workflow.hpp"

namespace kneesim::tool {
namespace {

namespace fs = std::filesystem;

// A planned trial with every tool, its setups written, and a stand-in for the IK motion.
BatchTrialPlan planOneTrial(const std::string& dir, const std::string& extra_columns, const std::string& extra_cells) {
  const std::string tasks =
      "<IKTaskSet><objects><IKMarkerTask name=\"F1\"><weight>2</weight></IKMarkerTask></objects></IKTaskSet>";
  std::ofstream(dir + "/tasks.xml") << tasks;
  for (const char* f : {"m.osim", "a.c3d", "f.stl", "i.stl", "forces.csv"}) std::ofstream(dir + "/" + f) << "";
  std::ofstream(dir + "/m.csv") << "subject,trial,tools,model,markers,ik_tasks,femoral_component,insert,knee_forces,"
                                   "activity,femoral_mesh,body_mass" + extra_columns + "\n"
                                << "jw,walk.1,workflow ik contact,m.osim,a.c3d,tasks.xml,f.stl,i.stl,forces.csv,"
                                   "chair,fc,66.7" + extra_cells + "\n";
  auto plans = planBatch(readManifest(dir + "/m.csv"), dir + "/out");
  writeTrialSetups(plans.at(0));
  std::ofstream(plans[0].folder + "/jw_walk.1_ik.mot") << "";
  return plans[0];
}

TEST(BatchSetups, TheToolsReadTheirSetupsAsTheRowSays) {
  const std::string dir = test::scratchDir("batch_setups");
  const BatchTrialPlan p = planOneTrial(dir, ",time_range,accuracy,marker_rotation,threshold,insert_body",
                                        ",0.5 2.25,1e-4,-90 0 0,0.002,tray");
  const std::string f = p.folder + "/";

  const ik::IkSetup ik = ik::readIkSetup(f + "jw_walk.1_ik.xml");
  EXPECT_EQ(ik.name, "jw_walk.1");
  EXPECT_EQ(ik.model_file, dir + "/m.osim");
  EXPECT_EQ(ik.marker_file, dir + "/a.c3d");
  EXPECT_EQ(ik.output_motion_file, f + "jw_walk.1_ik.mot");
  EXPECT_EQ(ik.results_directory, f) << "\".\": the setup's own folder";
  EXPECT_DOUBLE_EQ(ik.time_start, 0.5);
  EXPECT_DOUBLE_EQ(ik.time_end, 2.25);
  EXPECT_DOUBLE_EQ(ik.accuracy, 1e-4);
  EXPECT_DOUBLE_EQ(ik.marker_rotation_deg.x(), -90);
  ASSERT_EQ(ik.tasks.size(), 1u);
  EXPECT_DOUBLE_EQ(ik.tasks[0].weight, 2);
  EXPECT_TRUE(ik.report_errors);

  const ContactAreaSetup c = readContactAreaSetup(f + "jw_walk.1_contact.xml");
  EXPECT_EQ(c.name, "jw_walk.1");
  EXPECT_EQ(c.femur_file, dir + "/f.stl");
  EXPECT_EQ(c.insert_file, dir + "/i.stl");
  EXPECT_DOUBLE_EQ(c.options.threshold, 0.002);
  EXPECT_TRUE(c.use_model);
  EXPECT_EQ(c.model.motion_file, f + "jw_walk.1_ik.mot") << "contact reads this trial's IK motion";
  EXPECT_EQ(c.model.femoral_body, "femoral_component");
  EXPECT_EQ(c.model.insert_body, "tray");
  EXPECT_EQ(c.model.femoral_mesh, "fc");
  EXPECT_EQ(c.model.insert_mesh, "");
  EXPECT_EQ(c.results_directory, f);

  const WorkflowSetup w = readWorkflowSetup(f + "jw_walk.1_workflow.xml");
  EXPECT_EQ(w.name, "jw_walk.1");
  EXPECT_DOUBLE_EQ(w.body_mass, 66.7);
  EXPECT_EQ(w.results_directory, f + "jw_walk.1_workflow");
  EXPECT_FALSE(w.timings) << "two runs must write the same bytes";
  EXPECT_FALSE(w.plots);
  EXPECT_EQ(w.threads, 1);
  EXPECT_EQ(w.law, "hertz");
  ASSERT_EQ(w.trials.size(), 1u);
  EXPECT_TRUE(w.trials[0].fit);
  EXPECT_EQ(w.trials[0].source, WorkflowTrialSpec::Source::motion);
  EXPECT_EQ(w.trials[0].motion_file, f + "jw_walk.1_ik.mot");
  EXPECT_EQ(w.trials[0].c3d_file, dir + "/a.c3d");
  EXPECT_EQ(w.trials[0].knee_forces_file, dir + "/forces.csv");
  EXPECT_EQ(w.trials[0].window, "trial") << "a chair rise has no stance: the whole trial";

  const BatchTrialSetup b = readBatchTrialSetup(p.setup_file);
  EXPECT_EQ(b.name, "jw_walk.1");
  EXPECT_EQ(b.subject, "jw");
  EXPECT_EQ(b.trial, "walk.1");
  EXPECT_EQ(b.activity, "chair");
  EXPECT_EQ(b.setup_files, (std::vector<std::string>{f + "jw_walk.1_ik.xml", f + "jw_walk.1_contact.xml",
                                                      f + "jw_walk.1_workflow.xml"}));
  EXPECT_EQ(b.completion_file, f + "jw_walk.1.done");
}

TEST(BatchSetups, SetupsNameInputsAbsolutelyAndOutputsRelatively) {
  // So that a trial run from its folder writes the same bytes wherever the output tree lies.
  const std::string dir = test::scratchDir("batch_setups_paths");
  const BatchTrialPlan p = planOneTrial(dir, "", "");
  for (const auto& [path, contents] : p.setup_files) {
    EXPECT_EQ(contents.find(p.folder), std::string::npos) << path << " names its own folder:\n" << contents;
    if (path != p.setup_file) {
      EXPECT_NE(contents.find(dir + "/m.osim"), std::string::npos) << path;
    }
  }
}

}  // namespace
}  // namespace kneesim::tool
