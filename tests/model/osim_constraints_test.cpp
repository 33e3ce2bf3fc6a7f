// Constraint forms OpenSim reads: the 3.x form (body names) of OpenSim's knee_patella_ligament
// test model, the 4.x form (sockets, a WeldConstraint owning its frames), disabled ones and
// types kneesim does not enforce (listed, marked as affecting kinematics).
#include <gtest/gtest.h>

#include "model/osim_reader.hpp"
#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim::model {
namespace {

using test::sourcePath;

TEST(OsimConstraints, ConstantDistanceOfFormat30000) {
  const ModelPtr m = readOsim(sourcePath("tests/model/corpus/knee_patella_ligament.osim"));
  ASSERT_EQ(m->constraints.size(), 1u);
  const Constraint& k = m->constraints[0];
  EXPECT_EQ(k.name, "patellar_ligament_r");
  EXPECT_EQ(k.type, ConstraintType::ConstantDistance);
  EXPECT_EQ(m->bodies[k.body1].name, "patella_r");
  EXPECT_EQ(m->bodies[k.body2].name, "tibia_r");
  EXPECT_EQ(Vec3(k.X_B1F1.translation()), Vec3(0.0021, 0.0015, 0.0001));
  EXPECT_EQ(Vec3(k.X_B2F2.translation()), Vec3(0.039, -0.0822, 0));
  EXPECT_EQ(k.distance, 0.0635);
  EXPECT_TRUE(m->ignored.empty());
}

TEST(OsimConstraints, SocketFormsOfFormat40000) {
  const ModelPtr m = readOsim(sourcePath("tests/ik/fixtures/constraints40000.osim"));
  ASSERT_EQ(m->constraints.size(), 4u);
  const Constraint& line = m->constraints[1];
  EXPECT_EQ(line.type, ConstraintType::PointOnLine);
  EXPECT_EQ(line.body1, 0);  // ground
  EXPECT_EQ(m->bodies[line.body2].name, "rod2");
  EXPECT_LT((line.X_B1F1.linear().col(0) - Vec3::UnitX()).norm(), 1e-15);  // the line's direction
  EXPECT_EQ(Vec3(line.X_B1F1.translation()), Vec3(0, -3, 0));
  const Constraint& weld = m->constraints[2];
  EXPECT_EQ(weld.type, ConstraintType::Weld);
  EXPECT_EQ(m->bodies[weld.body1].name, "crank");
  EXPECT_EQ(m->bodies[weld.body2].name, "cube");
  EXPECT_LT((weld.X_B1F1.matrix() - poseFromXYZ(Vec3(0.1, 0.2, 0.3), Vec3(0.5, 0.2, 0.1)).matrix()).norm(), 1e-15);
  EXPECT_TRUE(weld.X_B2F2.isApprox(Pose::Identity()));
}

std::string withConstraint(const std::string& constraint) {
  return "<OpenSimDocument Version=\"40000\"><Model name=\"m\"><Ground name=\"ground\"/>\n"
         "<BodySet><objects><Body name=\"b\"><mass>1</mass><inertia>1 1 1 0 0 0</inertia></Body></objects></BodySet>\n"
         "<JointSet><objects><FreeJoint name=\"f\"><socket_parent_frame>/ground</socket_parent_frame>"
         "<socket_child_frame>/bodyset/b</socket_child_frame><coordinates><Coordinate name=\"q0\"/>"
         "<Coordinate name=\"q1\"/><Coordinate name=\"q2\"/><Coordinate name=\"q3\"/><Coordinate name=\"q4\"/>"
         "<Coordinate name=\"q5\"/></coordinates></FreeJoint></objects></JointSet>\n"
         "<ConstraintSet><objects>\n" + constraint + "\n</objects></ConstraintSet></Model></OpenSimDocument>\n";
}

TEST(OsimConstraints, DisabledAndUnsupportedAreListed) {
  ModelPtr m = parseOsim(withConstraint("<PointConstraint name=\"p\"><isEnforced>false</isEnforced>"
                                        "<socket_body_1>/ground</socket_body_1><socket_body_2>/bodyset/b</socket_body_2>"
                                        "</PointConstraint>"),
                         "c.osim");
  EXPECT_TRUE(m->constraints.empty());
  ASSERT_EQ(m->ignored.size(), 1u);
  EXPECT_EQ(m->ignored[0].type, "PointConstraint (disabled)");
  EXPECT_FALSE(m->ignored[0].affects_kinematics);
  m = parseOsim(withConstraint("<RollingOnSurfaceConstraint name=\"roll\"/>"), "c.osim");
  ASSERT_EQ(m->ignored.size(), 1u);
  EXPECT_EQ(m->ignored[0].category, "constraint");
  EXPECT_TRUE(m->ignored[0].affects_kinematics);
  // Bad input: a non-positive distance, a body that does not exist.
  EXPECT_NE(test::inputErrorOf([] {
              parseOsim(withConstraint("<ConstantDistanceConstraint name=\"d\"><socket_body_1>/ground</socket_body_1>"
                                       "<socket_body_2>/bodyset/b</socket_body_2><constant_distance>0</constant_distance>"
                                       "</ConstantDistanceConstraint>"),
                        "c.osim");
            }).find("ConstantDistanceConstraint[d]/constant_distance: expected a positive distance (m), got 0"),
            std::string::npos);
  EXPECT_NE(test::inputErrorOf([] {
              parseOsim(withConstraint("<PointConstraint name=\"p\"><socket_body_1>/bodyset/x</socket_body_1>"
                                       "<socket_body_2>/bodyset/b</socket_body_2></PointConstraint>"),
                        "c.osim");
            }).find("socket_body_1: unknown frame '/bodyset/x'"),
            std::string::npos);
}

}  // namespace
}  // namespace kneesim::model
