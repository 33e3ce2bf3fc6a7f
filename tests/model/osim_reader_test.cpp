#include "model/osim_reader.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <regex>

#include "core/error.hpp"
#include "model/kinematics.hpp"
#include "support/test_data.hpp"

namespace kneesim::model {
namespace {

using test::dataPath;
using test::fixturePath;

int countIgnored(const Model& m, const std::string& type) {
  return int(std::count_if(m.ignored.begin(), m.ignored.end(), [&](const IgnoredComponent& c) { return c.type == type; }));
}

const Joint& joint(const Model& m, const std::string& name) {
  const int j = m.findJoint(name);
  if (j < 0) throw std::runtime_error("no joint " + name);
  return m.joints[j];
}

const Coordinate& coordinate(const Model& m, const std::string& name) {
  const int c = m.findCoordinate(name);
  if (c < 0) throw std::runtime_error("no coordinate " + name);
  return m.coordinates[c];
}

const Body& body(const Model& m, const std::string& name) {
  const int b = m.findBody(name);
  if (b < 0) throw std::runtime_error("no body " + name);
  return m.bodies[b];
}

// ---------------------------------------------------------------------------------- real files

TEST(OsimReader, Gait2354Format20303) {
  KNEESIM_REQUIRE_DATA("opensim-ik-tests/subject01_simbody.osim");
  const ModelPtr m = readOsim(dataPath("opensim-ik-tests/subject01_simbody.osim"));
  EXPECT_EQ(m->format_version, 20303);
  EXPECT_EQ(m->name, "subject01");
  EXPECT_EQ(m->bodies.size(), 13u);  // ground + 12
  EXPECT_EQ(m->joints.size(), 12u);
  EXPECT_EQ(m->coordinates.size(), 23u);
  EXPECT_EQ(m->markers.size(), 39u);
  EXPECT_TRUE(m->couplers.empty());
  EXPECT_EQ(m->muscles.size(), 54u);  // read by model/osim_forces (tested there)
  EXPECT_EQ(countIgnored(*m, "Thelen2003Muscle"), 0);
  EXPECT_EQ(m->bodies[0].name, "ground");
  EXPECT_EQ(m->joints[0].name, "ground_pelvis");  // parents first

  // hip_r: <location_in_parent> -0.0724376 -0.0677245 0.0855522, parent pelvis.
  const Joint& hip = joint(*m, "hip_r");
  EXPECT_EQ(m->bodies[hip.parent_body].name, "pelvis");
  EXPECT_EQ(m->bodies[hip.child_body].name, "femur_r");
  EXPECT_TRUE(hip.X_PF.translation().isApprox(Vec3(-0.0724376, -0.0677245, 0.0855522), 1e-15));
  EXPECT_TRUE(hip.X_PF.linear().isIdentity(0));
  EXPECT_FALSE(hip.reverse);

  // femur_r: mass 8.98403823, mass_center 0 -0.195031 0, inertia_xx/yy/zz 0.17022071 0.04462096 0.17950086.
  const Body& femur = body(*m, "femur_r");
  EXPECT_EQ(femur.mass, 8.98403823);
  EXPECT_EQ(femur.mass_center, Vec3(0, -0.195031, 0));
  EXPECT_EQ(femur.inertia(0, 0), 0.17022071);
  EXPECT_EQ(femur.inertia(1, 1), 0.04462096);
  EXPECT_EQ(femur.inertia(2, 2), 0.17950086);
  EXPECT_EQ(femur.inertia(0, 1), 0.0);

  // knee_r: rotation1 about z by knee_angle_r; translation1 = 1.14724 * SimmSpline (12 knots).
  const Joint& knee = joint(*m, "knee_r");
  ASSERT_EQ(knee.type, JointType::Custom);
  ASSERT_EQ(knee.coordinates.size(), 1u);
  const int q = knee.coordinates[0];
  EXPECT_EQ(m->coordinates[q].name, "knee_angle_r");
  EXPECT_EQ(knee.spatial[0].axis, Vec3(0, 0, 1));
  EXPECT_EQ(knee.spatial[0].coordinates, std::vector<int>{q});
  EXPECT_EQ(knee.spatial[3].coordinates, std::vector<int>{q});
  EXPECT_TRUE(knee.spatial[5].coordinates.empty());
  const auto* mult = dynamic_cast<const MultiplierFunction*>(knee.spatial[3].function.get());
  ASSERT_NE(mult, nullptr);
  EXPECT_EQ(mult->getScale(), 1.14724);
  const auto* spline = dynamic_cast<const SimmSpline*>(mult->getFunction().get());
  ASSERT_NE(spline, nullptr);
  ASSERT_EQ(spline->getX().size(), 12u);
  EXPECT_EQ(spline->getX()[0], -2.0944);
  EXPECT_EQ(spline->getX()[7], 0.197344);
  EXPECT_EQ(spline->getY()[11], -0.00525);
  EXPECT_NEAR(knee.spatial[3].function->calcValue(0.197344), 1.14724 * -0.005227, 1e-17);
  // The range is stored in radians as in the file: -2.0943951 0.17453293.
  EXPECT_EQ(m->coordinates[q].range_min, -2.0943951);
  EXPECT_EQ(m->coordinates[q].range_max, 0.17453293);
  EXPECT_EQ(m->coordinates[q].motion_type, MotionType::Rotational);
  // pelvis_tx moves translation1 through MultiplierFunction(LinearFunction): OpenSim 4 calls it Coupled.
  EXPECT_EQ(coordinate(*m, "pelvis_tx").motion_type, MotionType::Coupled);
  EXPECT_EQ(coordinate(*m, "pelvis_tilt").motion_type, MotionType::Rotational);

  // R.ASIS on pelvis at 0.0234215 0.036283 0.13084, fixed false.
  const Marker& asis = m->markers[m->findMarker("R.ASIS")];
  EXPECT_EQ(m->bodies[asis.body].name, "pelvis");
  EXPECT_EQ(asis.p_BM, Vec3(0.0234215, 0.036283, 0.13084));
  EXPECT_FALSE(asis.fixed);
  // Meshes (tibia.vtp, ...) are not shipped: references kept, paths unresolved, warnings given.
  ASSERT_GE(body(*m, "tibia_r").meshes.size(), 2u);
  EXPECT_EQ(body(*m, "tibia_r").meshes[0].file, "tibia.vtp");
  EXPECT_EQ(body(*m, "tibia_r").meshes[0].resolved_path, "");
  EXPECT_FALSE(m->warnings.empty());
}

TEST(OsimReader, ConstraintTestFormat20302) {
  KNEESIM_REQUIRE_DATA("opensim-ik-tests/constraintTest_ikOnly.osim");
  const ModelPtr m = readOsim(dataPath("opensim-ik-tests/constraintTest_ikOnly.osim"));
  EXPECT_EQ(m->format_version, 20302);
  EXPECT_EQ(m->bodies.size(), 26u);
  EXPECT_EQ(m->joints.size(), 25u);
  EXPECT_EQ(m->coordinates.size(), 58u);
  EXPECT_EQ(m->markers.size(), 57u);
  ASSERT_EQ(m->couplers.size(), 8u);
  std::map<std::string, int> types;
  for (const CoordinateCoupler& cc : m->couplers) types[cc.function->getTypeName()]++;
  EXPECT_EQ(types["NaturalCubicSpline"], 6);
  EXPECT_EQ(types["PiecewiseLinearFunction"], 2);
  // tib_pat_r_r3_con: tib_pat_r_r3 = NaturalCubicSpline(knee_flex_r), 17 knots, first y 0.04960290.
  const CoordinateCoupler& cc = m->couplers[0];
  EXPECT_EQ(cc.name, "tib_pat_r_r3_con");
  EXPECT_EQ(m->coordinates[cc.dependent].name, "tib_pat_r_r3");
  ASSERT_EQ(cc.independents.size(), 1u);
  EXPECT_EQ(m->coordinates[cc.independents[0]].name, "knee_flex_r");
  EXPECT_EQ(cc.scale_factor, 1.0);
  const auto* s = dynamic_cast<const SimmSpline*>(cc.function.get());
  ASSERT_NE(s, nullptr);
  EXPECT_EQ(s->getX().size(), 17u);
  EXPECT_EQ(s->getY()[0], 0.0496029);
  EXPECT_EQ(cc.function->calcValue(1.57079633), 0.30647935);  // a knot
}

TEST(OsimReader, JwAllBodyFormat30000) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/model/jw_all_body_scaled.osim");
  const ModelPtr m = readOsim(dataPath("kgc4-jw/model/jw_all_body_scaled.osim"));
  EXPECT_EQ(m->format_version, 30000);
  EXPECT_EQ(m->bodies.size(), 25u);
  EXPECT_EQ(m->joints.size(), 24u);
  EXPECT_EQ(m->coordinates.size(), 59u);
  EXPECT_EQ(m->markers.size(), 54u);
  EXPECT_EQ(m->couplers.size(), 2u);  // patfem_flexion_con(_l); the two patfem_ty couplers are disabled
  EXPECT_EQ(m->muscles.size(), 54u);  // read by model/osim_forces (tested there)
  EXPECT_EQ(countIgnored(*m, "Ligament (disabled)"), 3);
  EXPECT_EQ(countIgnored(*m, "ConstantDistanceConstraint (disabled)"), 2);  // the patellar ligaments
  EXPECT_TRUE(m->constraints.empty());
  EXPECT_EQ(countIgnored(*m, "CoordinateCouplerConstraint (disabled)"), 2);
  // The disabled ligaments are listed as ligaments that do not pose the model (see model info).
  for (const IgnoredComponent& c : m->ignored) {
    if (c.type == "Ligament (disabled)") EXPECT_TRUE(c.category == "ligament" && !c.affects_kinematics);
    if (c.type == "ConstantDistanceConstraint (disabled)") EXPECT_FALSE(c.affects_kinematics);
  }
  EXPECT_EQ(m->wrap_objects.size(), 36u);

