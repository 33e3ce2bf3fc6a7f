// InverseDynamicsTool against OpenSim's own answers (opensim-core's ID regression cases), and
// its bad-input messages.
#include "dynamics/tool.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "core/strings.hpp"
#include "io/storage.hpp"
#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim::dynamics {
namespace {

namespace fs = std::filesystem;

/// OpenSim's Storage::compareColumnRMS: the RMS over our rows of (ours - standard linearly
/// interpolated at our time), over the times both cover.
struct ColumnComparison {
  std::string label;
  double rms = 0, range = 0;
};

std::vector<ColumnComparison> compareWithStandard(const io::Storage& result, const io::Storage& standard) {
  std::vector<ColumnComparison> out;
  const Eigen::VectorXd ts = standard.getColumn("time"), tr = result.getColumn("time");
  for (size_t c = 1; c < standard.labels.size(); ++c) {
    const int rc = result.findColumn(standard.labels[c]);
    EXPECT_GE(rc, 0) << "missing column " << standard.labels[c];
    if (rc < 0) continue;
    double sum = 0;
    int n = 0;
    for (int i = 0; i < tr.size(); ++i) {
      const double t = tr[i];
      if (t < ts[0] - 1e-6 || t > ts[ts.size() - 1] + 1e-6) continue;
      int k = 0;
      while (k + 2 < ts.size() && ts[k + 1] < t) ++k;
      const double w = std::clamp((t - ts[k]) / (ts[k + 1] - ts[k]), 0.0, 1.0);
      const double s = (1 - w) * standard.data(k, c) + w * standard.data(k + 1, c);
      sum += std::pow(result.data(i, rc) - s, 2);
      ++n;
    }
    EXPECT_GT(n, 10);
    ColumnComparison cc;
    cc.label = standard.labels[c];
    cc.rms = std::sqrt(sum / std::max(1, n));
    cc.range = standard.data.col(c).maxCoeff() - standard.data.col(c).minCoeff();
    out.push_back(cc);
  }
  return out;
}

/// Runs a copied setup with its results in a scratch folder; returns the generalised forces.
io::Storage runCase(const std::string& setup_name, const std::string& scratch) {
  IdSetup setup = readIdSetup(test::dataPath("opensim-dynamics-tests/id/" + setup_name));
  setup.output_gen_force_file = test::scratchDir(scratch) + "/result.sto";
  const IdReport report = runInverseDynamicsTool(setup);
  EXPECT_TRUE(fs::exists(setup.output_gen_force_file));
  return io::readStorage(setup.output_gen_force_file);
}

void expectWithinOpenSimTolerance(const io::Storage& result, const std::string& standard_name) {
  const io::Storage standard = io::readStorage(test::dataPath("opensim-dynamics-tests/id/" + standard_name));
  const auto cmp = compareWithStandard(result, standard);
  EXPECT_EQ(cmp.size(), standard.labels.size() - 1);
  for (const ColumnComparison& c : cmp) {
    // OpenSim's own test: CHECK_STORAGE_AGAINST_STANDARD with 2.0 per column (testID.cpp).
    EXPECT_LE(c.rms, 2.0) << c.label;
    std::cout << "  " << c.label << ": RMS " << formatSignificant(c.rms, 3) << " ("
              << formatSignificant(100 * c.rms / std::max(c.range, 1e-12), 3) << " % of range "
              << formatSignificant(c.range, 4) << ")\n";
  }
}

TEST(InverseDynamicsTool, Gait2354WithGroundReactionsMatchesOpenSim) {
  const io::Storage r = runCase("subject01_Setup_InverseDynamics.xml", "id_subject01");
  // OpenSim's frames: its resampled grid from 0.4999993 to 1.5999989 s (67 rows).
  ASSERT_EQ(r.getNumRows(), 67);
  EXPECT_NEAR(r.data(0, 0), 0.49999930, 5e-8);
  EXPECT_NEAR(r.data(66, 0), 1.59999886, 5e-8);
  expectWithinOpenSimTolerance(r, "std_subject01_InverseDynamics.sto");
}

TEST(InverseDynamicsTool, Arm26MatchesOpenSim) {
  const io::Storage r = runCase("arm26_Setup_InverseDynamics.xml", "id_arm26");
  expectWithinOpenSimTolerance(r, "std_arm26_InverseDynamics.sto");
}

/// A scratch copy of the subject01 case whose files a test may change.
std::string copyCase(const std::string& name) {
  EXPECT_TRUE(fs::exists(test::dataPath("opensim-dynamics-tests/id/subject01_walk1_grf.mot")));
  const std::string dir = test::scratchDir(name);
  for (const auto& e : fs::directory_iterator(test::dataPath("opensim-dynamics-tests/id")))
    if (startsWith(e.path().filename().string(), "subject01")) fs::copy(e.path(), dir + "/" + e.path().filename().string());
  return dir;
}

void replaceInFile(const std::string& path, const std::string& from, const std::string& to) {
  std::string text = readFileText(path);
  const size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  text.replace(at, from.size(), to);
  std::ofstream(path) << text;
}

std::string errorOfCase(const std::string& dir) {
  return test::inputErrorOf([&] { runInverseDynamicsTool(readIdSetup(dir + "/subject01_Setup_InverseDynamics.xml")); });
}

TEST(InverseDynamicsTool, BadInputIsOneLine) {
  {  // A GRF column missing.
    const std::string dir = copyCase("id_bad_column");
    replaceInFile(dir + "/subject01_walk1_grf.mot", "l_ground_force_vz", "l_ground_force_wz");
    const std::string msg = errorOfCase(dir);
    EXPECT_NE(msg.find("subject01_walk1_grf.xml:"), std::string::npos) << msg;
    EXPECT_NE(msg.find("force_identifier: expected 3 columns of"), std::string::npos) << msg;
    EXPECT_NE(msg.find("got 2 (l_ground_force_vx, l_ground_force_vy)"), std::string::npos) << msg;
  }
  {  // A body the model lacks.
    const std::string dir = copyCase("id_bad_body");
    replaceInFile(dir + "/subject01_walk1_grf.xml", "<applied_to_body>calcn_l<", "<applied_to_body>foot_l<");
    const std::string msg = errorOfCase(dir);
    EXPECT_NE(msg.find("applied_to_body: expected a body of model"), std::string::npos) << msg;
    EXPECT_NE(msg.find("got 'foot_l'"), std::string::npos) << msg;
  }
  {  // Force data that do not overlap the analysed times.
    const std::string dir = copyCase("id_bad_times");
    // Keep the GRF's first 0.3 s (its header, labels and 180 rows): the analysis is 0.5-1.6 s.
    const std::string grf = dir + "/subject01_walk1_grf.mot";
    const std::vector<std::string_view> lines = splitLines(readFileText(grf));
    std::ofstream out(grf);
    for (size_t i = 0; i < 6 + 180; ++i) out << lines[i] << "\n";
    out.close();
    replaceInFile(grf, "datarows 9009", "datarows 180");
    const std::string msg = errorOfCase(dir);
    EXPECT_NE(msg.find("external_loads_file: expected force data overlapping the analysed times"), std::string::npos) << msg;
  }
  {  // NaN in the forces.
    const std::string dir = copyCase("id_bad_nan");
    replaceInFile(dir + "/subject01_walk1_grf.mot", "\t743.0973413\t", "\tNaN\t");
    const std::string msg = errorOfCase(dir);
    EXPECT_NE(msg.find("subject01_walk1_grf.mot: ground_force_vy: expected finite force data, got nan"), std::string::npos)
        << msg;
  }
  {  // A time range outside the coordinates, an unknown element, a joint the model lacks.
    const std::string dir = copyCase("id_bad_setup");
    replaceInFile(dir + "/subject01_Setup_InverseDynamics.xml", "0.5 1.6", "5 6");
    EXPECT_NE(errorOfCase(dir).find("time_range: expected a time range overlapping the coordinates"), std::string::npos);
    replaceInFile(dir + "/subject01_Setup_InverseDynamics.xml", "<forces_to_exclude>", "<joint_loads>knee_x</joint_loads><forces_to_exclude>");
    replaceInFile(dir + "/subject01_Setup_InverseDynamics.xml", "5 6", "0.5 1.6");
    EXPECT_NE(errorOfCase(dir).find("joint_loads: expected a joint of"), std::string::npos);
    replaceInFile(dir + "/subject01_Setup_InverseDynamics.xml", "<forces_to_exclude>", "<force_to_exclude/><forces_to_exclude>");
    EXPECT_NE(errorOfCase(dir).find("force_to_exclude"), std::string::npos);
  }
  {  // A model file name longer than the system allows: not found (std::filesystem threw
     // filesystem_error here, an "internal error" at the command line, until 2026-11-28).
    const std::string dir = copyCase("id_long_name");
    replaceInFile(dir + "/subject01_Setup_InverseDynamics.xml", "subject01.osim", std::string(300, 'm') + ".osim");
    EXPECT_NE(errorOfCase(dir).find("model_file: model file not found: "), std::string::npos);
  }
}

// <KneeLoads> and <ForcePlates> of a setup: each bad input is one line naming the element.
TEST(InverseDynamicsTool, KneeLoadsAndForcePlatesBadInputIsOneLine) {
  const std::string dir = copyCase("id_bad_knee_plates");
  const std::string setup = dir + "/subject01_Setup_InverseDynamics.xml";
  const std::string good = readFileText(setup);
  const auto withTool = [&](const std::string& from, const std::string& to) {
    std::ofstream(setup) << good;
    replaceInFile(setup, from, to);
    return errorOfCase(dir);
  };
  const std::string excl = "<forces_to_exclude>";
  EXPECT_THAT(withTool(excl, "<KneeLoads><joint>knee_x</joint></KneeLoads>" + excl),
              testing::HasSubstr("KneeLoads: expected a joint of " + dir + "/subject01.osim, got 'knee_x'"));
  EXPECT_THAT(withTool(excl, "<KneeLoads><axes>posterior superior medial</axes></KneeLoads>" + excl),
              testing::HasSubstr("KneeLoads: missing <joint>"));
  EXPECT_THAT(withTool(excl, "<KneeLoads><joint>knee_r</joint><axes>up superior medial</axes></KneeLoads>" + excl),
              testing::HasSubstr("axes: expected anterior, posterior, superior, inferior, medial or lateral, got 'up'"));
  EXPECT_THAT(withTool(excl, "<KneeLoads><joint>knee_r</joint><axes>anterior posterior medial</axes></KneeLoads>" + excl),
              testing::HasSubstr("axes: expected one anteroposterior, one superoinferior and one mediolateral axis"));
  EXPECT_THAT(withTool(excl, "<KneeLoads><joint>knee_r</joint><side>right</side></KneeLoads>" + excl),
              testing::HasSubstr("side"));
  // Plates and an ExternalLoads file at once; plates without a C3D file, without feet, with a
  // missing or truncated file, with a threshold that is not a force.
  const std::string plates = "<ForcePlates><c3d_file>walk.c3d</c3d_file><Foot name=\"r\"><body>calcn_r</body>"
                             "<markers>RHeel RToe</markers></Foot></ForcePlates>";
  EXPECT_THAT(withTool(excl, plates + excl), testing::HasSubstr("expected either <external_loads_file> or <ForcePlates>, got both"));
  const std::string ext = "<external_loads_file>subject01_walk1_grf.xml</external_loads_file>";
  EXPECT_THAT(withTool(ext, "<ForcePlates><Foot name=\"r\"><markers>RHeel</markers></Foot></ForcePlates>"),
              testing::HasSubstr("ForcePlates: missing <c3d_file>"));
  EXPECT_THAT(withTool(ext, "<ForcePlates><c3d_file>walk.c3d</c3d_file></ForcePlates>"),
              testing::HasSubstr("expected at least one <Foot>, got none"));
  EXPECT_THAT(withTool(ext, "<ForcePlates><c3d_file>walk.c3d</c3d_file><threshold>-5</threshold><Foot name=\"r\">"
                            "<markers>RHeel</markers></Foot></ForcePlates>"),
              testing::HasSubstr("threshold: expected a threshold > 0 N, got -5"));
  EXPECT_THAT(withTool(ext, plates), testing::HasSubstr("ForcePlates: C3D file not found: " + dir + "/walk.c3d"));
  // JW's gait C3D cut short: a truncated binary is one line too, and no output is written.
  const std::string jw = test::dataPath("kgc4-jw/markers/jw_ngait_og3.c3d");
  ASSERT_TRUE(fs::exists(jw));
  std::string bytes = readFileText(jw);
  bytes.resize(bytes.size() / 3);
  std::ofstream(dir + "/walk.c3d", std::ios::binary) << bytes;
  const std::string msg = withTool(ext, plates);
  EXPECT_THAT(msg, testing::HasSubstr(dir + "/walk.c3d"));
  EXPECT_FALSE(fs::exists(dir + "/Results/subject01_InverseDynamics.sto")) << msg;
}

TEST(InverseDynamicsTool, WritesJointLoadsAndNamesForcesItLeavesOut) {
  const std::string dir = copyCase("id_joint_loads");
  replaceInFile(dir + "/subject01_Setup_InverseDynamics.xml", "<forces_to_exclude>muscles</forces_to_exclude>",
                "<joint_loads>knee_r</joint_loads><joint_loads_expressed_in>ground</joint_loads_expressed_in>");
  const IdSetup setup = readIdSetup(dir + "/subject01_Setup_InverseDynamics.xml");
  const IdReport report = runInverseDynamicsTool(setup);
  ASSERT_EQ(report.outputs.size(), 2u);
  // Muscles were not excluded: the run says OpenSim would have applied them.
  EXPECT_NE(join(report.warnings, "\n").find("OpenSim would apply Thelen2003Muscle"), std::string::npos);
  const io::Storage j = io::readStorage(setup.output_joint_loads_file);
  ASSERT_EQ(j.labels[1], "knee_r_on_tibia_r_in_ground_fx");
  // In late stance the shank carries about the body weight plus the push-off: the vertical
  // force the femur applies to the tibia is downwards (compression) and of the GRF's size.
  const int row = 40, fy = j.findColumn("knee_r_on_tibia_r_in_ground_fy");
  EXPECT_LT(j.data(row, fy), -400.0);
  EXPECT_GT(j.data(row, fy), -900.0);
}

}  // namespace
}  // namespace kneesim::dynamics
