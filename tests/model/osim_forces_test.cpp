// The force reader: wrap objects, muscles with their paths and parameters, coordinate actuators,
// actuator set files, and one-line errors for bad force elements.
#include "model/osim_forces.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "model/osim_reader.hpp"
#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim::model {
namespace {

using test::inputErrorOf;

// ground -Pin(q)-> arm, format 30000; @p forces goes inside <ForceSet><objects>.
std::string modelText(const std::string& forces, const std::string& wraps = "") {
  return R"(<?xml version="1.0" encoding="UTF-8" ?>
<OpenSimDocument Version="30000">
<Model name="m">
<BodySet><objects>
<Body name="ground"><mass>0</mass></Body>
<Body name="arm"><mass>1</mass><mass_center>0 -0.1 0</mass_center><inertia_xx>0.01</inertia_xx>
<inertia_yy>0.01</inertia_yy><inertia_zz>0.01</inertia_zz>
<Joint><PinJoint name="elbow"><parent_body>ground</parent_body><location_in_parent>0 1 0</location_in_parent>
<CoordinateSet><objects><Coordinate name="q"><default_value>0</default_value></Coordinate></objects></CoordinateSet>
</PinJoint></Joint>
<WrapObjectSet><objects>
<WrapCylinder name="cyl"><xyz_body_rotation>0 0 1.5707963267948966</xyz_body_rotation>
<translation>0 -0.05 0</translation><quadrant>-y</quadrant><radius>0.02</radius><length>0.1</length></WrapCylinder>
<WrapEllipsoid name="ell"><dimensions>0.03 0.02 0.01</dimensions><active>false</active></WrapEllipsoid>
)" + wraps + R"(
</objects></WrapObjectSet>
</Body>
</objects></BodySet>
<ForceSet><objects>
)" + forces + R"(
</objects></ForceSet>
</Model>
</OpenSimDocument>
)";
}

const char* const kThelen = R"(
<Thelen2003Muscle name="flexor">
  <GeometryPath><PathPointSet><objects>
    <PathPoint name="p1"><location>0 0.8 0</location><body>ground</body></PathPoint>
    <ConditionalPathPoint name="p2"><location>0.01 -0.02 0</location><body>arm</body>
      <range>-0.5 1.2</range><coordinate>q</coordinate></ConditionalPathPoint>
    <MovingPathPoint name="p3"><location>0 0 0</location><body>arm</body>
      <x_location><SimmSpline><x>-1 0 1</x><y>0.01 0.02 0.03</y></SimmSpline></x_location>
      <x_coordinate>q</x_coordinate>
      <y_location><Constant><value>-0.2</value></Constant></y_location>
      <y_coordinate>q</y_coordinate>
    </MovingPathPoint>
  </objects></PathPointSet>
  <PathWrapSet><objects>
    <PathWrap><wrap_object>cyl</wrap_object><method>midpoint</method><range>1 2</range></PathWrap>
  </objects></PathWrapSet></GeometryPath>
  <max_isometric_force>800</max_isometric_force><optimal_fiber_length>0.12</optimal_fiber_length>
  <tendon_slack_length>0.2</tendon_slack_length><pennation_angle_at_optimal>0.1</pennation_angle_at_optimal>
  <FmaxTendonStrain>0.04</FmaxTendonStrain><ignore_tendon_compliance>true</ignore_tendon_compliance>
</Thelen2003Muscle>
<CoordinateActuator name="q_reserve"><coordinate>q</coordinate><optimal_force>10</optimal_force>
  <min_control>-2</min_control><max_control>3</max_control></CoordinateActuator>
<PointActuator name="push"><body>arm</body></PointActuator>
<Ligament name="lig"><isDisabled>true</isDisabled></Ligament>
)";