  // knee: reverse CustomJoint, child tibial_tray, parent femoral_component; its CoordinateSet
  // order (adduction, rotation, flexion, tx, ty, tz) differs from the transform's (flexion first).
  const Joint& knee = joint(*m, "knee");
  EXPECT_TRUE(knee.reverse);
  EXPECT_EQ(m->bodies[knee.parent_body].name, "femoral_component");
  EXPECT_EQ(m->bodies[knee.child_body].name, "tibial_tray");
  ASSERT_EQ(knee.coordinates.size(), 6u);
  EXPECT_EQ(m->coordinates[knee.coordinates[0]].name, "knee_adduction");
  EXPECT_EQ(m->coordinates[knee.coordinates[2]].name, "knee_flexion");
  EXPECT_EQ(knee.spatial[0].coordinates, std::vector<int>{knee.coordinates[2]});
  EXPECT_EQ(knee.spatial[1].coordinates, std::vector<int>{knee.coordinates[0]});
  const Coordinate& flex = coordinate(*m, "knee_flexion");
  EXPECT_TRUE(flex.clamped);
  EXPECT_EQ(flex.range_min, -2.513);
  EXPECT_EQ(flex.range_max, 0.34906585);
  EXPECT_EQ(flex.index_in_joint, 2);
  EXPECT_TRUE(coordinate(*m, "knee_tz").locked);
  EXPECT_EQ(coordinate(*m, "knee_ty").default_value, 0.0419072278111028);
  EXPECT_EQ(coordinate(*m, "knee_ty").motion_type, MotionType::Translational);

