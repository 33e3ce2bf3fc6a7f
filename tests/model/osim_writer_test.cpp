#include "model/osim_writer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "model/kinematics.hpp"
#include "model/osim_reader.hpp"
#include "support/test_data.hpp"

namespace kneesim::model {
namespace {

// Values of two functions (and first derivatives) agree at sample points inside and outside
// the knots.
void expectSameFunction(const Function& a, const Function& b, const std::string& what) {
  ASSERT_EQ(a.getTypeName(), b.getTypeName()) << what;
  ASSERT_EQ(a.getArgumentSize(), b.getArgumentSize()) << what;
  for (double x : {-3.0, -1.1, -0.2, 0.0, 0.37, 1.0, 2.5, 7.0}) {
    double args[6] = {x, 0.5 * x, -x, 0, 0, 0};
    EXPECT_EQ(a.calcValue(args), b.calcValue(args)) << what << " at " << x;
    const int c[1] = {0};
    EXPECT_EQ(a.calcDerivative(args, c, 1), b.calcDerivative(args, c, 1)) << what << " at " << x;
  }
}

bool samePose(const Pose& a, const Pose& b, double tol) {
  return (a.translation() - b.translation()).norm() <= tol && (a.linear() - b.linear()).norm() <= tol;
}

// Everything readOsim keeps must come back: names, indices, frames, functions, flags.
void expectSameModel(const Model& a, const Model& b) {
  const double tol = 1e-15;
  EXPECT_EQ(a.name, b.name);
  EXPECT_TRUE(a.gravity == b.gravity);
  ASSERT_EQ(a.bodies.size(), b.bodies.size());
  for (size_t i = 0; i < a.bodies.size(); ++i) {
    const Body &x = a.bodies[i], &y = b.bodies[i];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.mass, y.mass) << x.name;
    EXPECT_TRUE(x.mass_center == y.mass_center) << x.name;
    EXPECT_TRUE(x.inertia == y.inertia) << x.name;
    ASSERT_EQ(x.meshes.size(), y.meshes.size()) << x.name;
    for (size_t k = 0; k < x.meshes.size(); ++k) {
      EXPECT_EQ(x.meshes[k].file, y.meshes[k].file);
      EXPECT_TRUE(x.meshes[k].scale == y.meshes[k].scale);
      EXPECT_TRUE(samePose(x.meshes[k].X_BG, y.meshes[k].X_BG, tol)) << x.name << " mesh " << k;
    }
  }
  ASSERT_EQ(a.joints.size(), b.joints.size());
  for (size_t i = 0; i < a.joints.size(); ++i) {
    const Joint &x = a.joints[i], &y = b.joints[i];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.type, y.type) << x.name;
    EXPECT_EQ(x.parent_body, y.parent_body) << x.name;
    EXPECT_EQ(x.child_body, y.child_body) << x.name;
    EXPECT_EQ(x.reverse, y.reverse) << x.name;
    EXPECT_EQ(x.coordinates, y.coordinates) << x.name;
    EXPECT_TRUE(samePose(x.X_PF, y.X_PF, tol)) << x.name;
    EXPECT_TRUE(samePose(x.X_BM, y.X_BM, tol)) << x.name;
    if (x.type != JointType::Custom) continue;
    for (int ax = 0; ax < 6; ++ax) {
      EXPECT_TRUE(x.spatial[ax].axis == y.spatial[ax].axis) << x.name << " axis " << ax;
      EXPECT_EQ(x.spatial[ax].coordinates, y.spatial[ax].coordinates) << x.name << " axis " << ax;
      expectSameFunction(*x.spatial[ax].function, *y.spatial[ax].function, x.name + " axis " + std::to_string(ax));
    }
  }
  ASSERT_EQ(a.coordinates.size(), b.coordinates.size());
  for (size_t i = 0; i < a.coordinates.size(); ++i) {
    const Coordinate &x = a.coordinates[i], &y = b.coordinates[i];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.motion_type, y.motion_type) << x.name;
    EXPECT_EQ(x.default_value, y.default_value) << x.name;
    EXPECT_EQ(x.range_min, y.range_min) << x.name;
    EXPECT_EQ(x.range_max, y.range_max) << x.name;
    EXPECT_EQ(x.clamped, y.clamped) << x.name;
    EXPECT_EQ(x.locked, y.locked) << x.name;
    EXPECT_EQ(x.joint, y.joint) << x.name;
    EXPECT_EQ(x.index_in_joint, y.index_in_joint) << x.name;
  }
  ASSERT_EQ(a.couplers.size(), b.couplers.size());
  for (size_t i = 0; i < a.couplers.size(); ++i) {
    EXPECT_EQ(a.couplers[i].name, b.couplers[i].name);
    EXPECT_EQ(a.couplers[i].dependent, b.couplers[i].dependent);
    EXPECT_EQ(a.couplers[i].independents, b.couplers[i].independents);
    EXPECT_EQ(a.couplers[i].scale_factor, b.couplers[i].scale_factor);
    expectSameFunction(*a.couplers[i].function, *b.couplers[i].function, a.couplers[i].name);
  }
  ASSERT_EQ(a.markers.size(), b.markers.size());
  for (size_t i = 0; i < a.markers.size(); ++i) {
    EXPECT_EQ(a.markers[i].name, b.markers[i].name);
    EXPECT_EQ(a.markers[i].body, b.markers[i].body);
    EXPECT_LE((a.markers[i].p_BM - b.markers[i].p_BM).norm(), tol) << a.markers[i].name;
    EXPECT_EQ(a.markers[i].fixed, b.markers[i].fixed);
  }
}

