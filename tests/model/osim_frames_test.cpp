// Frames OpenSim 4.x reads: bodies and joints listed in a model's <components> (Moco's models),
// Stations and StationDefinedFrames (4.5), checked against poses worked out by hand.
#include <gtest/gtest.h>

#include "model/kinematics.hpp"
#include "model/osim_reader.hpp"
#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim::model {
namespace {

using test::sourcePath;

// Moco writes models whose bodies and joints sit in the model's <components>, paths /body.
TEST(OsimFrames, ComponentsOnlyModelOfMoco) {
  const ModelPtr m = readOsim(sourcePath("tests/model/corpus/testMocoMetabolics_hanging_muscle_40600.osim"));
  EXPECT_EQ(m->format_version, 40600);
  ASSERT_EQ(m->bodies.size(), 2u);
  EXPECT_EQ(m->bodies[1].name, "body");
  EXPECT_EQ(m->bodies[1].mass, 0.5);
  ASSERT_EQ(m->joints.size(), 1u);
  EXPECT_EQ(m->joints[0].type, JointType::Slider);
  EXPECT_EQ(m->coordinates[0].name, "height");
  EXPECT_EQ(m->gravity, Vec3(9.81, 0, 0));
  // The muscle and the metabolics component are listed, each as what it is.
  ASSERT_EQ(m->ignored.size(), 2u);
  for (const IgnoredComponent& c : m->ignored) {
    if (c.type == "DeGrooteFregly2016Muscle") EXPECT_EQ(c.category, "muscle");
    EXPECT_FALSE(c.affects_kinematics);
  }
}

// A marker on a StationDefinedFrame of body b. Stations (metres, in b): a = (0.1, 0.1, 0.1),
// b = (0.1, -0.1, 0.1), c = (0.1, 0, -0.1), origin (0.1, 0, 0). ab = (0, -1, 0); ab x ac is
// along (0.2, 0, 0), i.e. +x of b; with OpenSim's defaults (ab_axis +x, ab_x_ac_axis +y) the
// frame's x is b's -y, its y is b's +x, its z = x cross y is b's +z. The marker at (1, 2, 3) in
// the frame is at (0.1, 0, 0) + 1 (0,-1,0) + 2 (1,0,0) + 3 (0,0,1) = (2.1, -1, 3) in b.
// With ab_axis -z and ab_x_ac_axis +x: z = -ab = (0,1,0), x = (1,0,0), y = z cross x = (0,0,-1):
// the marker is at (0.1, 0, 0) + (1, 0, 0) + 2 (0, 0, -1) + 3 (0, 1, 0) = (1.1, 3, -2).
std::string sdfModel(const std::string& axes) {
  auto station = [](const char* n, const char* loc) {
    return std::string("<Station name=\"") + n + "\"><socket_parent_frame>/bodyset/b</socket_parent_frame><location>" +
           loc + "</location></Station>\n";
  };
  return "<OpenSimDocument Version=\"40500\"><Model name=\"m\"><Ground name=\"ground\"/>\n"
         "<BodySet><objects><Body name=\"b\"><mass>1</mass><inertia>1 1 1 0 0 0</inertia>\n<components>\n" +
         station("a", "0.1 0.1 0.1") + station("b", "0.1 -0.1 0.1") + station("c", "0.1 0 -0.1") +
         station("o", "0.1 0 0") +
         "<StationDefinedFrame name=\"sdf\"><socket_point_a>../a</socket_point_a><socket_point_b>../b</socket_point_b>"
         "<socket_point_c>../c</socket_point_c><socket_origin_point>../o</socket_origin_point>" + axes +
         "</StationDefinedFrame>\n</components></Body></objects></BodySet>\n"
         "<JointSet><objects><WeldJoint name=\"w\"><socket_parent_frame>/ground</socket_parent_frame>"
         "<socket_child_frame>/bodyset/b</socket_child_frame></WeldJoint></objects></JointSet>\n"
         "<MarkerSet><objects><Marker name=\"mk\"><socket_parent_frame>/bodyset/b/sdf</socket_parent_frame>"
         "<location>1 2 3</location></Marker></objects></MarkerSet>\n"
         "</Model></OpenSimDocument>\n";
}

TEST(OsimFrames, StationDefinedFrameAsOpenSimBuildsIt) {
  ModelPtr m = parseOsim(sdfModel(""), "sdf.osim");
  EXPECT_LT((m->markers[0].p_BM - Vec3(2.1, -1, 3)).norm(), 1e-12) << m->markers[0].p_BM.transpose();
  m = parseOsim(sdfModel("<ab_axis>-z</ab_axis><ab_x_ac_axis>+x</ab_x_ac_axis>"), "sdf.osim");
  EXPECT_LT((m->markers[0].p_BM - Vec3(1.1, 3, -2)).norm(), 1e-12) << m->markers[0].p_BM.transpose();
  // OpenSim's own test model loads (its frame hangs on nothing kneesim simulates).
  EXPECT_NO_THROW(readOsim(sourcePath("tests/model/corpus/StationDefinedFrames_Basic_40500.osim")));
  // Collinear stations and a bad axis name are one-line errors.
  std::string flat = sdfModel("");
  flat.replace(flat.find("0.1 0 -0.1"), 10, "0.1 0.3 0.1");
  EXPECT_NE(test::inputErrorOf([&] { parseOsim(flat, "sdf.osim"); })
                .find("StationDefinedFrame[sdf]: expected point_a, point_b and point_c to form a triangle"),
            std::string::npos);
  EXPECT_NE(test::inputErrorOf([&] { parseOsim(sdfModel("<ab_axis>w</ab_axis>"), "sdf.osim"); })
                .find("ab_axis: expected +x, -x, +y, -y, +z or -z, got 'w'"),
            std::string::npos);
}

// dennis_hopper (format 30512): sockets written socket_<name>_connectee_name, a WrapCylinder in
// the WrapObjectSet of a PhysicalOffsetFrame (fixed on the frame's body at the frame's pose), a
// PointOnLineConstraint among a body's <components> (OpenSim enforces it wherever it is owned) and
// the knee written from the shank to the thigh (used from the thigh, as OpenSim does).
TEST(OsimFrames, HopperOf30512) {
  const ModelPtr m = readOsim(sourcePath("tests/model/corpus/dennis_hopper_30512.osim"));
  EXPECT_EQ(m->format_version, 30512);
  ASSERT_EQ(m->wrap_objects.size(), 1u);
  const WrapObject& w = m->wrap_objects[0];
  EXPECT_EQ(w.name, "patella");
  EXPECT_EQ(m->bodies[w.body].name, "thigh");
  EXPECT_LT((w.X_BW.translation() - Vec3(0, -0.25, 0)).norm(), 1e-15);
  ASSERT_EQ(m->constraints.size(), 1u);
  const Constraint& k = m->constraints[0];
  EXPECT_EQ(k.type, ConstraintType::PointOnLine);
  EXPECT_EQ(k.body1, 0);
  EXPECT_EQ(m->bodies[k.body2].name, "shank");
  EXPECT_LT((k.X_B2F2.translation() - Vec3(0, -0.25, 0)).norm(), 1e-15);
  const Joint& knee = m->joints[m->findJoint("knee")];
  EXPECT_TRUE(knee.reversed_in_tree);
  EXPECT_EQ(m->bodies[knee.parent_body].name, "thigh");
  EXPECT_EQ(m->bodies[knee.child_body].name, "shank");
  EXPECT_LT((knee.X_PF.translation() - Vec3(0, -0.25, 0)).norm(), 1e-15);  // the file's thigh_offset
  EXPECT_LT((knee.X_BM.translation() - Vec3(0, 0.25, 0)).norm(), 1e-15);   // the file's shank_offset
}

}  // namespace
}  // namespace kneesim::model