  // femoral_component_weld: location_in_parent 0 -0.39335 0, orientation_in_parent 3.083 0 -3.083,
  // so R = Rx(3.083) Rz(-3.083) whose first row is (cos 3.083, sin 3.083, 0).
  const Joint& weld = joint(*m, "femoral_component_weld");
  EXPECT_EQ(weld.type, JointType::Weld);
  EXPECT_EQ(weld.X_PF.translation(), Vec3(0, -0.39335, 0));
  EXPECT_NEAR(weld.X_PF.linear()(0, 0), std::cos(3.083), 1e-15);
  EXPECT_NEAR(weld.X_PF.linear()(0, 1), std::sin(3.083), 1e-15);
  EXPECT_NEAR(weld.X_PF.linear()(0, 2), 0.0, 1e-15);
  EXPECT_NEAR(weld.X_PF.linear()(2, 2), std::cos(3.083), 1e-15);  // Rx(a)Rz(b): R22 = cos a

  // patfem_flexion_con: patfem_flexion = 1 * (knee_flexion + 1.57).
  const CoordinateCoupler& pc = m->couplers[0];
  EXPECT_EQ(pc.name, "patfem_flexion_con");
  EXPECT_EQ(m->coordinates[pc.dependent].name, "patfem_flexion");
  EXPECT_EQ(m->coordinates[pc.independents[0]].name, "knee_flexion");
  EXPECT_DOUBLE_EQ(pc.function->calcValue(-1.0), 0.57);