// Round trip through a file; also checks every marker at random poses with the plain Eigen
// forward kinematics, which knows nothing of the writer.
ModelPtr roundTrip(const Model& m, const std::string& name) {
  const std::string path = test::scratchDir("osim_writer_" + name) + "/" + name + ".osim";
  writeOsim(path, m, {{"written by osim_writer_test", "second line -- with dashes"}, "test credits", ""});
  ModelPtr back = readOsim(path);
  EXPECT_EQ(back->format_version, 40000);
  expectSameModel(m, *back);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<double> q(m.coordinates.size());
    for (double& v : q) v = u(rng);
    for (const auto& cc : m.couplers) {  // honour couplers so both sides see a consistent pose
      double x[6];
      for (size_t k = 0; k < cc.independents.size(); ++k) x[k] = q[cc.independents[k]];
      q[cc.dependent] = cc.scale_factor * cc.function->calcValue(x);
    }
    for (const Marker& mk : m.markers)
      EXPECT_LE((test::markerInGround(m, q, mk.name) - test::markerInGround(*back, q, mk.name)).norm(), 1e-14)
          << name << " " << mk.name;
  }
  return back;
}

TEST(OsimWriter, ExactNumbersAndEulerAngles) {
  for (double v : {0.1, 1.0 / 3.0, -2.5e-17, 6.02214076e23, 0.39335, 3.141592653589793, -0.0}) {
    double back;
    ASSERT_TRUE(tryParseDouble(formatExact(v), back));
    EXPECT_EQ(back, v) << formatExact(v);
  }
  EXPECT_EQ(formatExact(0.1), "0.1");
  EXPECT_EQ(formatExact(-0.39335), "-0.39335");
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int k = 0; k < 50; ++k) {
    const Vec3 r(u(rng), 0.5 * u(rng), u(rng));
    const Pose X = poseFromXYZ(r, Vec3::Zero());
    EXPECT_LE((poseFromXYZ(calcXYZFromRotation(X.linear()), Vec3::Zero()).linear() - X.linear()).norm(), 1e-14);
  }
  // Gimbal lock (b = +-90 deg): a and c are not separable, the rotation still is.
  for (double b : {M_PI / 2, -M_PI / 2}) {
    const Pose X = poseFromXYZ(Vec3(0.3, b, -0.4), Vec3::Zero());
    EXPECT_LE((poseFromXYZ(calcXYZFromRotation(X.linear()), Vec3::Zero()).linear() - X.linear()).norm(), 1e-12);
  }
}

