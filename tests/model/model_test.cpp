#include "model/model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/error.hpp"
#include "support/test_data.hpp"

namespace kneesim::model {
namespace {

Body makeBody(const std::string& name) {
  Body b;
  b.name = name;
  b.mass = 1.0;
  return b;
}

Joint makeJoint(const std::string& name, int parent, int child) {
  Joint j;
  j.name = name;
  j.type = JointType::Weld;
  j.parent_body = parent;
  j.child_body = child;
  return j;
}

TEST(Model, PoseFromXYZIsBodyFixedXThenYThenZ) {
  // Hand-derived: Rx(90) Ry(90) = [0 0 1; 1 0 0; 0 1 0].
  const Pose X = poseFromXYZ(Vec3(M_PI / 2, M_PI / 2, 0), Vec3(1, 2, 3));
  Mat3 R;
  R << 0, 0, 1, 1, 0, 0, 0, 1, 0;
  EXPECT_TRUE(X.linear().isApprox(R, 1e-15));
  EXPECT_EQ(X.translation(), Vec3(1, 2, 3));
  // A single angle about z: first column (cos, sin, 0).
  const Pose Z = poseFromXYZ(Vec3(0, 0, 0.3), Vec3::Zero());
  EXPECT_NEAR(Z.linear()(0, 0), std::cos(0.3), 1e-16);
  EXPECT_NEAR(Z.linear()(1, 0), std::sin(0.3), 1e-16);
}

TEST(Model, FinalizeOrdersJointsParentFirstAndIndexesNames) {
  Model m;
  m.bodies = {makeBody("ground"), makeBody("b1"), makeBody("b2"), makeBody("b3")};
  m.joints = {makeJoint("j3", 2, 3), makeJoint("j2", 1, 2), makeJoint("j1", 0, 1)};
  Coordinate c;
  c.name = "q";
  c.joint = 1;  // j2 before sorting
  m.coordinates = {c};
  m.joints[1].type = JointType::Pin;
  m.joints[1].coordinates = {0};
  m.markers = {{"mk", 3, Vec3(1, 0, 0), false}};
  m.finalize();
  EXPECT_EQ(m.joints[0].name, "j1");
  EXPECT_EQ(m.joints[1].name, "j2");
  EXPECT_EQ(m.joints[2].name, "j3");
  EXPECT_EQ(m.coordinates[0].joint, 1);
  EXPECT_EQ(m.coordinates[0].index_in_joint, 0);
  EXPECT_EQ(m.findBody("b2"), 2);
  EXPECT_EQ(m.findJoint("j3"), 2);
  EXPECT_EQ(m.findCoordinate("q"), 0);
  EXPECT_EQ(m.findMarker("mk"), 0);
  EXPECT_EQ(m.findBody("nope"), -1);
  EXPECT_EQ(m.findParentJoint(3), 2);
  EXPECT_EQ(m.findParentJoint(0), -1);
}

TEST(Model, FinalizeFillsUnusedCustomAxes) {
  Model m;
  m.bodies = {makeBody("ground"), makeBody("b")};
  Joint j = makeJoint("c", 0, 1);
  j.type = JointType::Custom;
  const Vec3 axes[6] = {Vec3::UnitZ(), Vec3::UnitX(), Vec3(0, 2, 0), Vec3::UnitX(), Vec3::UnitY(), Vec3::UnitZ()};
  for (int a = 0; a < 6; ++a) j.spatial[a].axis = axes[a];
  j.spatial[0].coordinates = {0};
  j.coordinates = {0};
  Coordinate c;
  c.name = "q";
  m.coordinates = {c};
  m.joints = {j};
  m.finalize();
  EXPECT_EQ(m.joints[0].spatial[0].function->calcValue(0.7), 0.7);  // identity for a used axis
  EXPECT_EQ(m.joints[0].spatial[1].function->calcValue(0.7), 0.0);  // zero for an unused one
  EXPECT_EQ(m.joints[0].spatial[2].axis, Vec3(0, 1, 0));            // normalised
}

TEST(Model, FinalizeRejectsBrokenTrees) {
  {
    Model m;
    m.source_file = "x.osim";
    m.bodies = {makeBody("ground"), makeBody("b")};
    EXPECT_THROW(m.finalize(), InputError);  // b has no joint
  }
  {
    Model m;
    m.bodies = {makeBody("ground"), makeBody("b"), makeBody("c")};
    m.joints = {makeJoint("j1", 2, 1), makeJoint("j2", 1, 2)};  // a cycle detached from ground
    EXPECT_THROW(m.finalize(), InputError);
  }
  {
    Model m;
    m.bodies = {makeBody("ground"), makeBody("b"), makeBody("b")};
    m.joints = {makeJoint("j1", 0, 1), makeJoint("j2", 0, 2)};
    try {
      m.finalize();
      FAIL() << "duplicate body names accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("duplicate body name 'b'"), std::string::npos);
    }
  }
}

TEST(Model, FindMeshFileLooksNextToTheModelThenInGeometry) {
  const std::string dir = test::scratchDir("model_mesh");
  namespace fs = std::filesystem;
  fs::create_directories(dir + "/Geometry");
  std::ofstream(dir + "/here.stl") << "solid x\nendsolid x\n";
  std::ofstream(dir + "/Geometry/there.stl") << "solid x\nendsolid x\n";
  EXPECT_EQ(findMeshFile("here.stl", dir), fs::path(dir + "/here.stl").lexically_normal().string());
  EXPECT_EQ(findMeshFile("there.stl", dir), fs::path(dir + "/Geometry/there.stl").lexically_normal().string());
  EXPECT_EQ(findMeshFile(dir + "/here.stl", "/elsewhere"), fs::path(dir + "/here.stl").lexically_normal().string());
  EXPECT_EQ(findMeshFile("file://" + dir + "/here.stl", ""), fs::path(dir + "/here.stl").lexically_normal().string());
  EXPECT_EQ(findMeshFile("absent.stl", dir), "");
  EXPECT_EQ(findMeshFile("", dir), "");
  EXPECT_EQ(findMeshFile("Geometry", dir), "");  // a folder is not a mesh
}

}  // namespace
}  // namespace kneesim::model