  // Markers are named with dots; the tibial tray's mesh is referenced but not shipped.
  EXPECT_GE(m->findMarker("R.Thigh.Superior"), 0);
  EXPECT_EQ(body(*m, "tibial_tray").meshes.at(0).file, "tibial_tray.vtp");
}

// ---------------------------------------------------------------------------------- fixtures

TEST(OsimReader, Chain40000FramesAxesAndIgnoredComponents) {
  const ModelPtr m = readOsim(fixturePath("fixtures/chain40000.osim"));
  EXPECT_EQ(m->format_version, 40000);
  ASSERT_EQ(m->bodies.size(), 6u);
  ASSERT_EQ(m->joints.size(), 5u);
  ASSERT_EQ(m->coordinates.size(), 9u);
  EXPECT_EQ(m->markers.size(), 6u);
  EXPECT_EQ(m->muscles.size(), 1u);
  EXPECT_EQ(m->wrap_objects.size(), 1u);
  EXPECT_EQ(countIgnored(*m, "ContactHalfSpace"), 1);

  const double h = M_PI / 2;
  const Joint& pin = joint(*m, "pin");
  EXPECT_EQ(pin.type, JointType::Pin);
  EXPECT_EQ(pin.parent_body, 0);
  EXPECT_TRUE(pin.X_PF.translation().isApprox(Vec3(0, 1, 0)));
  Mat3 Rx90;
  Rx90 << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  EXPECT_TRUE(pin.X_PF.linear().isApprox(Rx90, 1e-15));
  EXPECT_TRUE(pin.X_BM.translation().isApprox(Vec3(0.1, 0, 0)));
  EXPECT_EQ(coordinate(*m, "q_pin").motion_type, MotionType::Rotational);
  EXPECT_TRUE(coordinate(*m, "q_pin").clamped);

  const Joint& slider = joint(*m, "slider");
  EXPECT_EQ(slider.type, JointType::Slider);
  Mat3 Rz90;
  Rz90 << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  EXPECT_TRUE(slider.X_PF.linear().isApprox(Rz90, 1e-15));
  EXPECT_TRUE(slider.X_BM.isApprox(Pose::Identity()));  // child frame is the body itself
  EXPECT_EQ(coordinate(*m, "q_slide").motion_type, MotionType::Translational);

  const Joint& gimbal = joint(*m, "gimbal");
  EXPECT_EQ(gimbal.type, JointType::Gimbal);
  ASSERT_EQ(gimbal.coordinates.size(), 3u);
  EXPECT_EQ(m->coordinates[gimbal.coordinates[1]].name, "q_gy");
  EXPECT_EQ(coordinate(*m, "q_gy").range_min, -10.0);  // OpenSim's default range when none is given
  EXPECT_EQ(coordinate(*m, "q_gy").range_max, 10.0);
  EXPECT_FALSE(coordinate(*m, "q_gy").clamped);
  EXPECT_TRUE(gimbal.X_BM.translation().isApprox(Vec3(0, -0.1, 0)));
  EXPECT_EQ(joint(*m, "universal").coordinates.size(), 2u);  // <coordinates><objects> form

  const Joint& custom = joint(*m, "custom");
  ASSERT_EQ(custom.type, JointType::Custom);
  EXPECT_TRUE(custom.X_PF.translation().isApprox(Vec3(0, 0, 0.2)));
  EXPECT_TRUE(custom.X_BM.linear().isApprox(Rx90, 1e-15));
  EXPECT_EQ(custom.spatial[3].function->getTypeName(), "SimmSpline");
  EXPECT_NEAR(custom.spatial[3].function->calcValue(h), 0.1 * h * h, 1e-15);
  EXPECT_EQ(custom.spatial[4].function->calcValue(0.0), 0.2);
  EXPECT_EQ(coordinate(*m, "q_c_rot").motion_type, MotionType::Rotational);
  EXPECT_EQ(coordinate(*m, "q_c_tz").motion_type, MotionType::Translational);
  EXPECT_EQ(coordinate(*m, "q_c_tz").default_value, 0.02);

  ASSERT_EQ(m->couplers.size(), 1u);
  const CoordinateCoupler& cc = m->couplers[0];
  EXPECT_EQ(m->coordinates[cc.dependent].name, "q_c_tz");
  EXPECT_EQ(cc.scale_factor, 2.0);
  EXPECT_DOUBLE_EQ(cc.scale_factor * cc.function->calcValue(0.3), 0.32);

  // mA2 sits on an offset frame; it is stored in A's frame: (0,0,0.1) + Rz90 (0.1,0,0).
  const Marker& mA2 = m->markers[m->findMarker("mA2")];
  EXPECT_EQ(m->bodies[mA2.body].name, "A");
  EXPECT_TRUE(mA2.p_BM.isApprox(Vec3(0, 0.1, 0.1), 1e-15));
  EXPECT_TRUE(mA2.fixed);

  // box.stl is found through the Geometry/ fallback; the floor mesh is missing: a warning.
  const Body& A = body(*m, "A");
  ASSERT_EQ(A.meshes.size(), 1u);
  EXPECT_NE(A.meshes[0].resolved_path.find("fixtures/Geometry/box.stl"), std::string::npos);
  EXPECT_EQ(A.meshes[0].scale, Vec3(1, 2, 3));
  ASSERT_EQ(m->bodies[0].meshes.size(), 1u);
  EXPECT_EQ(m->bodies[0].meshes[0].resolved_path, "");
  ASSERT_EQ(m->warnings.size(), 1u);
  EXPECT_NE(m->warnings[0].find("missing_floor.vtp"), std::string::npos);

  // Inertia <inertia> is xx yy zz xy xz yz.
  EXPECT_EQ(A.inertia(0, 1), 0.001);
  EXPECT_EQ(A.inertia(2, 1), 0.003);
}

// The hand-derived ground positions of fixtures/README.md, through an Eigen forward kinematics.
TEST(OsimReader, Chain40000MatchesHandDerivedMarkerPositions) {
  const ModelPtr m = readOsim(fixturePath("fixtures/chain40000.osim"));
  const double h = M_PI / 2, f = 0.24674011002723395;
  const auto qz = test::coordinateValues(*m, {{"q_c_tz", 0.02}});
  const std::map<std::string, Vec3> zero = {{"mA", {0, 1, 0.2}},   {"mA2", {-0.1, 0.9, 0.1}}, {"mB", {0.1, 0.9, 0}},
                                            {"mC", {-0.3, 1, 0.1}}, {"mD", {-0.4, 1, 0.1}},   {"mE", {-0.4, 0.88, -0.1}}};
  for (const auto& kv : zero)
    EXPECT_TRUE(test::markerInGround(*m, qz, kv.first).isApprox(kv.second, 1e-12))
        << kv.first << ": " << test::markerInGround(*m, qz, kv.first).transpose();
  const auto qp = test::coordinateValues(*m, {{"q_pin", h}, {"q_slide", 0.3}, {"q_gx", h}, {"q_gy", M_PI},
                                              {"q_gz", h}, {"q_ux", h}, {"q_uy", h}, {"q_c_rot", h},
                                              {"q_c_tz", 0.32}});
  const std::map<std::string, Vec3> posed = {{"mA", {-0.2, 1, 0}},     {"mA2", {-0.1, 0.9, -0.1}},
                                             {"mB", {-0.3, 0.9, 0.1}}, {"mC", {-0.4, 0.9, -0.2}},
                                             {"mD", {-0.4, 0.9, -0.3}}, {"mE", {-0.1, 0.48, -0.2 - f}}};
  for (const auto& kv : posed)
    EXPECT_LT((test::markerInGround(*m, qp, kv.first) - kv.second).norm(), 1e-12)
        << kv.first << ": " << test::markerInGround(*m, qp, kv.first).transpose();
}

TEST(OsimReader, Reverse30000MatchesHandDerivedMarkerPositions) {
  const ModelPtr m = readOsim(fixturePath("fixtures/reverse30000.osim"));
  EXPECT_TRUE(joint(*m, "rev").reverse);
  EXPECT_EQ(body(*m, "P").inertia(0, 2), 0.02);
  EXPECT_EQ(body(*m, "P").inertia(2, 1), 0.03);
  const auto q0 = test::coordinateValues(*m, {{"q_rev", 0.0}});
  const auto q1 = test::coordinateValues(*m, {{"q_rev", M_PI / 2}});
  EXPECT_LT((test::markerInGround(*m, q0, "mP") - Vec3(-0.2, 0.6, 0)).norm(), 1e-12);
  EXPECT_LT((test::markerInGround(*m, q0, "mQ") - Vec3(-0.3, 0.6, 0)).norm(), 1e-12);
  EXPECT_LT((test::markerInGround(*m, q1, "mP") - Vec3(0.1, 0.7, 0)).norm(), 1e-12);
  EXPECT_LT((test::markerInGround(*m, q1, "mQ") - Vec3(0.1, 0.8, 0)).norm(), 1e-12);
}

// ---------------------------------------------------------------------------------- bad input

/// A minimal 4.x model with one body on a joint given by @p joint, so a test can break one thing.
std::string model4(const std::string& joint, const std::string& extra = "") {
  return "<?xml version=\"1.0\"?>\n"
         "<OpenSimDocument Version=\"40000\">\n"
         "<Model name=\"m\">\n"
         "<BodySet><objects>\n"
         "<Body name=\"b\"><mass>1</mass><mass_center>0 0 0</mass_center><inertia>1 1 1 0 0 0</inertia></Body>\n"
         "</objects></BodySet>\n"
         "<JointSet><objects>\n" +
         joint +
         "</objects></JointSet>\n" + extra +
         "</Model>\n"
         "</OpenSimDocument>\n";
}

const char* const kPin =
    "<PinJoint name=\"j\"><socket_parent_frame>/ground</socket_parent_frame>"
    "<socket_child_frame>/bodyset/b</socket_child_frame>"
    "<coordinates><Coordinate name=\"q\"/></coordinates></PinJoint>\n";

/// Parses @p text and returns the one-line InputError message ("" if it parsed).
std::string errorOf(const std::string& text) {
  try {
    parseOsim(text, "bad.osim");
  } catch (const InputError& e) {
    const std::string w = e.what();
    EXPECT_EQ(w.find('\n'), std::string::npos);
    return w;
  }
  return "";
}

TEST(OsimReader, GoodMinimalModelParses) {
  const ModelPtr m = parseOsim(model4(kPin), "ok.osim");
  EXPECT_EQ(m->joints.size(), 1u);
  EXPECT_EQ(m->coordinates[0].name, "q");
}

TEST(OsimReader, MalformedXml) {
  const std::string e = errorOf("<OpenSimDocument Version=\"40000\">\n<Model name=\"m\">\n<BodySet>\n</Model>\n");
  EXPECT_TRUE(std::regex_search(e, std::regex("^bad\\.osim:[0-9]+: malformed XML"))) << e;
}

// Found by fuzzing (fuzz/, docs/fuzzing.md): a Version attribute of +infinity (or 1e10, -1) was
// converted to an int, undefined behaviour (UBSan on the fuzzer's input,
// fixtures/fuzz/osim/version-infinity.osim).
TEST(OsimReaderFuzz, AVersionNoIntegerHoldsIsAOneLineError) {
  const std::string path = test::fixturePath("fixtures/fuzz/osim/version-infinity.osim");
  try {
    readOsim(path);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ":3: OpenSimDocument: expected a numeric Version attribute, got '+infinity'");
  }
  std::string text = model4(kPin);
  for (const std::string v : {"1e10", "-1", "nan"}) {
    std::string bad = text;
    bad.replace(bad.find("40000"), 5, v);
    EXPECT_EQ(errorOf(bad), "bad.osim:2: OpenSimDocument: expected a numeric Version attribute, got '" + v + "'");
  }
}

