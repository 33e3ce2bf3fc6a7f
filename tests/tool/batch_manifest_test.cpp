// Batch manifests: CSV and TOML read into the same rows, every cell located; one line per error.
#include "tool/batch_manifest.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim::tool {
namespace {

std::string writeText(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

TEST(BatchManifest, CsvRowsWithQuotesCommentsAndCrLf) {
  const std::string dir = test::scratchDir("manifest_csv");
  const std::string path = writeText(dir, "m.csv",
                                     "# a cohort\r\n"
                                     "Subject, trial ,TOOLS,model,markers,activity\r\n"
                                     "\r\n"
                                     "s1,walk1,ik+contact,m.osim,\"a, b.trc\",gait\r\n"
                                     "# a comment between rows\r\n"
                                     "s2,walk1,\"ik\",m.osim,\"say \"\"hi\"\".c3d\",\r\n");
  const Manifest m = readManifest(path);
  ASSERT_EQ(m.rows.size(), 2u);
  const ManifestRow& a = m.rows[0];
  EXPECT_EQ(a.find("subject")->text, "s1");
  EXPECT_EQ(a.find("trial")->text, "walk1");
  EXPECT_EQ(a.find("tools")->text, "ik+contact");
  EXPECT_EQ(a.find("markers")->text, "a, b.trc");
  EXPECT_EQ(a.find("activity")->text, "gait");
  EXPECT_EQ(a.find("markers")->where.line, 4);
  EXPECT_EQ(a.find("markers")->where.element, "row 1/markers");
  const ManifestRow& b = m.rows[1];
  EXPECT_EQ(b.find("markers")->text, "say \"hi\".c3d");
  EXPECT_EQ(b.find("activity"), nullptr) << "an empty cell is left out";
  EXPECT_EQ(b.where.line, 6);
  EXPECT_EQ(b.where.element, "row 2");
}

TEST(BatchManifest, CsvErrorsNameTheLine) {
  const std::string dir = test::scratchDir("manifest_csv_errors");
  const auto error = [&](const std::string& text) {
    const std::string path = writeText(dir, "m.csv", text);
    return test::inputErrorOf([&] { readManifest(path); });
  };
  const std::string f = dir + "/m.csv";
  EXPECT_EQ(error("subject,trail\n"), f + ":1: header/trail: unknown column 'trail' (expected subject, trial, tools, "
                                          "model, markers, ik_tasks, time_range, accuracy, marker_rotation, motion, "
                                          "activity, window, knee_forces, c3d, femoral_component, insert, femoral_body, "
                                          "insert_body, femoral_mesh, insert_mesh, threshold, distance_provider, "
                                          "body_mass, plots)");
  EXPECT_EQ(error("subject,Subject\n"), f + ":1: header/subject: column 'subject' appears twice");
  EXPECT_EQ(error("subject,\n"), f + ":1: header/: expected a column name, got an empty cell");
  EXPECT_EQ(error("subject,trial\ns1,t1\ns2\n"), f + ":3: row 2: expected 2 cells as in the header, got 1");
  EXPECT_EQ(error("subject,trial\ns1,\"t1\n"),
            f + ":2: row 1: expected a closing '\"', got the end of the line (a cell cannot span lines)");
  EXPECT_EQ(error("subject,trial\ns1,\"t1\"x\n"), f + ":2: row 1: expected ',' after a quoted cell, got 'x'");
  EXPECT_EQ(error("\"subject,trial\n"), f + ":1: header: expected a closing '\"', got the end of the line (a cell cannot span lines)");
  EXPECT_EQ(error("# only a comment\n"), f + ": expected a header row naming the columns, got an empty file");
  EXPECT_EQ(error("subject,trial\n"), f + ": expected at least one trial, got none");
}

TEST(BatchManifest, TomlTrialsTakeTheDefaults) {
  const std::string dir = test::scratchDir("manifest_toml");
  const std::string path = writeText(dir, "m.toml",
                                     "# a cohort\n"
                                     "[defaults]\n"
                                     "model = \"m.osim\"\n"
                                     "tools = [\"ik\", \"contact\"]\n"
                                     "body_mass = 66.7\n"
                                     "\n"
                                     "[[trial]]\n"
                                     "subject = \"s1\"\n"
                                     "trial = \"walk1\"\n"
                                     "time_range = [0.5, 2]\n"
                                     "\n"
                                     "[[trial]]\n"
                                     "subject = \"s2\"\n"
                                     "trial = \"walk1\"\n"
                                     "tools = \"ik\"\n"
                                     "plots = true\n"
                                     "accuracy = 1e-6\n");
  const Manifest m = readManifest(path);
  ASSERT_EQ(m.rows.size(), 2u);
  const ManifestRow& a = m.rows[0];
  EXPECT_EQ(a.find("model")->text, "m.osim");
  EXPECT_EQ(a.find("tools")->text, "ik contact");
  EXPECT_EQ(a.find("body_mass")->text, "66.7");
  EXPECT_EQ(a.find("time_range")->text, "0.5 2");
  EXPECT_EQ(a.where.line, 7);
  EXPECT_EQ(a.where.element, "trial[1]");
  EXPECT_EQ(a.find("trial")->where.line, 9);
  EXPECT_EQ(a.find("model")->where.line, 3) << "a default is located where [defaults] gives it";
  const ManifestRow& b = m.rows[1];
  EXPECT_EQ(b.find("tools")->text, "ik") << "a trial's own value wins over the default";
  EXPECT_EQ(b.find("plots")->text, "true");
  EXPECT_EQ(b.find("accuracy")->text, "1e-06");
  EXPECT_EQ(b.find("tools")->where.line, 15);
}

TEST(BatchManifest, TomlErrorsNameTheLine) {
  const std::string dir = test::scratchDir("manifest_toml_errors");
  const auto error = [&](const std::string& text) {
    const std::string path = writeText(dir, "m.toml", text);
    return test::inputErrorOf([&] { readManifest(path); });
  };
  const std::string f = dir + "/m.toml";
  EXPECT_EQ(error("[[trial]]\nsubject = \"s1\"\ntrail = \"t\"\n").rfind(f + ":3: trial[1]/trail: unknown key 'trail'", 0),
            0u);
  EXPECT_EQ(error("[[trial]]\nsubject = \"s1\nx = 1\n"), f + ":2: TOML: Unterminated string literal");
  EXPECT_EQ(error("[[trial]]\nsubject = \"s1\"\nsubject = \"s2\"\n"), f + ":3: TOML: Key subject already present");
  EXPECT_EQ(error("[[trial]]\nsubject = \"s1\"\n[trial.more]\nx = 1\n").rfind(f + ":1: trial[1]/more: unknown key", 0), 0u)
      << "a table inside a trial is refused";
  EXPECT_EQ(error("[[trial]]\nsubject = \"s1\"\n[trial.model]\nx = 1\n"),
            f + ":1: trial[1]/model: expected a string, number, boolean or array, got a table or date");
  EXPECT_EQ(error("model = \"m.osim\"\n"),
            f + ":1: model: expected [[trial]] tables and an optional [defaults] table, got 'model'");
  EXPECT_EQ(error("[defaults]\nmodel = \"m.osim\"\n"), f + ": expected at least one trial, got none");
}

}  // namespace
}  // namespace kneesim::tool