TEST(OsimForces, ReadsMusclesWrapObjectsAndActuators) {
  const ModelPtr m = parseOsim(modelText(kThelen), "/tmp/m.osim");
  ASSERT_EQ(m->wrap_objects.size(), 2u);
  const WrapObject& cyl = m->wrap_objects[0];
  EXPECT_EQ(cyl.shape, WrapShape::Cylinder);
  EXPECT_EQ(cyl.body, 1);
  EXPECT_EQ(cyl.dimensions.x(), 0.02);
  EXPECT_EQ(cyl.dimensions.y(), 0.1);
  EXPECT_EQ(cyl.quadrant_axis, 1);
  EXPECT_EQ(cyl.quadrant_sign, -1);
  // xyz_body_rotation (0, 0, pi/2): the wrap frame's x axis is the body's y axis.
  EXPECT_TRUE(cyl.X_BW.linear().col(0).isApprox(Vec3(0, 1, 0), 1e-15));
  EXPECT_TRUE(cyl.X_BW.translation().isApprox(Vec3(0, -0.05, 0)));
  EXPECT_FALSE(m->wrap_objects[1].active);
  EXPECT_EQ(m->wrap_objects[1].dimensions, Vec3(0.03, 0.02, 0.01));

  ASSERT_EQ(m->muscles.size(), 1u);
  const Muscle& mu = m->muscles[0];
  EXPECT_EQ(mu.type, "Thelen2003Muscle");
  EXPECT_TRUE(mu.enabled);
  EXPECT_EQ(mu.max_isometric_force, 800);
  EXPECT_EQ(mu.optimal_fiber_length, 0.12);
  EXPECT_EQ(mu.tendon_slack_length, 0.2);
  EXPECT_EQ(mu.pennation_angle_at_optimal, 0.1);
  EXPECT_EQ(mu.max_contraction_velocity, 10);  // OpenSim's default
  EXPECT_EQ(mu.parameters.at("FmaxTendonStrain"), 0.04);
  EXPECT_EQ(mu.parameters.at("ignore_tendon_compliance"), 1.0);
  ASSERT_EQ(mu.path.points.size(), 3u);
  EXPECT_EQ(mu.path.points[0].body, 0);
  EXPECT_EQ(mu.path.points[1].type, PathPointType::Conditional);
  EXPECT_EQ(mu.path.points[1].coordinate, 0);
  EXPECT_EQ(mu.path.points[1].range_max, 1.2);
  const PathPoint& moving = mu.path.points[2];
  EXPECT_EQ(moving.type, PathPointType::Moving);
  ASSERT_TRUE(moving.location_functions[0] && moving.location_functions[1]);
  EXPECT_FALSE(moving.location_functions[2]);
  EXPECT_NEAR(moving.location_functions[0]->calcValue(0.5), 0.025, 1e-12);
  EXPECT_EQ(moving.location_coordinates[1], 0);
  EXPECT_EQ(moving.location_coordinates[2], -1);
  ASSERT_EQ(mu.path.wraps.size(), 1u);
  EXPECT_EQ(mu.path.wraps[0].wrap_object, 0);
  EXPECT_EQ(mu.path.wraps[0].method, WrapMethod::Midpoint);
  EXPECT_EQ(mu.path.wraps[0].range_begin, 1);
  EXPECT_EQ(mu.path.wraps[0].range_end, 2);

  ASSERT_EQ(m->actuators.size(), 1u);
  EXPECT_EQ(m->actuators[0].coordinate, 0);
  EXPECT_EQ(m->actuators[0].optimal_force, 10);
  EXPECT_EQ(m->actuators[0].min_control, -2);
  EXPECT_EQ(m->actuators[0].max_control, 3);
  auto ignored = [&](const std::string& type) {
    return std::count_if(m->ignored.begin(), m->ignored.end(), [&](const IgnoredComponent& c) { return c.type == type; });
  };
  EXPECT_EQ(ignored("PointActuator"), 1);
  EXPECT_EQ(ignored("Ligament (disabled)"), 1);
  EXPECT_EQ(m->findMuscle("flexor"), 0);
}