// OpenSim 1.x's layout (opensim-core's DynamicsEngines/TestSimbodyEngine/pendulum2.osim): a bare
// <Model> whose bodies and joints sit in <DynamicsEngine><SimbodyEngine>. One line naming it.
TEST(OsimReader, DynamicsEngineLayoutOfOpenSim1IsNamed) {
  const std::string e = errorOf(
      "<?xml version=\"1.0\"?>\n<Model name=\"\">\n<DynamicsEngine>\n<SimbodyEngine>\n<BodySet><objects>"
      "<SimbodyBody name=\"ground\"/></objects></BodySet>\n</SimbodyEngine>\n</DynamicsEngine>\n</Model>\n");
  EXPECT_NE(e.find("bad.osim:3: Model/DynamicsEngine: expected the BodySet of a model of format 10901 or later, got "
                   "OpenSim 1.x's <DynamicsEngine> layout (format 10500), which kneesim does not read"),
            std::string::npos)
      << e;
}

// OpenSim 1.6's layout (format 10600, as opensim-core's Tools/Test/snowboard10600.osim): 4.x-era
// Bodies with nested joints, a MarkerSet and gravity inside <DynamicsEngine><SimbodyEngine>, the
// actuators in an <ActuatorSet>. OpenSim 4 moves the SimbodyEngine's children into the model and
// reads the ActuatorSet as the ForceSet; so does kneesim.
TEST(OsimReader, DynamicsEngineOfFormat10600IsUnwrapped) {
  const std::string text =
      "<?xml version=\"1.0\"?>\n<OpenSimDocument Version=\"10600\">\n<Model name=\"m\">\n"
      "<ActuatorSet name=\"\"><objects><CoordinateActuator name=\"tau\"><coordinate> q </coordinate>"
      "<optimal_force> 2 </optimal_force></CoordinateActuator></objects></ActuatorSet>\n"
      "<DynamicsEngine>\n<SimbodyEngine name=\"default\">\n<gravity> 0 -9.5 0 </gravity>\n"
      "<BodySet name=\"\"><objects>\n"
      "<Body name=\"ground\"><mass> 0 </mass><Joint/></Body>\n"
      "<Body name=\"b\"><WrapObjectSet name=\"\"><objects/><groups/></WrapObjectSet><mass> 2 </mass>"
      "<mass_center> 0 -0.5 0 </mass_center><inertia_xx> 0.1 </inertia_xx><inertia_yy> 0.1 </inertia_yy>"
      "<inertia_zz> 0.1 </inertia_zz>\n<Joint><CustomJoint name=\"j\"><parent_body> ground </parent_body>"
      "<location_in_parent> 0 1 0 </location_in_parent><orientation_in_parent> 0 0 0 </orientation_in_parent>"
      "<location> 0 0.5 0 </location><orientation> 0 0 0 </orientation>\n"
      "<CoordinateSet name=\"\"><objects><Coordinate name=\"q\"><default_value> 0 </default_value>"
      "<tolerance> 1e-8 </tolerance><stiffness> 0 </stiffness><range> -1 1 </range><keys> q_key </keys>"
      "<clamped> true </clamped><locked> false </locked><restraint_function/><min_restraint_function/>"
      "<max_restraint_function/><restraint_active> false </restraint_active><prescribed_function/>"
      "</Coordinate></objects><groups/></CoordinateSet>\n"
      "<TransformAxisSet name=\"\"><objects><TransformAxis name=\"r1\"><function/><coordinate> q </coordinate>"
      "<is_rotation> true </is_rotation><axis> 0 0 1 </axis></TransformAxis></objects><groups/></TransformAxisSet>"
      "</CustomJoint></Joint></Body>\n"
      "</objects><groups/></BodySet>\n"
      "<MarkerSet name=\"\"><objects><Marker name=\"tip\"><body> b </body><location> 0 -0.5 0 </location>"
      "</Marker></objects><groups/></MarkerSet>\n"
      "</SimbodyEngine>\n</DynamicsEngine>\n</Model>\n</OpenSimDocument>\n";
  const ModelPtr m = parseOsim(text, "snow.osim");
  EXPECT_EQ(m->format_version, 10600);
  EXPECT_EQ(m->gravity, Vec3(0, -9.5, 0));
  ASSERT_EQ(m->bodies.size(), 2u);
  EXPECT_EQ(body(*m, "b").mass, 2.0);
  ASSERT_EQ(m->coordinates.size(), 1u);
  EXPECT_EQ(m->coordinates[0].range_min, -1.0);
  ASSERT_EQ(m->markers.size(), 1u);
  // Rotation q about z at (0, 1, 0) in ground; the body's origin 0.5 above its joint frame, the
  // tip 0.5 below its origin: tip = (0, 1, 0) + Rz(q) (0, -1, 0) = (sin q, 1 - cos q, 0).
  const double q = 0.3;
  EXPECT_TRUE(test::markerInGround(*m, test::coordinateValues(*m, {{"q", q}}), "tip")
                  .isApprox(Vec3(std::sin(q), 1 - std::cos(q), 0), 1e-14));
  // The ActuatorSet was read as the ForceSet: the actuator is simulated, not listed as ignored.
  EXPECT_EQ(m->actuators.size(), 1u);
  EXPECT_EQ(countIgnored(*m, "ActuatorSet"), 0);
}

