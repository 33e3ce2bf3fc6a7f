// planBatch: each manifest row becomes a folder of its own with setup files named after the trial;
// bad rows are refused at their cell; the setup hash follows a row's contents, not its position.
#include "tool/batch_plan.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>

#include "core/strings.hpp"
#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim::tool {
namespace {

namespace fs = std::filesystem;

// A folder with empty stand-ins for the input files (planning only checks that they exist).
std::string makeInputs(const std::string& name) {
  const std::string dir = test::scratchDir(name);
  for (const char* f : {"m.osim", "a.c3d", "b.trc", "tasks.xml", "f.stl", "i.stl", "forces.csv", "walk.mot"})
    std::ofstream(dir + "/" + f) << "";
  return dir;
}

Manifest csv(const std::string& dir, const std::string& text) {
  std::ofstream(dir + "/m.csv") << text;
  return readManifest(dir + "/m.csv");
}

const char* kHeader = "subject,trial,tools,model,markers,ik_tasks,femoral_component,insert,knee_forces,activity\n";

TEST(BatchPlan, EachTrialHasItsFolderAndItsOwnFileNames) {
  const std::string dir = makeInputs("plan_layout");
  const Manifest m = csv(dir, std::string(kHeader) + "s1,walk,ik contact,m.osim,a.c3d,tasks.xml,f.stl,i.stl,,gait\n" +
                                  "s2,walk,workflow;ik,m.osim,b.trc,,f.stl,i.stl,forces.csv,stairs\n");
  const auto plans = planBatch(m, dir + "/out");
  ASSERT_EQ(plans.size(), 2u);
  const BatchTrialPlan& a = plans[0];
  EXPECT_EQ(a.spec.name, "s1_walk");
  EXPECT_EQ(a.folder, dir + "/out/s1/walk");
  EXPECT_EQ(a.setup_file, dir + "/out/s1/walk/s1_walk_batch.xml");
  EXPECT_EQ(a.log_file, dir + "/out/s1/walk/s1_walk.log");
  EXPECT_EQ(a.summary_file, dir + "/out/s1/walk/s1_walk_summary.json");
  EXPECT_EQ(a.completion_file, dir + "/out/s1/walk/s1_walk.done");
  EXPECT_EQ(a.failure_file, dir + "/out/s1/walk/s1_walk.failed");
  ASSERT_EQ(a.setup_files.size(), 3u);
  EXPECT_EQ(a.setup_files[0].first, a.setup_file);
  EXPECT_EQ(a.setup_files[1].first, dir + "/out/s1/walk/s1_walk_ik.xml");
  EXPECT_EQ(a.setup_files[2].first, dir + "/out/s1/walk/s1_walk_contact.xml");
  EXPECT_EQ(a.spec.model, dir + "/m.osim") << "inputs are absolute, resolved against the manifest's folder";
  EXPECT_EQ(a.spec.c3d, dir + "/a.c3d") << "a C3D marker file also gives the gait events";
  EXPECT_EQ(a.spec.window, "stance");
  const BatchTrialPlan& b = plans[1];
  EXPECT_EQ(b.spec.tools, (std::vector<std::string>{"ik", "workflow"})) << "ik runs first whatever the cell's order";
  EXPECT_EQ(b.spec.c3d, "") << "a TRC gives no force plates";
  EXPECT_EQ(b.spec.window, "stance");
  EXPECT_EQ(b.spec.knee_forces, dir + "/forces.csv");
  EXPECT_NE(a.folder, b.folder);
}

TEST(BatchPlan, BadRowsAreRefusedAtTheirCell) {
  const std::string dir = makeInputs("plan_errors");
  const std::string m = dir + "/m.csv";
  const auto error = [&](const std::string& rows) {
    return test::inputErrorOf([&] { planBatch(csv(dir, std::string(kHeader) + rows), dir + "/out"); });
  };
  EXPECT_EQ(error("s1,walk,ik,m.osim,a.c3d,,,,,\ns1,walk,ik,m.osim,b.trc,,,,,\n"),
            m + ":3: row 2: subject s1 has trial walk twice (each trial writes its own folder)");
  EXPECT_EQ(error("s1,walk,ik,m.osim,,,,,,\n"), m + ":2: row 1/markers: expected a marker file for ik, got an empty cell");
  EXPECT_EQ(error("s1,walk,ik+so,m.osim,a.c3d,,,,,\n"),
            m + ":2: row 1/tools: expected tools among ik, contact, workflow, got 'so'");
  EXPECT_EQ(error("s1,walk,ik ik,m.osim,a.c3d,,,,,\n"), m + ":2: row 1/tools: tool 'ik' is named twice");
  EXPECT_EQ(error("s 1,walk,ik,m.osim,a.c3d,,,,,\n"),
            m + ":2: row 1/subject: expected letters, digits, '.', '_' or '-' (it names folders and files), got 's 1'");
  EXPECT_EQ(error("s1,..,ik,m.osim,a.c3d,,,,,\n"), m + ":2: row 1/trial: expected a name not starting with '.', got '..'");
  EXPECT_EQ(error("s1,walk,ik,m.osim,missing.c3d,,,,,\n"), m + ":2: row 1/markers: file not found: " + dir + "/missing.c3d");
  EXPECT_EQ(error("s1,walk,contact,m.osim,a.c3d,,f.stl,i.stl,,\n"),
            m + ":2: row 1/motion: expected a motion for contact/workflow (or ik among the tools), got an empty cell");
  EXPECT_EQ(error("s1,walk,ik workflow,m.osim,a.c3d,,f.stl,i.stl,,\n"),
            m + ":2: row 1/knee_forces: expected measured knee forces for workflow, got an empty cell");
  EXPECT_EQ(error("s1,walk,ik contact,m.osim,a.c3d,,,i.stl,,\n"),
            m + ":2: row 1/femoral_component: expected the femoral component's STL, got an empty cell");
  std::ofstream(m) << "subject,trial,tools,model,markers,time_range,body_mass\ns1,walk,ik,m.osim,a.c3d,0.5,\n";
  EXPECT_EQ(test::inputErrorOf([&] { planBatch(readManifest(m), dir); }),
            m + ":2: row 1/time_range: expected two times 'start end' (s), got '0.5'");
  std::ofstream(m) << "subject,trial,tools,model,markers,time_range\ns1,walk,ik,m.osim,a.c3d,2 1\n";
  EXPECT_EQ(test::inputErrorOf([&] { planBatch(readManifest(m), dir); }),
            m + ":2: row 1/time_range: expected two times 'start end' (s) with start <= end, got '2 1'");
  fs::create_directories(dir + "/trials.c3d");
  std::ofstream(m) << "subject,trial,tools,model,markers\ns1,walk,ik,m.osim,trials.c3d\n";
  EXPECT_EQ(test::inputErrorOf([&] { planBatch(readManifest(m), dir); }),
            m + ":2: row 1/markers: expected a file, got a folder: " + dir + "/trials.c3d");
  std::ofstream(m) << "subject,trial,tools,model,markers,body_mass\ns1,walk,ik,m.osim,a.c3d,-60\n";
  EXPECT_EQ(test::inputErrorOf([&] { planBatch(readManifest(m), dir); }),
            m + ":2: row 1/body_mass: expected a body mass (kg) > 0, got '-60'");
}

TEST(BatchPlan, TheSetupHashFollowsARowsContentsNotItsPosition) {
  const std::string dir = makeInputs("plan_hash");
  const std::string r1 = "s1,walk,ik,m.osim,a.c3d,,,,,gait\n", r2 = "s2,walk,ik,m.osim,a.c3d,,,,,gait\n";
  const auto p = planBatch(csv(dir, kHeader + r1 + r2), dir + "/out");
  const auto swapped = planBatch(csv(dir, kHeader + r2 + r1), dir + "/out");
  EXPECT_EQ(p[0].setup_hash, swapped[1].setup_hash);
  EXPECT_EQ(p[1].setup_hash, swapped[0].setup_hash);
  EXPECT_NE(p[0].setup_hash, p[1].setup_hash);
  const auto edited = planBatch(csv(dir, kHeader + r1 + "s2,walk,ik,m.osim,b.trc,,,,,gait\n"), dir + "/out");
  EXPECT_EQ(edited[0].setup_hash, p[0].setup_hash);
  EXPECT_NE(edited[1].setup_hash, p[1].setup_hash) << "another marker file makes another trial";
  // FNV-1a 64: the empty input gives the offset basis; "a" followed by the 0xff file separator
  // gives 089bc907b544c769 (computed with an independent Python implementation, whose "a" alone
  // gives the published test vector af63dc4c8601ec8c).
  EXPECT_EQ(calcSetupHash({}), "cbf29ce484222325");
  EXPECT_EQ(calcSetupHash({"a"}), "089bc907b544c769");
  EXPECT_NE(calcSetupHash({"ab", ""}), calcSetupHash({"a", "b"}));
}

TEST(BatchPlan, WritingSetupsLeavesUnchangedFilesAlone) {
  const std::string dir = makeInputs("plan_write");
  const auto plans = planBatch(csv(dir, std::string(kHeader) + "s1,walk,ik,m.osim,a.c3d,,,,,\n"), dir + "/out");
  writeTrialSetups(plans[0]);
  for (const auto& [path, contents] : plans[0].setup_files) EXPECT_EQ(readFileText(path), contents);
  const auto old = fs::file_time_type::clock::now() - std::chrono::hours(1);
  fs::last_write_time(plans[0].setup_file, old);
  writeTrialSetups(plans[0]);
  EXPECT_EQ(fs::last_write_time(plans[0].setup_file), old);
  std::ofstream(plans[0].setup_file) << "edited";
  writeTrialSetups(plans[0]);
  EXPECT_EQ(readFileText(plans[0].setup_file), plans[0].setup_files[0].second);
}

}  // namespace
}  // namespace kneesim::tool