// A PathWrap range beyond any int (1e10, inf, nan) was converted to one: undefined behaviour, seen
// by UBSan the way fuzz_osim saw the Version attribute's (fixtures/fuzz/osim/wrap-range-1e10.osim
// holds this model for the fuzz target's replay).
TEST(OsimForcesFuzz, WrapRangesNoIntegerHoldsAreOneLineErrors) {
  for (const std::string range : {"1 1e10", "-inf 2", "nan 1"}) {
    std::string text = modelText(kThelen);
    text.replace(text.find("<range>1 2</range>"), 18, "<range>" + range + "</range>");
    EXPECT_NE(inputErrorOf([&] { parseOsim(text, "/tmp/bad.osim"); })
                  .find("PathWrap/range: expected two point numbers (first last), got '" + range + "'"),
              std::string::npos)
        << range;
  }
  const std::string path = test::fixturePath("fixtures/fuzz/osim/wrap-range-1e10.osim");
  EXPECT_NE(inputErrorOf([&] { readOsim(path); }).find("expected two point numbers (first last), got '1 1e10'"),
            std::string::npos);
}

TEST(OsimForces, SchutteCurvesAreKeptByName) {
  const std::string schutte = R"(
<Schutte1993Muscle_Deprecated name="s"><isDisabled>true</isDisabled>
  <GeometryPath><PathPointSet><objects>
    <PathPoint name="a"><location>0 0.8 0</location><body>ground</body></PathPoint>
    <PathPoint name="b"><location>0 -0.2 0</location><body>arm</body></PathPoint>
  </objects></PathPointSet></GeometryPath>
  <damping>0.1</damping>
  <SimmSpline name="active_force_length_curve"><x>0 1 2</x><y>0 1 0</y></SimmSpline>
</Schutte1993Muscle_Deprecated>)";
  const ModelPtr m = parseOsim(modelText(schutte), "/tmp/m.osim");
  ASSERT_EQ(m->muscles.size(), 1u);
  EXPECT_FALSE(m->muscles[0].enabled);
  EXPECT_EQ(m->muscles[0].parameters.at("damping"), 0.1);
  ASSERT_TRUE(m->muscles[0].functions.count("active_force_length_curve"));
  EXPECT_NEAR(m->muscles[0].functions.at("active_force_length_curve")->calcValue(1.0), 1.0, 1e-12);
}

TEST(OsimForces, Format40000SocketsNameFramesAndWrapObjects) {
  const ModelPtr m = readOsim(test::sourcePath("tests/model/fixtures/chain40000.osim"));
  ASSERT_EQ(m->muscles.size(), 1u);
  const GeometryPath& p = m->muscles[0].path;
  ASSERT_EQ(p.points.size(), 2u);
  EXPECT_EQ(m->bodies[p.points[0].body].name, "A");
  EXPECT_EQ(m->bodies[p.points[1].body].name, "E");
  ASSERT_EQ(p.wraps.size(), 1u);
  EXPECT_EQ(m->wrap_objects[p.wraps[0].wrap_object].name, "B_wrap");
  EXPECT_EQ(m->bodies[m->wrap_objects[0].body].name, "B");
}

TEST(OsimForces, BadForceElementsAreOneLineErrors) {
  auto error = [](const std::string& forces, const std::string& wraps = "") {
    return inputErrorOf([&] { parseOsim(modelText(forces, wraps), "/tmp/bad.osim"); });
  };
  const std::string head = R"(<Thelen2003Muscle name="m"><GeometryPath><PathPointSet><objects>
    <PathPoint name="a"><location>0 0.8 0</location><body>ground</body></PathPoint>)";
  const std::string b = R"(<PathPoint name="b"><location>0 -0.2 0</location><body>arm</body></PathPoint>)";
  const std::string tail = "</objects></PathPointSet>";
  EXPECT_NE(error(head + b + tail + "<PathWrapSet><objects><PathWrap><wrap_object>nowhere</wrap_object></PathWrap>"
                  "</objects></PathWrapSet></GeometryPath></Thelen2003Muscle>")
                .find("unknown wrap object 'nowhere'"),
            std::string::npos);
  EXPECT_NE(error(head + R"(<PathPoint name="b"><location>0 0 0</location><body>leg</body></PathPoint>)" + tail +
                  "</GeometryPath></Thelen2003Muscle>")
                .find("unknown body 'leg'"),
            std::string::npos);
  const std::string one = error(head + tail + "</GeometryPath></Thelen2003Muscle>");
  EXPECT_NE(one.find("expected at least two path points that are always active, got 1"), std::string::npos) << one;
  EXPECT_NE(one.find("/tmp/bad.osim:"), std::string::npos) << one;
  EXPECT_NE(error(head + b + tail + "</GeometryPath><max_isometric_force>nan</max_isometric_force></Thelen2003Muscle>")
                .find("expected a finite non-negative number, got nan"),
            std::string::npos);
  EXPECT_NE(error("", R"(<WrapSphere name="s"><quadrant>w</quadrant><radius>0.1</radius></WrapSphere>)")
                .find("expected all, x, -x, y, -y, z or -z, got 'w'"),
            std::string::npos);
  EXPECT_NE(error("", R"(<WrapEllipsoid name="e"><dimensions>0.1 -0.1 0.1</dimensions></WrapEllipsoid>)")
                .find("expected three positive radii"),
            std::string::npos);
  EXPECT_NE(error(R"(<CoordinateActuator name="r"><coordinate>nope</coordinate></CoordinateActuator>)")
                .find("unknown coordinate 'nope'"),
            std::string::npos);
  // A muscle type kneesim does not evaluate is listed and kept out, not an error.
  const ModelPtr m = parseOsim(modelText("<RigidTendonMuscle name=\"r\"/>"), "/tmp/m.osim");
  EXPECT_TRUE(m->muscles.empty());
  ASSERT_EQ(m->ignored.size(), 1u);
  EXPECT_EQ(m->ignored[0].type, "RigidTendonMuscle");
}