// The real 10600 file (tests/model/corpus/snowboard_10600.osim, from opensim-core): everything in
// its SimbodyEngine is read, and its two joints named mtp_l are told apart as OpenSim does.
TEST(OsimReader, Snowboard10600) {
  const ModelPtr m = readOsim(test::sourcePath("tests/model/corpus/snowboard_10600.osim"));
  EXPECT_EQ(m->format_version, 10600);
  EXPECT_EQ(m->gravity, Vec3(0, -9.80664999999999940000, 0));
  EXPECT_EQ(m->bodies.size(), 10u);  // ground + board, tibiae, tali, calcanei, toes
  EXPECT_EQ(m->coordinates.size(), 18u);
  EXPECT_EQ(m->markers.size(), 24u);
  // calcn_r: mass 1.25, mass_center 0.1 0.03 0; ankle_r's axis -0.10501355 -0.17402245 0.97912632.
  EXPECT_EQ(body(*m, "calcn_r").mass, 1.25);
  EXPECT_EQ(body(*m, "toes_l").mass, 0.2166);
  EXPECT_EQ(m->bodies[joint(*m, "mtp_l_0").child_body].name, "toes_l");
  EXPECT_EQ(m->coordinates[m->findCoordinate("mtp_l_0/mtp_angle_l")].joint, m->findJoint("mtp_l_0"));
}

