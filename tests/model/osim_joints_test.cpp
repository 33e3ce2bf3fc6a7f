// Joint forms OpenSim 4.x reads: unnamed joints, CustomJoints of formats 10500-10902 (a
// TransformAxisSet, a SpatialTransform of fewer than six axes), the 30501 <connectors> form with
// location_in_child, EllipsoidJoint and ScapulothoracicJoint; kinematics checked by hand.
#include <gtest/gtest.h>

#include <cmath>

#include "core/strings.hpp"
#include "model/kinematics.hpp"
#include "model/osim_reader.hpp"
#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim::model {
namespace {

using test::sourcePath;

/// A 3.x model (joints nested in bodies) with bodies "a" and "b" on the given joints.
std::string model3(const std::string& joint_a, const std::string& joint_b, int version = 20302) {
  auto body = [](const std::string& name, const std::string& joint) {
    return "<Body name=\"" + name + "\"><mass>1</mass><mass_center>0 0 0</mass_center>"
           "<inertia_xx>1</inertia_xx><inertia_yy>1</inertia_yy><inertia_zz>1</inertia_zz>"
           "<Joint>" + joint + "</Joint></Body>\n";
  };
  return "<OpenSimDocument Version=\"" + std::to_string(version) + "\"><Model name=\"m\"><BodySet><objects>\n"
         "<Body name=\"ground\"><Joint/></Body>\n" + body("a", joint_a) + body("b", joint_b) +
         "</objects></BodySet></Model></OpenSimDocument>\n";
}

// Test models of formats 10905 to 30000 leave joints unnamed; OpenSim reads them, so does kneesim,
// naming each after its type (then its child body when the type is taken) and saying so.
TEST(OsimJoints, UnnamedJointsAreNamed) {
  const std::string weld = "<WeldJoint><parent_body>ground</parent_body><location_in_parent>0 1 0</location_in_parent></WeldJoint>";
  const std::string pin = "<PinJoint><parent_body>a</parent_body><CoordinateSet><objects><Coordinate name=\"q\"/>"
                          "</objects></CoordinateSet></PinJoint>";
  const std::string weld_b = "<WeldJoint><parent_body>a</parent_body></WeldJoint>";
  ModelPtr m = parseOsim(model3(weld, pin, 30000), "unnamed.osim");
  ASSERT_EQ(m->joints.size(), 2u);
  EXPECT_EQ(m->joints[0].name, "weldjoint");
  EXPECT_EQ(m->joints[1].name, "pinjoint");
  EXPECT_EQ(m->joints[1].type, JointType::Pin);
  ASSERT_EQ(m->warnings.size(), 2u);
  EXPECT_EQ(m->warnings[0], "unnamed.osim:3: OpenSimDocument/Model[m]/BodySet/objects/Body[a]/Joint/WeldJoint: "
                            "<WeldJoint> of body 'a' has no name; it is called 'weldjoint'");
  m = parseOsim(model3(weld, weld_b, 30000), "unnamed.osim");
  EXPECT_EQ(m->joints[1].name, "b_weldjoint");
}

// OpenSim 4 tells coordinates apart by path (/jointset/J/q): two joints may each have a "q"
// (StationDefinedFrames_Advanced's FreeJoints both have rx..tz). The first keeps the name, the
// later one is called "J/q" with a warning; two "q" in one joint are an error, as in OpenSim.
TEST(OsimJoints, CoordinateNamesSharedByTwoJoints) {
  const std::string pin_a = "<PinJoint name=\"ja\"><parent_body>ground</parent_body><CoordinateSet><objects>"
                            "<Coordinate name=\"q\"><default_value>0.1</default_value></Coordinate>"
                            "</objects></CoordinateSet></PinJoint>";
  const std::string pin_b = "<PinJoint name=\"jb\"><parent_body>a</parent_body><CoordinateSet><objects>"
                            "<Coordinate name=\"q\"><default_value>0.2</default_value></Coordinate>"
                            "</objects></CoordinateSet></PinJoint>";
  ModelPtr m = parseOsim(model3(pin_a, pin_b), "shared.osim");
  ASSERT_EQ(m->coordinates.size(), 2u);
  EXPECT_EQ(m->coordinates[0].name, "q");
  EXPECT_EQ(m->coordinates[1].name, "jb/q");
  EXPECT_EQ(m->coordinates[1].default_value, 0.2);
  EXPECT_EQ(m->coordinates[m->findCoordinate("q")].default_value, 0.1);
  ASSERT_EQ(m->warnings.size(), 1u);
  EXPECT_NE(m->warnings[0].find("coordinate 'q' of joint 'jb' shares its name with another joint's; it is called 'jb/q'"),
            std::string::npos);
  const std::string ball = "<BallJoint name=\"jb\"><parent_body>a</parent_body><CoordinateSet><objects>"
                           "<Coordinate name=\"r\"/><Coordinate name=\"s\"/><Coordinate name=\"r\"/>"
                           "</objects></CoordinateSet></BallJoint>";
  EXPECT_NE(test::inputErrorOf([&] { parseOsim(model3(pin_a, ball), "dup.osim"); })
                .find("duplicate coordinate name 'r' in joint 'jb'"),
            std::string::npos);
}

// Format 10500's CustomJoint: a TransformAxisSet whose axes say is_rotation and name one
// coordinate; rotations go to rotation1.., translations to translation1.., in order.
TEST(OsimJoints, TransformAxisSetOfFormat10500) {
  const std::string custom =
      "<CustomJoint name=\"j\"><parent_body>ground</parent_body><location_in_parent>0 1 0</location_in_parent>"
      "<CoordinateSet><objects><Coordinate name=\"r\"/><Coordinate name=\"t\"/></objects></CoordinateSet>"
      "<TransformAxisSet><objects>"
      "<TransformAxis name=\"\"><function><LinearFunction><coefficients>1 0</coefficients></LinearFunction></function>"
      "<coordinate>t</coordinate><is_rotation>false</is_rotation><axis>0 0 1</axis></TransformAxis>"
      "<TransformAxis name=\"\"><function><LinearFunction><coefficients>1 0</coefficients></LinearFunction></function>"
      "<coordinate>r</coordinate><is_rotation>true</is_rotation><axis>1 0 0</axis></TransformAxis>"
      "</objects></TransformAxisSet></CustomJoint>";
  const std::string weld = "<WeldJoint name=\"w\"><parent_body>a</parent_body></WeldJoint>";
  const ModelPtr m = parseOsim(model3(custom, weld, 10500), "old.osim");
  const Joint& j = m->joints[m->findJoint("j")];
  EXPECT_EQ(j.spatial[0].axis, Vec3::UnitX());  // rotation1: the one rotation
  EXPECT_EQ(j.spatial[3].axis, Vec3::UnitZ());  // translation1: the one translation
  EXPECT_EQ(m->coordinates[m->findCoordinate("r")].motion_type, MotionType::Rotational);
  EXPECT_EQ(m->coordinates[m->findCoordinate("t")].motion_type, MotionType::Translational);
  // a's origin: (0, 1, 0) + t along z; a point (0, 1, 0) of a turns by r about x.
  const std::vector<double> q = test::coordinateValues(*m, {{"r", M_PI / 2}, {"t", 0.3}});
  const Pose X = test::bodyPoses(*m, q)[m->findBody("a")];
  EXPECT_LT((X * Vec3(0, 1, 0) - Vec3(0, 1, 1.3)).norm(), 1e-12);
  // The four unused axes are independent unit axes (OpenSim would refuse collinear ones).
  EXPECT_GT(j.spatial[1].axis.cross(j.spatial[2].axis).norm(), 0.5);
  EXPECT_GT(j.spatial[4].axis.cross(j.spatial[5].axis).norm(), 0.5);
}

// OpenSim's ThreeMasses example (format 10902): SpatialTransforms naming only their three
// translation axes, with MultiplierFunctions.
TEST(OsimJoints, SpatialTransformWithOnlyTranslationsOfFormat10902) {
  const ModelPtr m = readOsim(sourcePath("tests/model/corpus/ThreeMasses_10902.osim"));
  EXPECT_EQ(m->format_version, 10902);
  ASSERT_EQ(m->joints.size(), 3u);
  EXPECT_EQ(m->coordinates.size(), 9u);
  // OpenSim derives motion types from the functions: a MultiplierFunction is not a
  // LinearFunction of slope 1, so these coordinates are coupled, whatever the file says.
  for (const Coordinate& c : m->coordinates) EXPECT_EQ(c.motion_type, MotionType::Coupled) << c.name;
  // sphere2 sits at (3, 0, 0) in ground and moves with its three coordinates.
  const std::vector<double> q =
      test::coordinateValues(*m, {{"sphere2_TransX", 0.1}, {"sphere2_TransY", -0.2}, {"sphere2_TransZ", 0.3}});
  EXPECT_LT((test::bodyPoses(*m, q)[m->findBody("sphere2")].translation() - Vec3(3.1, -0.2, 0.3)).norm(), 1e-12);
  EXPECT_EQ(m->ignored.size(), 3u);  // the BodyDragForces, as forces
  EXPECT_EQ(m->ignored[0].category, "force");
}

// Two joints of the same name (opensim-core's snowboard10600.osim names both toes' joints mtp_l,
// each with a coordinate mtp_angle_l): OpenSim renames the later joint mtp_l_0 with a warning, and
// tells the coordinates apart by path; kneesim calls the later ones mtp_l_0 and mtp_l_0/mtp_angle_l.
TEST(OsimJoints, DuplicateJointNamesAreRenamedAsOpenSimDoes) {
  const std::string pin_a = "<PinJoint name=\"mtp\"><parent_body>ground</parent_body><location_in_parent>1 0 0"
                            "</location_in_parent><CoordinateSet><objects><Coordinate name=\"q\"/></objects>"
                            "</CoordinateSet></PinJoint>";
  std::string pin_b = pin_a;
  pin_b.replace(pin_b.find("1 0 0"), 5, "-1 0 0");
  const ModelPtr m = parseOsim(model3(pin_a, pin_b), "dup.osim");
  ASSERT_EQ(m->joints.size(), 2u);
  EXPECT_EQ(m->joints[0].name, "mtp");
  EXPECT_EQ(m->joints[1].name, "mtp_0");
  EXPECT_EQ(m->bodies[m->joints[1].child_body].name, "b");
  ASSERT_EQ(m->coordinates.size(), 2u);
  EXPECT_EQ(m->coordinates[1].name, "mtp_0/q");
  // b turns about z at (-1, 0, 0) by its own coordinate, not a's.
  const auto X = test::bodyPoses(*m, test::coordinateValues(*m, {{"q", 0.2}, {"mtp_0/q", 0.5}}));
  EXPECT_TRUE(X[m->findBody("b")].isApprox(test::shift(Vec3(-1, 0, 0)) * test::rot(Vec3::UnitZ(), 0.5), 1e-14));
  EXPECT_NE(join(m->warnings, "\n").find("joint name 'mtp' is taken by another joint; this <PinJoint> is "
                                                "called 'mtp_0'"),
            std::string::npos);
}

// The 4.0 pre-release form (30501): <connectors> naming parent_body and child_body by relative
// names, location_in_child, no ground body (OpenSim's Python tutorial double pendulum).
TEST(OsimJoints, ConnectorsOfFormat30501) {
  const ModelPtr m = readOsim(sourcePath("tests/model/corpus/double_pendulum_30501.osim"));
  ASSERT_EQ(m->joints.size(), 2u);
  // rod1 hangs from its (0, 0.5, 0) at the ground origin; rod2 from its (0, 0.5, 0) at rod1's origin.
  const double q1 = 0.3, q2 = -0.4;
  const std::vector<double> q = test::coordinateValues(*m, {{"q1", q1}, {"q2", q2}});
  const auto X = test::bodyPoses(*m, q);
  const Vec3 rod1 = Vec3(0.5 * std::sin(q1), -0.5 * std::cos(q1), 0);
  EXPECT_LT((X[m->findBody("rod1")].translation() - rod1).norm(), 1e-12);
  const Vec3 rod2 = rod1 + Vec3(0.5 * std::sin(q1 + q2), -0.5 * std::cos(q1 + q2), 0);
  EXPECT_LT((X[m->findBody("rod2")].translation() - rod2).norm(), 1e-12);
}

// The 4.0 development form of 30500-30502 (opensim-core's Tools/Test/BuiltinGeometry.osim):
// the ground is a body named 'ground' in the BodySet (there is no <Ground>) and the connectors
// name their bodies in <connected_to_name> (later <connectee_name>).
TEST(OsimJoints, GroundBodyAndConnectedToNameOfFormat30502) {
  const std::string text =
      "<OpenSimDocument Version=\"30502\"><Model name=\"m\"><BodySet><objects>\n"
      "<Body name=\"ground\"><mass>0</mass><mass_center>0 0 0</mass_center></Body>\n"
      "<Body name=\"rod\"><mass>1</mass><mass_center>0 0 0</mass_center><inertia>1 1 1 0 0 0</inertia></Body>\n"
      "</objects></BodySet>\n<JointSet><objects>\n<PinJoint name=\"pin\"><connectors>"
      "<Connector_Body_ name=\"parent_body\"><connected_to_name>ground</connected_to_name></Connector_Body_>"
      "<Connector_Body_ name=\"child_body\"><connected_to_name>rod</connected_to_name></Connector_Body_>"
      "</connectors><location_in_parent>0 1 0</location_in_parent><orientation_in_parent>0 0 0</orientation_in_parent>"
      "<location_in_child>0 0.5 0</location_in_child><orientation_in_child>0 0 0</orientation_in_child>"
      "<CoordinateSet><objects><Coordinate name=\"q\"/></objects></CoordinateSet></PinJoint>\n"
      "</objects></JointSet></Model></OpenSimDocument>\n";
  const ModelPtr m = parseOsim(text, "builtin.osim");
  ASSERT_EQ(m->bodies.size(), 2u);  // the BodySet's ground is the model's ground, not a second body
  ASSERT_EQ(m->joints.size(), 1u);
  EXPECT_EQ(m->joints[0].parent_body, 0);
  EXPECT_EQ(m->bodies[m->joints[0].child_body].name, "rod");
  // The rod hangs from its (0, 0.5, 0) at (0, 1, 0): its origin is at (0, 1, 0) + Rz(q) (0, -0.5, 0).
  const double q = 0.7;
  const Vec3 p = test::bodyPoses(*m, test::coordinateValues(*m, {{"q", q}}))[m->findBody("rod")].translation();
  EXPECT_LT((p - Vec3(0.5 * std::sin(q), 1 - 0.5 * std::cos(q), 0)).norm(), 1e-14);
}

TEST(OsimJoints, ScapulothoracicAndEllipsoidJoints) {
  const ModelPtr m = readOsim(sourcePath("tests/model/fixtures/shoulder40000.osim"));
  const Joint& st = m->joints[m->findJoint("scapulothoracic")];
  EXPECT_EQ(st.type, JointType::Scapulothoracic);
  EXPECT_EQ(st.coordinates.size(), 4u);
  EXPECT_EQ(st.radii, Vec3(0.07, 0.15, 0.08));
  EXPECT_EQ(st.winging_origin, Eigen::Vector2d(-0.05, -0.03));
  EXPECT_EQ(st.winging_direction, 0.4);
  const Joint& cap = m->joints[m->findJoint("cap_joint")];
  EXPECT_EQ(cap.type, JointType::Ellipsoid);
  EXPECT_EQ(cap.radii, Vec3(0.05, 0.04, 0.03));
  for (const Coordinate& c : m->coordinates) EXPECT_EQ(c.motion_type, MotionType::Rotational) << c.name;
  // Bad input: a radius of zero, a winging origin of three numbers, a coordinate short.
  const std::string text = readFileText(sourcePath("tests/model/fixtures/shoulder40000.osim"));
  auto broken = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    t.replace(t.find(from), from.size(), to);
    return test::inputErrorOf([&] { parseOsim(t, "s.osim"); });
  };
  EXPECT_NE(broken("<radii_x_y_z>0.05", "<radii_x_y_z>0").find(
                "EllipsoidJoint[cap_joint]/radii_x_y_z: expected three positive semi-axes (m), got '0 0.04 0.03'"),
            std::string::npos);
  EXPECT_NE(broken("-0.05 -0.03<", "-0.05 -0.03 0<").find("expected 2 numbers"), std::string::npos);
  std::string two = text;
  const size_t from = two.find("<Coordinate name=\"cap_z\">");
  two.erase(from, two.find("</Coordinate>", from) + 13 - from);
  EXPECT_NE(test::inputErrorOf([&] { parseOsim(two, "s.osim"); }).find("expected 3 coordinates for a EllipsoidJoint, got 2"),
            std::string::npos);
}

}  // namespace
}  // namespace kneesim::model
