#include "tool/knee_model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "core/error.hpp"
#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim::tool {
namespace {

constexpr double kDeg = M_PI / 180.0;

std::string writeSetup(const std::string& dir, const std::string& body) {
  const std::string path = dir + "/build.xml";
  std::ofstream(path) << "<?xml version=\"1.0\"?>\n<KneeModelTool name=\"m\">\n" << body << "</KneeModelTool>\n";
  return path;
}

const char* const kRequired =
    "<source_model_file>src.osim</source_model_file><femoral_component_file>f.stl</femoral_component_file>"
    "<tibial_insert_file>i.stl</tibial_insert_file><patellar_button_file>b.stl</patellar_button_file>"
    "<output_model_file>out/m.osim</output_model_file>";

// The setup as written: paths against the setup's folder, degrees to radians, lab axes as columns,
// markers and range overrides.
TEST(KneeModelSetup, ReadsAllElements) {
  const std::string dir = test::scratchDir("knee_model_setup");
  const std::string path = writeSetup(
      dir, std::string(kRequired) +
               "<neutral_flexion>10</neutral_flexion><flexion_knots>-10 30 10</flexion_knots>"
               "<smoothing_window>12</smoothing_window><lab_axes>-x z y</lab_axes>"
               "<MarkerSet><Marker name=\"A\"><body>femur</body><source>R.A</source></Marker>"
               "<Marker name=\"B\"><body>toes</body></Marker></MarkerSet>"
               "<CoordinateRanges><Range name=\"hip_adduction\">-30 20</Range></CoordinateRanges>");
  const KneeModelSetup s = readKneeModelSetup(path);
  EXPECT_EQ(s.name, "m");
  EXPECT_EQ(s.source_model_file, dir + "/src.osim");
  EXPECT_EQ(s.output_model_file, dir + "/out/m.osim");
  EXPECT_TRUE(s.tibial_tray_file.empty());
  EXPECT_NEAR(s.neutral_flexion, 10 * kDeg, 1e-15);
  ASSERT_EQ(s.flexion_knots.size(), 5u);
  EXPECT_NEAR(s.flexion_knots[1], 0.0, 1e-15);
  EXPECT_NEAR(s.smoothing_window, 12 * kDeg, 1e-15);
  Eigen::Matrix3d R;
  R << -1, 0, 0, 0, 0, 1, 0, 1, 0;
  EXPECT_TRUE(s.R_lab_model == R);
  ASSERT_EQ(s.markers.size(), 2u);
  EXPECT_EQ(s.markers[0].source, "R.A");
  EXPECT_EQ(s.markers[1].source, "");
  ASSERT_EQ(s.ranges.size(), 1u);
  EXPECT_EQ(s.ranges[0].second.second, 20.0);
}

TEST(KneeModelSetup, BadSetupsGiveOneLineErrors) {
  const std::string dir = test::scratchDir("knee_model_bad");
  auto expectError = [&](const std::string& body, const std::string& needle) {
    try {
      readKneeModelSetup(writeSetup(dir, body));
      ADD_FAILURE() << "no error for " << body;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  };
  const std::string ok = kRequired;
  expectError(ok + "<bogus/>", "unknown element <bogus>");
  expectError("<femoral_component_file>f.stl</femoral_component_file>", "source_model_file");
  expectError(ok + "<lab_axes>x x y</lab_axes>", "right-handed");
  expectError(ok + "<lab_axes>-x up y</lab_axes>", "expected an axis");
  expectError(ok + "<flexion_knots>5 40 5</flexion_knots>", "including 0");
  expectError(ok + "<neutral_flexion>7</neutral_flexion>", "neutral flexion");
  expectError(ok + "<flexion_knots>0 10</flexion_knots>", "first last step");
  // Found by fuzzing (fixtures/fuzz/knee_model_setup/): a step of 5e-320 deg asked for 3e321 knots,
  // pushed one by one until the memory ran out; an infinite last knot never ended the loop.
  EXPECT_NE(test::inputErrorOf([] {
              readKneeModelSetup(test::fixturePath("fixtures/fuzz/knee_model_setup/knot-step-denormal.xml"));
            }).find("knot-step-denormal.xml:10: KneeModelTool[jw_knee24]/flexion_knots: expected at most 1000 values, got inf"),
            std::string::npos);
  expectError(ok + "<flexion_knots>-20 inf 5</flexion_knots>", "last >= first, got '-20 inf 5'");
  expectError(ok + "<flexion_knots>0 1000 0.5</flexion_knots>", "expected at most 1000 values, got 2001");
  expectError(ok + "<MarkerSet><Marker name=\"A\"><body>shin</body></Marker></MarkerSet>", "unknown body 'shin'");
  expectError(ok + "<MarkerSet><Marker name=\"A\"><body>femur</body></Marker><Marker name=\"A\"><body>femur</body></Marker></MarkerSet>",
              "duplicate marker 'A'");
  expectError(ok + "<CoordinateRanges><Range name=\"x\">3 1</Range></CoordinateRanges>", "min < max");
  // A missing source model is reported by the build, naming the file, before anything is written.
  try {
    buildKneeModel(readKneeModelSetup(writeSetup(dir, ok)));
    ADD_FAILURE() << "no error for a missing source model";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("src.osim"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/out/m.osim"));
}

}  // namespace
}  // namespace kneesim::tool