TEST(OsimReader, UnknownJointType) {
  std::string j = kPin;
  j.replace(j.find("PinJoint"), 8, "FooJoint");
  j.replace(j.rfind("PinJoint"), 8, "FooJoint");
  const std::string e = errorOf(model4(j));
  EXPECT_NE(e.find("bad.osim:8: "), std::string::npos) << e;
  EXPECT_NE(e.find("FooJoint[j]: unknown joint type 'FooJoint' (expected WeldJoint, PinJoint"), std::string::npos) << e;
}

TEST(OsimReader, UnknownFunctionType) {
  const std::string custom =
      "<CustomJoint name=\"j\"><socket_parent_frame>/ground</socket_parent_frame>\n"
      "<socket_child_frame>/bodyset/b</socket_child_frame>\n"
      "<coordinates><Coordinate name=\"q\"/></coordinates>\n"
      "<SpatialTransform>\n"
      "<TransformAxis name=\"rotation1\"><coordinates>q</coordinates><axis>0 0 1</axis>\n"
      "<GCVSpline name=\"function\"><x>0 1</x><y>0 1</y></GCVSpline></TransformAxis>\n"
      "<TransformAxis name=\"rotation2\"><axis>1 0 0</axis></TransformAxis>\n"
      "<TransformAxis name=\"rotation3\"><axis>0 1 0</axis></TransformAxis>\n"
      "<TransformAxis name=\"translation1\"><axis>1 0 0</axis></TransformAxis>\n"
      "<TransformAxis name=\"translation2\"><axis>0 1 0</axis></TransformAxis>\n"
      "<TransformAxis name=\"translation3\"><axis>0 0 1</axis></TransformAxis>\n"
      "</SpatialTransform></CustomJoint>\n";
  const std::string e = errorOf(model4(custom));
  EXPECT_NE(e.find("bad.osim:13: "), std::string::npos) << e;
  EXPECT_NE(e.find("GCVSpline[function]: unknown function type 'GCVSpline' (expected Constant"), std::string::npos) << e;

  // The same model with a known function parses, and a transform axis naming a coordinate the
  // joint does not have is an error on that axis's <coordinates>.
  std::string good = custom;
  good.replace(good.find("GCVSpline"), 9, "SimmSpline");
  good.replace(good.find("GCVSpline"), 9, "SimmSpline");
  EXPECT_NO_THROW(parseOsim(model4(good), "ok.osim"));
  std::string missing = good;
  missing.replace(missing.find("<coordinates>q</coordinates>"), 28, "<coordinates>qq</coordinates>");
  const std::string e2 = errorOf(model4(missing));
  EXPECT_NE(e2.find("bad.osim:12: "), std::string::npos) << e2;
  EXPECT_NE(e2.find("unknown coordinate 'qq' (expected one of the joint's coordinates: q)"), std::string::npos) << e2;
}

TEST(OsimReader, JointNamingAMissingParentBody) {
  const std::string v3 =
      "<OpenSimDocument Version=\"30000\"><Model name=\"m\"><BodySet><objects>\n"
      "<Body name=\"ground\"><Joint/></Body>\n"
      "<Body name=\"b\"><mass>1</mass><Joint><WeldJoint name=\"w\">\n"
      "<parent_body>femur</parent_body>\n"
      "</WeldJoint></Joint></Body>\n"
      "</objects></BodySet></Model></OpenSimDocument>\n";
  const std::string e = errorOf(v3);
  EXPECT_NE(e.find("bad.osim:4: "), std::string::npos) << e;
  EXPECT_NE(e.find("parent_body: unknown parent body 'femur' (expected one of ground, b)"), std::string::npos) << e;

  std::string v4 = kPin;
  v4.replace(v4.find("/ground"), 7, "/bodyset/femur");
  const std::string e4 = errorOf(model4(v4));
  EXPECT_NE(e4.find("bad.osim:8: "), std::string::npos) << e4;
  EXPECT_NE(e4.find("unknown frame '/bodyset/femur'"), std::string::npos) << e4;
}

TEST(OsimReader, NonNumericValues) {
  std::string text = model4(kPin);
  text.replace(text.find("<mass>1</mass>"), 14, "<mass>heavy</mass>");
  const std::string e = errorOf(text);
  EXPECT_NE(e.find("bad.osim:5: "), std::string::npos) << e;
  EXPECT_NE(e.find("Body[b]/mass: expected a number, got 'heavy'"), std::string::npos) << e;

  const std::string range = model4(
      "<PinJoint name=\"j\"><socket_parent_frame>/ground</socket_parent_frame>"
      "<socket_child_frame>/bodyset/b</socket_child_frame>"
      "<coordinates><Coordinate name=\"q\"><range>-1 one</range></Coordinate></coordinates></PinJoint>\n");
  EXPECT_NE(errorOf(range).find("range: expected a number, got 'one'"), std::string::npos) << errorOf(range);
}

