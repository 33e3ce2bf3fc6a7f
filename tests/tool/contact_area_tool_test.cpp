// ContactAreaTool: setup files end to end against closed forms (a ball on a slider over a flat
// insert, placed by a hand-made model and a motion), JW's hinge kinematics from a flexion list and
// from the ngait_og3 goniometer, and one clear line for each bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "contact/shapes.hpp"
#include "core/error.hpp"
#include "io/knee_forces.hpp"
#include "io/storage.hpp"
#include "model/osim_reader.hpp"
#include "support/input_error.hpp"
#include "support/test_data.hpp"
#include "tool/contact_area_tool.hpp"
#include "tool/run.hpp"

namespace kneesim::tool {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector3d;

constexpr double kR = 0.02;

void writeText(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

// Scratch folder with flat_insert.stl (top y = 0, 40 x 60 mm, 0.5 mm grid), ball.stl (R = 20 mm,
// centred at its origin), the fixture model and a motion lowering the ball from 1 mm above the
// insert to 1 mm into it.
std::string makeScene(const std::string& name) {
  const std::string dir = test::scratchDir(name);
  std::vector<double> xs, zs;
  test::appendNodes(xs, -0.02, 0.02, 0.5e-3);
  test::appendNodes(zs, -0.03, 0.03, 0.5e-3);
  io::TriangleMesh insert = test::makeHeightField(xs, zs, -0.01, [](double, double) { return 0.0; });
  io::writeStl(dir + "/flat_insert.stl", insert);
  io::writeStl(dir + "/ball.stl", test::makeSphere(Vector3d::Zero(), kR, 120, 240));
  fs::copy_file(test::fixturePath("fixtures/slider_knee.osim"), dir + "/slider_knee.osim");
  std::ostringstream mot;
  mot << "lowering\nversion=1\nnRows=5\nnColumns=2\ninDegrees=yes\nendheader\ntime\tlift\n";
  for (int k = 0; k < 5; ++k) mot << 0.1 * k << "\t" << -0.004 - 0.0005 * k << "\n";  // g = 1 mm .. -1 mm
  writeText(dir + "/lowering.mot", mot.str());
  return dir;
}

std::string modelSetup(const std::string& extra = "", const std::string& model_extra = "") {
  return "<ContactAreaTool name=\"slider\">\n"
         "  <femoral_component_file>ball.stl</femoral_component_file>\n"
         "  <insert_file>flat_insert.stl</insert_file>\n"
         "  <extra_thresholds>0.002 0.006</extra_thresholds>\n" +
         extra +
         "  <ModelKinematics>\n"
         "    <model_file>slider_knee.osim</model_file>\n"
         "    <motion_file>lowering.mot</motion_file>\n"
         "    <femoral_body>femur</femoral_body>\n"
         "    <insert_body>tray</insert_body>\n"
         "    <femoral_mesh>ball</femoral_mesh>\n"
         "    <insert_mesh>flat_insert</insert_mesh>\n" +
         model_extra +
         "  </ModelKinematics>\n"
         "  <results_directory>out</results_directory>\n"
         "</ContactAreaTool>\n";
}

double discArea(double t, double g) { return M_PI * ((kR + t) * (kR + t) - (kR + g) * (kR + g)); }

// Model kinematics: X_IF = (I, (0.001, 0.025 + lift, 0)) (fixtures/README.md), so the gap is
// lift + 5 mm and S = pi ((R+t)^2 - (R+g)^2) within the discretisation (the contact-area tests
// bound it: 1.1 mm^2 here).
TEST(ContactAreaTool, ModelKinematicsMatchDiscAreas) {
  const std::string dir = makeScene("cat_model");
  writeText(dir + "/setup.xml", modelSetup("  <write_vtp>true</write_vtp>\n  <vtp_every>2</vtp_every>\n"));
  EXPECT_EQ(detectTool(dir + "/setup.xml"), "contact-area");
  std::ostringstream summary;
  runSetupFile(dir + "/setup.xml", {&summary, {}});
  EXPECT_NE(summary.str().find("5 frames"), std::string::npos) << summary.str();

  const io::Storage st = io::readStorage(dir + "/out/slider_contact_area.sto");
  ASSERT_EQ(st.getNumRows(), 5);
  const double sag = kR * (1 - std::cos(M_PI / 120));
  for (int k = 0; k < 5; ++k) {
    const double g = 1e-3 - 0.5e-3 * k;
    const double bound = 2 * M_PI * (kR + 6e-3) * (sag + 0.5e-6 / (8 * (kR + g)));
    EXPECT_NEAR(st.data(k, 0), 0.1 * k, 1e-12);
    EXPECT_NEAR(st.data(k, st.findColumn("S")), discArea(4e-3, g), bound) << k;
    EXPECT_NEAR(st.data(k, st.findColumn("S@2mm")), discArea(2e-3, g), bound) << k;
    EXPECT_NEAR(st.data(k, st.findColumn("S@6mm")), discArea(6e-3, g), bound) << k;
    EXPECT_NEAR(st.data(k, st.findColumn("dmin")), g, g < 0 ? sag : 1e-8) << k;
    EXPECT_NEAR(st.data(k, st.findColumn("cx_medial")), 0.001, 2e-5) << k;  // the ball is at x = 1 mm
  }
  // dS/dt = -2 pi (R + g) dg/dt with dg/dt = -5 mm/s, at g = 0.
  EXPECT_NEAR(st.data(2, st.findColumn("dS_dt")), 2 * M_PI * kR * 5e-3, 0.03 * 2 * M_PI * kR * 5e-3);
  EXPECT_TRUE(fs::exists(dir + "/out/slider_distance_maps.pvd"));
  EXPECT_TRUE(fs::exists(dir + "/out/slider_distance_maps/insert_00000.vtp"));
  EXPECT_TRUE(fs::exists(dir + "/out/slider_distance_maps/femur_00004.vtp"));
  EXPECT_FALSE(fs::exists(dir + "/out/slider_distance_maps/insert_00001.vtp"));
}

// The same through MeshDistance, and a time range: same numbers for the frames kept.
TEST(ContactAreaTool, MeshDistanceAndTimeRange) {
  const std::string dir = makeScene("cat_exact");
  writeText(dir + "/setup.xml", modelSetup("  <distance_provider>MeshDistance</distance_provider>\n"
                                           "  <time_range>0.15 0.45</time_range>\n"));
  const ContactAreaReport r = runContactArea(readContactAreaSetup(dir + "/setup.xml"));
  ASSERT_EQ(r.series.frames.size(), 3u);
  EXPECT_EQ(r.distance_method, "MeshDistance");
  EXPECT_NEAR(r.series.time[0], 0.2, 1e-12);
  EXPECT_NEAR(r.series.frames[0].S, discArea(4e-3, 0.0), 1.2e-6);
}

// One clear line per bad input.
void expectError(const std::string& dir, const std::string& setup, const std::string& phrase) {
  writeText(dir + "/bad.xml", setup);
  try {
    runContactArea(readContactAreaSetup(dir + "/bad.xml"));
    ADD_FAILURE() << "no error for: " << phrase;
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(phrase), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

std::string replace(std::string s, const std::string& a, const std::string& b) {
  const size_t at = s.find(a);
  EXPECT_NE(at, std::string::npos) << a;
  if (at != std::string::npos) s.replace(at, a.size(), b);
  return s;
}

TEST(ContactAreaTool, BadInputsAreOneLineErrors) {
  const std::string dir = makeScene("cat_errors");
  const std::string good = modelSetup();
  // Meshes: missing, empty, open, in millimetres.
  expectError(dir, replace(good, "ball.stl", "missing.stl"), "STL file not found");
  writeText(dir + "/empty.stl", "");
  expectError(dir, replace(good, "ball.stl", "empty.stl"), "empty STL file");
  io::TriangleMesh open = test::makeSphere(Vector3d::Zero(), kR, 20, 40);
  open.triangles.pop_back();
  io::writeStl(dir + "/open.stl", open);
  expectError(dir, replace(good, "ball.stl", "open.stl"), "open.stl");
  io::TriangleMesh mm = test::makeSphere(Vector3d::Zero(), kR * 1000, 20, 40);
  io::writeStl(dir + "/ball_mm.stl", mm);
  expectError(dir, replace(good, "ball.stl", "ball_mm.stl"), "millimetres");
  // Kinematics: missing files and columns, unknown bodies and meshes, no overlap in time.
  expectError(dir, replace(good, "lowering.mot", "nope.mot"), "motion file not found");
  writeText(dir + "/nolift.mot", "x\nversion=1\nnRows=1\nnColumns=2\ninDegrees=no\nendheader\ntime\tother\n0\t0\n");
  expectError(dir, replace(good, "lowering.mot", "nolift.mot"), "no column for coordinate 'lift'");
  expectError(dir, replace(good, "<femoral_body>femur", "<femoral_body>thigh"), "no body 'thigh'");
  expectError(dir, replace(good, "<femoral_mesh>ball", "<femoral_mesh>knee"), "has no mesh 'knee'");
  expectError(dir, modelSetup("  <time_range>5 6</time_range>\n"), "does not overlap");
  // Setup: unknown provider, element, both or no kinematics.
  expectError(dir, modelSetup("  <distance_provider>bvh</distance_provider>\n"), "no distance provider named 'bvh'");
  expectError(dir, modelSetup("  <treshold>0.004</treshold>\n"), "unknown element <treshold>");
  expectError(dir, modelSetup("  <threshold>-0.004</threshold>\n"), "expected a length >= 0");
  expectError(dir, replace(good, "<ModelKinematics>", "<HingeKinematics><flexion_deg>0</flexion_deg></HingeKinematics>\n<ModelKinematics>"),
              "got both");
  // Hinge sources: a flexion file without the column, a knee-force file without GON.
  writeText(dir + "/flex.mot", "f\nversion=1\nnRows=2\nnColumns=2\ninDegrees=yes\nendheader\ntime\tknee\n0\t0\n0.1\t5\n");
  const std::string hinge =
      "<ContactAreaTool><femoral_component_file>ball.stl</femoral_component_file><insert_file>flat_insert.stl"
      "</insert_file><HingeKinematics>SOURCE</HingeKinematics></ContactAreaTool>";
  expectError(dir, replace(hinge, "SOURCE", "<flexion_file>flex.mot</flexion_file><flexion_column>knee_flexion</flexion_column>"),
              "column 'knee_flexion' is not in");
  writeText(dir + "/forces.csv", "Time(sec),PM,AM,AL,PL\n0,1,2,3,4\n0.1,1,2,3,4\n");
  expectError(dir, replace(hinge, "SOURCE", "<knee_forces_file>forces.csv</knee_forces_file>"), "no goniometer column GON");
  expectError(dir, replace(hinge, "SOURCE", "<flexion_range_deg>10 0 1</flexion_range_deg>"), "last >= first");
  expectError(dir, replace(hinge, "SOURCE", ""), "exactly one flexion source");
}

// Found by fuzzing (fuzz/, docs/fuzzing.md): a flexion range of '5 nan 1' passed the checks (NaN
// compares false) and its frame count, NaN, was converted to an int -- undefined behaviour (UBSan on
// fixtures/fuzz/contact_area_setup/flexion-range-nan.xml); so was the count of '0 1e300 1e-300'.
TEST(ContactAreaToolFuzz, FlexionRangesWithoutAnIntegerCountAreOneLineErrors) {
  const std::string path = test::fixturePath("fixtures/fuzz/contact_area_setup/flexion-range-nan.xml");
  EXPECT_NE(test::inputErrorOf([&] { readContactAreaSetup(path); })
                .find("flexion_range_deg: expected 'first last step' with step > 0 and last >= first, got '5 nan 1'"),
            std::string::npos);
  const std::string dir = test::scratchDir("cat_fuzz");
  const std::string hinge =
      "<ContactAreaTool><femoral_component_file>ball.stl</femoral_component_file><insert_file>flat_insert.stl"
      "</insert_file><HingeKinematics><flexion_range_deg>RANGE</flexion_range_deg></HingeKinematics></ContactAreaTool>";
  for (const auto& [range, phrase] : {std::pair{"0 1e300 1e-300", "expected at most 1000000 values, got inf"},
                                      std::pair{"0 1e10 1", "expected at most 1000000 values, got 1e+10"},
                                      std::pair{"-inf 0 1", "last >= first, got '-inf 0 1'"}}) {
    writeText(dir + "/bad.xml", replace(hinge, "RANGE", range));
    const std::string msg = test::inputErrorOf([&] { readContactAreaSetup(dir + "/bad.xml"); });
    EXPECT_NE(msg.find(phrase), std::string::npos) << msg;
  }
}

// calcModelKinematics from a motion in memory: a coordinate coupled to one the motion has follows
// its coupler, one off the path between the two bodies keeps its default, and only an uncoupled
// coordinate on the path is required. The fixture plus a pelvis on a pin (off the path) and the
// slider coupled to a "drive" coordinate of that pin's twin: lift = 0.5 drive - 0.004.
TEST(ContactAreaTool, ModelKinematicsInMemoryFollowCouplersAndSkipCoordinatesOffThePath) {
  const std::string dir = makeScene("cat_memory");
  std::string osim;
  {
    std::ifstream in(dir + "/slider_knee.osim");
    osim.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const std::string pin = R"(<PinJoint name="NAME_joint">
					<socket_parent_frame>ground_NAME</socket_parent_frame>
					<socket_child_frame>/bodyset/NAME</socket_child_frame>
					<coordinates><Coordinate name="COORD"><default_value>0.2</default_value></Coordinate></coordinates>
					<frames><PhysicalOffsetFrame name="ground_NAME"><socket_parent>/ground</socket_parent>
						<translation>0 1 0</translation><orientation>0 0 0</orientation></PhysicalOffsetFrame></frames>
				</PinJoint>
				)";
  const auto body = [](const std::string& n) {
    return "<Body name=\"" + n + "\"><mass>1</mass><mass_center>0 0 0</mass_center><inertia>0.01 0.01 0.01 0 0 0</inertia></Body>\n";
  };
  osim = replace(osim, "<Body name=\"tray\">", body("pelvis") + body("driver") + "<Body name=\"tray\">");
  std::string joints = replace(replace(pin, "NAME", "pelvis"), "COORD", "tilt");
  joints = replace(replace(replace(joints, "NAME", "pelvis"), "NAME", "pelvis"), "NAME", "pelvis");
  std::string driver = replace(pin, "COORD", "drive");
  for (int k = 0; k < 4; ++k) driver = replace(driver, "NAME", "driver");
  osim = replace(osim, "<SliderJoint name=\"lift_joint\">", joints + driver + "<SliderJoint name=\"lift_joint\">");
  osim = replace(osim, "</JointSet>",
                 "</JointSet>\n<ConstraintSet><objects><CoordinateCouplerConstraint name=\"lift_drive\">"
                 "<coupled_coordinates_function><LinearFunction><coefficients>0.5 -0.004</coefficients></LinearFunction>"
                 "</coupled_coordinates_function><independent_coordinate_names>drive</independent_coordinate_names>"
                 "<dependent_coordinate_name>lift</dependent_coordinate_name><scale_factor>1</scale_factor>"
                 "</CoordinateCouplerConstraint></objects></ConstraintSet>");
  writeText(dir + "/coupled.osim", osim);
  const model::ModelPtr m = model::readOsim(dir + "/coupled.osim");
  ASSERT_EQ(m->couplers.size(), 1u);
  writeText(dir + "/setup.xml", modelSetup());
  ContactAreaSetup setup = readContactAreaSetup(dir + "/setup.xml");
  io::Storage mot;
  mot.labels = {"time", "drive"};
  mot.data.resize(3, 2);
  mot.data << 0, 0.0, 0.1, 0.001, 0.2, -0.001;  // lift = -4, -3.5, -4.5 mm: gap 1, 1.5, 0.5 mm
  const ContactKinematics k = calcModelKinematics(setup, m, mot, "drive motion");
  ASSERT_EQ(k.X_IF.size(), 3u);
  for (int j = 0; j < 3; ++j) {
    const double lift = 0.5 * mot.data(j, 1) - 0.004;
    EXPECT_NEAR((k.X_IF[size_t(j)].translation() - Vector3d(0.001, 0.025 + lift, 0)).norm(), 0, 1e-12) << j;
    EXPECT_TRUE(k.X_IF[size_t(j)].linear().isIdentity(1e-12));
  }
  // Without "drive" the slider's coupler has nothing to follow: drive is on the path through it.
  mot.labels = {"time", "tilt"};
  try {
    calcModelKinematics(setup, m, mot, "tilt motion");
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("has no column for coordinate 'drive'"), std::string::npos) << e.what();
  }
}

const char* kJwHinge =
    "<ContactAreaTool name=\"jw\">\n"
    "  <femoral_component_file>FEMUR</femoral_component_file>\n"
    "  <insert_file>INSERT</insert_file>\n"
    "  <HingeKinematics>SOURCE</HingeKinematics>\n"
    "  <results_directory>out</results_directory>\n"
    "</ContactAreaTool>\n";

std::string jwSetup(const std::string& source, const std::string& extra = "") {
  std::string s = kJwHinge;
  s = replace(s, "FEMUR", test::dataPath("kgc4-jw/implant/femoral_component.stl"));
  s = replace(s, "INSERT", test::dataPath("kgc4-jw/implant/tibial_insert.stl"));
  s = replace(s, "SOURCE", source);
  return replace(s, "  <results_directory>", extra + "  <results_directory>");
}

// JW's hinge kinematics from a flexion list: the areas of the contact-area tests (2722.3 and
// 2531.7 mm^2 at 0 and 30 degrees).
TEST(ContactAreaTool, JwHingeFromFlexionList) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/implant/femoral_component.stl");
  const std::string dir = test::scratchDir("cat_jw_list");
  writeText(dir + "/jw.xml", jwSetup("<flexion_deg>0 30</flexion_deg><time_step>0.5</time_step>",
                                     "  <hinge_file>hinge.csv</hinge_file>\n"));
  const ContactAreaReport r = runContactArea(readContactAreaSetup(dir + "/jw.xml"));
  ASSERT_EQ(r.series.frames.size(), 2u);
  EXPECT_NEAR(r.series.frames[0].S * 1e6, 2722.3, 0.1);
  EXPECT_NEAR(r.series.frames[1].S * 1e6, 2531.7, 0.1);
  EXPECT_NEAR(r.series.time[1], 0.5, 1e-12);
  EXPECT_TRUE(fs::exists(dir + "/out/hinge.csv"));
  const io::Storage st = io::readStorage(dir + "/out/jw_contact_area.sto");
  EXPECT_NEAR(st.data(1, st.findColumn("flexion")), 30 * M_PI / 180, 1e-8);
}

// The ngait_og3 goniometer (degrees, flexion positive: 2.8..64.7 over the trial) drives the hinge:
// the flexion column is the GON value in radians at the file's times.
TEST(ContactAreaTool, JwHingeFromGoniometer) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv");
  const std::string dir = test::scratchDir("cat_jw_gon");
  const std::string csv = test::dataPath("kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv");
  writeText(dir + "/jw.xml", jwSetup("<knee_forces_file>" + csv + "</knee_forces_file>",
                                     "  <time_range>2.0 2.03</time_range>\n"));
  const ContactAreaReport r = runContactArea(readContactAreaSetup(dir + "/jw.xml"));
  const io::KneeForces kf = io::readKneeForces(csv);
  ASSERT_EQ(r.series.frames.size(), 3u);  // 2.00667, 2.01500 and 2.02334 s at 120 Hz
  const auto& flexion = r.kinematics.columns[0].second;
  for (size_t j = 0; j < r.series.time.size(); ++j) {
    size_t row = 0;
    while (std::abs(kf.time[row] - r.series.time[j]) > 1e-9) ++row;
    EXPECT_NEAR(flexion[j], kf.goniometer[row] * M_PI / 180, 1e-12);
    EXPECT_GT(r.series.frames[j].S, 2e-3);  // near full extension: most of the dishes within 4 mm
  }
  EXPECT_TRUE(r.warnings.empty());
}

// The hinge seated on a 5-degree flexion grid (seating_grid_deg, linear interpolation of the seating
// coordinates between knots) against seating every frame: the interpolated poses touch the insert
// to micrometres and give the same areas within a few mm^2 (the seated position scatters by up to
// 1 mm along the flat dishes, README "Seating"; the area hardly depends on it).
TEST(ContactAreaTool, JwHingeOnAFlexionGridMatchesSeatingEveryFrame) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/implant/femoral_component.stl");
  const std::string dir = test::scratchDir("cat_jw_grid");
  const std::string angles = "<flexion_range_deg>3 25.5 2.25</flexion_range_deg>";  // 11 frames
  writeText(dir + "/every.xml", jwSetup(angles + "<seating_grid_deg>0</seating_grid_deg>"));
  writeText(dir + "/grid.xml", jwSetup(angles + "<seating_grid_deg>5</seating_grid_deg>"));
  const ContactAreaReport every = runContactArea(readContactAreaSetup(dir + "/every.xml"));
  const ContactAreaReport grid = runContactArea(readContactAreaSetup(dir + "/grid.xml"));
  ASSERT_EQ(grid.series.frames.size(), 11u);
  EXPECT_NE(grid.kinematics.description.find("5-degree grid (7 knots, 0 to 30 deg)"), std::string::npos)
      << grid.kinematics.description;
  double worst_area = 0, worst_gap = 0, worst_move = 0;
  for (size_t j = 0; j < 11; ++j) {
    worst_area = std::max(worst_area, std::abs(grid.series.frames[j].S - every.series.frames[j].S));
    for (size_t c = 1; c <= 2; ++c) worst_gap = std::max(worst_gap, std::abs(grid.kinematics.columns[c].second[j]));
    worst_move = std::max(worst_move, (grid.kinematics.X_IF[j].translation() - every.kinematics.X_IF[j].translation()).norm());
  }
  std::printf("[ JW grid  ] 5-degree grid vs seating every frame: area within %.2f mm^2, residual gaps within %.2f um, "
              "femur within %.3f mm\n", worst_area * 1e6, worst_gap * 1e6, worst_move * 1e3);
  EXPECT_LT(worst_gap, 20e-6);
  EXPECT_LT(worst_area, 15e-6);
}

}  // namespace
}  // namespace kneesim::tool