TEST(OsimWriter, Chain40000RoundTrip) {
  ModelPtr m = readOsim(test::fixturePath("fixtures/chain40000.osim"));
  ModelPtr back = roundTrip(*m, "chain40000");
  // The hand-derived configuration Z of fixtures/README.md still holds: mE at all-zero q.
  std::vector<double> q(back->coordinates.size(), 0.0);
  q[back->findCoordinate("q_c_tz")] = 0.02;
  EXPECT_LE((test::markerInGround(*back, q, "mA2") - test::markerInGround(*m, q, "mA2")).norm(), 1e-15);
  // The offset mesh frame comes back as the same pose (the file's writer put it on a frame).
  const std::string text = formatOsim(*m);
  EXPECT_NE(text.find("<socket_parent_frame>ground_offset</socket_parent_frame>"), std::string::npos);
  EXPECT_NE(text.find("<socket_parent_frame>/bodyset/A</socket_parent_frame>"), std::string::npos);
  EXPECT_EQ(text.find("Thelen2003Muscle"), std::string::npos);  // ignored components are not written
}

TEST(OsimWriter, EveryJointAndFunctionTypeInCode) {
  // A model built in code with every joint type, every function type, an offset mesh and a
  // multi-argument coupler.
  auto m = std::make_shared<Model>();
  m->name = "all_types";
  m->bodies.resize(9);
  m->bodies[0].name = "ground";
  const char* names[] = {"ground", "pin", "slider", "ball", "free", "universal", "gimbal", "custom", "weld"};
  const JointType types[] = {JointType::Weld,      JointType::Pin,    JointType::Slider,
                             JointType::Ball,      JointType::Free,   JointType::Universal,
                             JointType::Gimbal,    JointType::Custom, JointType::Weld};
  const int ncoord[] = {0, 1, 1, 3, 6, 2, 3, 3, 0};
  for (int b = 1; b < 9; ++b) {
    Body& body = m->bodies[b];
    body.name = names[b];
    body.mass = 0.5 + b;
    body.mass_center = Vec3(0.01 * b, -0.02, 0.003);
    body.inertia << 0.1, 0.001, 0.002, 0.001, 0.2, 0.003, 0.002, 0.003, 0.3;
    Joint j;
    j.name = std::string(names[b]) + "_joint";
    j.type = types[b];
    j.parent_body = b - 1;
    j.child_body = b;
    j.X_PF = poseFromXYZ(Vec3(0.1 * b, -0.2, 0.3), Vec3(0, -0.1 * b, 0.02));
    j.X_BM = poseFromXYZ(Vec3(-0.05, 0.07 * b, 0), Vec3(0.01, 0.02, -0.03 * b));
    for (int k = 0; k < ncoord[b]; ++k) {
      Coordinate c;
      c.name = std::string(names[b]) + "_q" + std::to_string(k);
      c.default_value = 0.01 * (k + 1);
      c.range_min = -1.5 - k;
      c.range_max = 2.0;
      c.clamped = (k % 2) == 0;
      c.locked = b == 2;
      c.motion_type = (types[b] == JointType::Slider || (types[b] == JointType::Free && k >= 3))
                          ? MotionType::Translational
                          : MotionType::Rotational;
      j.coordinates.push_back(int(m->coordinates.size()));
      m->coordinates.push_back(c);
    }
    if (j.type == JointType::Custom) {
      const int c0 = j.coordinates[0], c1 = j.coordinates[1], c2 = j.coordinates[2];
      j.spatial[0].axis = Vec3(0, 0, 1);
      j.spatial[0].coordinates = {c0};
      j.spatial[0].function = makeLinear(1.0, 0.0);
      j.spatial[1].axis = Vec3(1, 0, 0);
      j.spatial[1].coordinates = {c1};
      j.spatial[1].function = makeLinear(-1.0, 0.0);
      j.spatial[2].axis = Vec3(0, 1, 0);
      j.spatial[2].coordinates = {c2};
      j.spatial[2].function = makeLinear(1.0, 0.0);
      j.spatial[3].axis = Vec3(1, 0, 0);
      j.spatial[3].coordinates = {c0};
      j.spatial[3].function = makeSimmSpline({-1, 0, 0.5, 1, 2}, {0.01, 0, -0.002, 0.003, 0.02});
      j.spatial[4].axis = Vec3(0, 1, 0);
      j.spatial[4].coordinates = {c0};
      j.spatial[4].function = makeMultiplier(makeNaturalCubicSpline({-1, 0, 1, 2}, {0.1, 0.2, 0.25, 0.2}), 0.5);
      j.spatial[5].axis = Vec3(0, 0, 1);
      j.spatial[5].coordinates = {c0};
      j.spatial[5].function = makePiecewiseLinear({-1, 0, 1}, {-0.01, 0.0, 0.03});
      m->coordinates[c0].motion_type = MotionType::Rotational;
    }
    m->joints.push_back(j);
  }
  // Meshes: one at the identity, one offset.
  MeshRef direct;
  direct.file = "box.stl";
  direct.scale = Vec3(1, 2, 3);
  m->bodies[3].meshes.push_back(direct);
  MeshRef offset = direct;
  offset.file = "Geometry/box.stl";
  offset.X_BG = poseFromXYZ(Vec3(0.2, -0.1, 1.3), Vec3(0.01, 0.02, 0.03));
  m->bodies[3].meshes.push_back(offset);
  m->bodies[0].meshes.push_back(direct);
  // Couplers: polynomial of one coordinate, constant of two.
  CoordinateCoupler cc;
  cc.name = "poly";
  cc.independents = {int(m->coordinates.size()) - 3};  // custom_q0
  cc.dependent = 0;                                    // pin_q0
  cc.function = makePolynomial({0.5, -0.2, 0.1});
  cc.scale_factor = 1.5;
  m->couplers.push_back(cc);
  CoordinateCoupler c2;
  c2.name = "constant2";
  c2.independents = {3, 4};
  c2.dependent = 5;
  c2.function = std::make_shared<Constant>(0.25, 2);
  m->couplers.push_back(c2);
  Marker mk;
  mk.name = "m_custom";
  mk.body = 7;
  mk.p_BM = Vec3(0.1, -0.2, 1.0 / 3.0);
  m->markers.push_back(mk);
  mk.name = "m_weld";
  mk.body = 8;
  mk.fixed = true;
  m->markers.push_back(mk);
  mk.name = "m_ground";
  mk.body = 0;
  m->markers.push_back(mk);
  m->finalize();
  roundTrip(*m, "all_types");
}

TEST(OsimWriter, Gait2354Format20303RoundTrip) {
  KNEESIM_REQUIRE_DATA("opensim-ik-tests/subject01_simbody.osim");
  ModelPtr m = readOsim(test::dataPath("opensim-ik-tests/subject01_simbody.osim"));
  roundTrip(*m, "gait2354");
}

TEST(OsimWriter, RefusesJointsReversedInTheOpenSim3Sense) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/model/jw_all_body_scaled.osim");
  ModelPtr m = readOsim(test::dataPath("kgc4-jw/model/jw_all_body_scaled.osim"));
  const std::string path = test::scratchDir("osim_writer_reverse") + "/jw.osim";
  try {
    writeOsim(path, *m);
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("joint[knee"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("reversed"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(path));  // no partial output
}

}  // namespace
}  // namespace kneesim::model