TEST(OsimReader, OtherStructuralErrors) {
  // Wrong number of coordinates for a native joint.
  std::string two = kPin;
  two.replace(two.find("<Coordinate name=\"q\"/>"), 22, "<Coordinate name=\"q\"/><Coordinate name=\"r\"/>");
  EXPECT_NE(errorOf(model4(two)).find("expected 1 coordinates for a PinJoint, got 2"), std::string::npos);
  // A body left out of the tree.
  const std::string orphan = model4(
      kPin, "");
  std::string text = orphan;
  text.replace(text.find("</objects></BodySet>"), 0, "<Body name=\"lost\"><mass>1</mass></Body>\n");
  EXPECT_NE(errorOf(text).find("expected a joint connecting body 'lost' to the tree"), std::string::npos) << errorOf(text);
  // Two joints with the same child body (a closed loop).
  std::string loop = kPin;
  loop += "<WeldJoint name=\"w\"><socket_parent_frame>/ground</socket_parent_frame>"
          "<socket_child_frame>/bodyset/b</socket_child_frame></WeldJoint>\n";
  const std::string e_loop = errorOf(model4(loop));
  EXPECT_NE(e_loop.find("bad.osim:9: "), std::string::npos) << e_loop;
  EXPECT_NE(e_loop.find("body 'b' is already the child of joint 'j'"), std::string::npos) << e_loop;
  // A coupler naming an unknown coordinate.
  const std::string coupler = model4(kPin,
                                     "<ConstraintSet><objects><CoordinateCouplerConstraint name=\"c\">"
                                     "<coupled_coordinates_function><LinearFunction><coefficients>1 0</coefficients>"
                                     "</LinearFunction></coupled_coordinates_function>"
                                     "<independent_coordinate_names>q</independent_coordinate_names>"
                                     "<dependent_coordinate_name>nope</dependent_coordinate_name>"
                                     "</CoordinateCouplerConstraint></objects></ConstraintSet>\n");
  EXPECT_NE(errorOf(coupler).find("unknown coordinate 'nope'"), std::string::npos) << errorOf(coupler);
  // Spline knots out of order, in a transform axis.
  const std::string knots = model4(
      "<CustomJoint name=\"j\"><socket_parent_frame>/ground</socket_parent_frame>\n"
      "<socket_child_frame>/bodyset/b</socket_child_frame>\n"
      "<SpatialTransform>\n"
      "<TransformAxis name=\"rotation1\"><coordinates>q</coordinates><axis>0 0 1</axis>\n"
      "<SimmSpline name=\"function\"><x>0 1 0.5</x><y>0 1 2</y></SimmSpline></TransformAxis>\n"
      "<TransformAxis name=\"rotation2\"><axis>1 0 0</axis></TransformAxis>\n"
      "<TransformAxis name=\"rotation3\"><axis>0 1 0</axis></TransformAxis>\n"
      "<TransformAxis name=\"translation1\"><axis>1 0 0</axis></TransformAxis>\n"
      "<TransformAxis name=\"translation2\"><axis>0 1 0</axis></TransformAxis>\n"
      "<TransformAxis name=\"translation3\"><axis>0 0 1</axis></TransformAxis>\n"
      "</SpatialTransform></CustomJoint>\n");
  EXPECT_NE(errorOf(knots).find("bad.osim:12: "), std::string::npos) << errorOf(knots);
  EXPECT_NE(errorOf(knots).find("expected strictly increasing x, got 1 then 0.5 at knot 2"), std::string::npos)
      << errorOf(knots);
  // Collinear rotation axes, as OpenSim refuses them.
  std::string collinear = knots;
  collinear.replace(collinear.find("<x>0 1 0.5</x>"), 14, "<x>0 1 1.5</x>");
  collinear.replace(collinear.find("<axis>0 1 0</axis>"), 18, "<axis>0 0 2</axis>");
  EXPECT_NE(errorOf(collinear).find("'rotation3' is collinear with 'rotation1'"), std::string::npos)
      << errorOf(collinear);
  // A coupler whose dependent is also its independent.
  const std::string self = model4(kPin,
                                  "<ConstraintSet><objects><CoordinateCouplerConstraint name=\"c\">"
                                  "<coupled_coordinates_function><LinearFunction><coefficients>1 0</coefficients>"
                                  "</LinearFunction></coupled_coordinates_function>"
                                  "<independent_coordinate_names>q</independent_coordinate_names>"
                                  "<dependent_coordinate_name>q</dependent_coordinate_name>"
                                  "</CoordinateCouplerConstraint></objects></ConstraintSet>\n");
  EXPECT_NE(errorOf(self).find("expected the dependent coordinate to differ"), std::string::npos) << errorOf(self);
  // A missing file.
  EXPECT_THROW(readOsim("/nonexistent/model.osim"), InputError);
  // Not an OpenSim document at all.
  EXPECT_NE(errorOf("<robot name=\"r\"/>").find("expected an OpenSim model"), std::string::npos);
}

}  // namespace
}  // namespace kneesim::model