// OpenSim writes an actuator's unbounded controls as -Inf and Inf (the Actuator default; the
// Matlab double_pendulum_markers model has them): read as kneesim's "no bound", +-1e30. NaN is bad.
TEST(OsimForces, InfiniteControlBoundsAreUnbounded) {
  std::string text = modelText(kThelen);
  const std::string bounds = "<min_control>-2</min_control><max_control>3</max_control>";
  ASSERT_NE(text.find(bounds), std::string::npos);
  text.replace(text.find(bounds), bounds.size(), "<min_control>-Inf</min_control><max_control>Inf</max_control>");
  const ModelPtr m = parseOsim(text, "/tmp/m.osim");
  ASSERT_EQ(m->actuators.size(), 1u);
  EXPECT_EQ(m->actuators[0].min_control, -1e30);
  EXPECT_EQ(m->actuators[0].max_control, 1e30);
  text.replace(text.find("<max_control>Inf"), 16, "<max_control>NaN");
  EXPECT_NE(inputErrorOf([&] { parseOsim(text, "/tmp/m.osim"); }).find("max_control: expected a number or +-Inf, got NaN"),
            std::string::npos);
}

TEST(OsimForces, ActuatorSetFileAppendsOrReplaces) {
  const ModelPtr m = parseOsim(modelText(kThelen), "/tmp/m.osim");
  const std::string dir = test::scratchDir("osim_forces_actuators");
  const std::string path = dir + "/actuators.xml";
  std::ofstream(path) << R"(<OpenSimDocument Version="30000"><ForceSet name="arm_reserves"><objects>
    <CoordinateActuator name="q_res"><coordinate>q</coordinate><optimal_force>1</optimal_force></CoordinateActuator>
    </objects></ForceSet></OpenSimDocument>)";
  const ModelPtr appended = readOsimActuatorSet(path, m, false);
  EXPECT_EQ(appended->muscles.size(), 1u);
  ASSERT_EQ(appended->actuators.size(), 2u);
  EXPECT_EQ(appended->actuators[1].name, "q_res");
  EXPECT_EQ(appended->actuators[1].min_control, -1e30);  // OpenSim's default: unbounded
  const ModelPtr replaced = readOsimActuatorSet(path, m, true);
  EXPECT_TRUE(replaced->muscles.empty());
  ASSERT_EQ(replaced->actuators.size(), 1u);
  std::ofstream(path) << "<ForceSet><objects><CoordinateActuator name=\"x\"><coordinate>z</coordinate>"
                         "</CoordinateActuator></objects></ForceSet>";
  EXPECT_NE(inputErrorOf([&] { readOsimActuatorSet(path, m, false); }).find("unknown coordinate 'z'"),
            std::string::npos);
}

}  // namespace
}  // namespace kneesim::model
