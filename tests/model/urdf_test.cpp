#include "model/urdf.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <random>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "model/kinematics.hpp"
#include "model/osim_reader.hpp"
#include "support/test_data.hpp"

namespace kneesim::model {
namespace {

using test::fixturePath;

const Body& body(const Model& m, const std::string& name) {
  const int b = m.findBody(name);
  if (b < 0) throw std::runtime_error("no body " + name);
  return m.bodies[b];
}

Vec3 origin(const Model& m, const std::vector<double>& q, const std::string& name) {
  return test::bodyPoses(m, q)[m.findBody(name)].translation();
}

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const std::string& s : v) out += s + " | ";
  return out;
}

bool contains(const std::vector<std::string>& v, const std::string& part) {
  return std::any_of(v.begin(), v.end(), [&](const std::string& s) { return s.find(part) != std::string::npos; });
}

TEST(Urdf, ReadsTheFixture) {
  const ModelPtr m = readUrdf(fixturePath("fixtures/chain.urdf"));
  EXPECT_EQ(m->name, "chain_urdf");
  EXPECT_EQ(m->format_version, 0);
  ASSERT_EQ(m->bodies.size(), 6u);  // ground + base + l1..l4
  ASSERT_EQ(m->joints.size(), 5u);  // the weld of the root link + 4
  ASSERT_EQ(m->coordinates.size(), 3u);
  EXPECT_EQ(m->joints[0].name, "ground_base");
  EXPECT_EQ(m->joints[0].type, JointType::Weld);

  // l1: the inertial frame is rotated by Rz90, so diag(0.1, 0.2, 0.3) becomes diag(0.2, 0.1, 0.3).
  const Body& l1 = body(*m, "l1");
  EXPECT_EQ(l1.mass, 2.0);
  EXPECT_TRUE(l1.mass_center.isApprox(Vec3(0.05, 0, 0)));
  Mat3 I = Vec3(0.2, 0.1, 0.3).asDiagonal();
  EXPECT_LT((l1.inertia - I).norm(), 1e-15);
  ASSERT_EQ(l1.meshes.size(), 1u);
  EXPECT_EQ(l1.meshes[0].file, "box.stl");
  EXPECT_NE(l1.meshes[0].resolved_path.find("fixtures/Geometry/box.stl"), std::string::npos);
  EXPECT_EQ(l1.meshes[0].scale, Vec3(0.001, 0.001, 0.001));
  EXPECT_TRUE(l1.meshes[0].X_BG.translation().isApprox(Vec3(0, 0, 0.01)));

  const Coordinate& rev = m->coordinates[m->findCoordinate("j_rev")];
  EXPECT_EQ(rev.motion_type, MotionType::Rotational);
  EXPECT_EQ(rev.range_min, -2.0);
  EXPECT_EQ(rev.range_max, 2.0);
  EXPECT_TRUE(rev.clamped);
  const Coordinate& pri = m->coordinates[m->findCoordinate("j_pri")];
  EXPECT_EQ(pri.motion_type, MotionType::Translational);
  EXPECT_TRUE(pri.clamped);
  EXPECT_FALSE(m->coordinates[m->findCoordinate("j_cont")].clamped);
  EXPECT_EQ(m->joints[m->findJoint("j_rev")].type, JointType::Pin);
  EXPECT_EQ(m->joints[m->findJoint("j_pri")].type, JointType::Slider);
  EXPECT_EQ(m->joints[m->findJoint("j_fix")].type, JointType::Weld);
  // The pin's z axis lies along the URDF axis (x of the joint frame): R_PF z = Rz90 x = y.
  const Joint& jr = m->joints[m->findJoint("j_rev")];
  EXPECT_TRUE((jr.X_PF.linear() * Vec3::UnitZ()).isApprox(Vec3(0, 1, 0), 1e-15));
  EXPECT_TRUE(m->ignored.size() >= 2u);  // l1's collision box and l3's visual cylinder
}

TEST(Urdf, FixtureMatchesHandDerivedPositions) {
  const ModelPtr m = readUrdf(fixturePath("fixtures/chain.urdf"));
  const auto qz = test::coordinateValues(*m, {});
  const auto qp = test::coordinateValues(*m, {{"j_rev", M_PI / 2}, {"j_pri", 0.3}, {"j_cont", M_PI / 2}});
  const std::map<std::string, std::pair<Vec3, Vec3>> links = {{"l1", {{0, 0, 0.5}, {0, 0, 0.5}}},
                                                              {"l2", {{0, 0.2, 0.5}, {0.3, 0.2, 0.5}}},
                                                              {"l3", {{0.1, 0.2, 0.5}, {0.3, 0.2, 0.4}}},
                                                              {"l4", {{0, 0.2, 0.5}, {0.3, 0.2, 0.5}}}};
  for (const auto& kv : links) {
    EXPECT_LT((origin(*m, qz, kv.first) - kv.second.first).norm(), 1e-12) << kv.first;
    EXPECT_LT((origin(*m, qp, kv.first) - kv.second.second).norm(), 1e-12) << kv.first;
  }
  const int l4 = m->findBody("l4");
  EXPECT_LT((test::bodyPoses(*m, qz)[l4] * Vec3(0.1, 0, 0) - Vec3(-0.1, 0.2, 0.5)).norm(), 1e-12);
  EXPECT_LT((test::bodyPoses(*m, qp)[l4] * Vec3(0.1, 0, 0) - Vec3(0.4, 0.2, 0.5)).norm(), 1e-12);
}

TEST(Urdf, WorldRootFloatingJointAndMimic) {
  const std::string text =
      "<robot name=\"r\">\n"
      "<link name=\"world\"/><link name=\"pelvis\"><inertial><mass value=\"10\"/>"
      "<inertia ixx=\"1\" ixy=\"0\" ixz=\"0\" iyy=\"1\" iyz=\"0\" izz=\"1\"/></inertial></link>\n"
      "<link name=\"a\"/><link name=\"b\"/>\n"
      "<joint name=\"free\" type=\"floating\"><parent link=\"world\"/><child link=\"pelvis\"/>"
      "<origin xyz=\"0 0 1\"/></joint>\n"
      "<joint name=\"ja\" type=\"continuous\"><parent link=\"pelvis\"/><child link=\"a\"/><axis xyz=\"0 0 -1\"/></joint>\n"
      "<joint name=\"jb\" type=\"prismatic\"><parent link=\"a\"/><child link=\"b\"/><axis xyz=\"0 0 1\"/>"
      "<limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/>"
      "<mimic joint=\"ja\" multiplier=\"0.5\" offset=\"0.1\"/></joint>\n"
      "</robot>\n";
  const ModelPtr m = parseUrdf(text, "world.urdf");
  ASSERT_EQ(m->bodies.size(), 4u);  // world is ground
  EXPECT_EQ(m->joints.size(), 3u);
  EXPECT_EQ(m->joints[0].type, JointType::Free);
  EXPECT_EQ(m->joints[0].parent_body, 0);
  ASSERT_EQ(m->coordinates.size(), 8u);
  EXPECT_EQ(m->coordinates[0].name, "free_rx");
  EXPECT_EQ(m->coordinates[5].name, "free_tz");
  EXPECT_EQ(m->coordinates[5].motion_type, MotionType::Translational);
  ASSERT_EQ(m->couplers.size(), 1u);
  EXPECT_EQ(m->coordinates[m->couplers[0].dependent].name, "jb");
  EXPECT_EQ(m->coordinates[m->couplers[0].independents[0]].name, "ja");
  EXPECT_DOUBLE_EQ(m->couplers[0].function->calcValue(2.0), 1.1);
  // A continuous joint about -z turns b's origin the other way: at ja = pi/2, the point (1,0,0)
  // of a lands at (0,-1,1) (z up through the free joint's origin).
  const auto q = test::coordinateValues(*m, {{"ja", M_PI / 2}});
  EXPECT_LT((test::bodyPoses(*m, q)[m->findBody("a")] * Vec3(1, 0, 0) - Vec3(0, -1, 1)).norm(), 1e-12);
}

/// Compares the ground pose of every body of @p a with the same-named body of @p b.
void expectSameKinematics(const Model& a, const std::vector<double>& qa, const Model& b, const std::vector<double>& qb,
                          double tol, const std::string& what) {
  const auto Xa = test::bodyPoses(a, qa), Xb = test::bodyPoses(b, qb);
  for (size_t i = 1; i < a.bodies.size(); ++i) {
    const int j = b.findBody(a.bodies[i].name);
    ASSERT_GE(j, 0) << a.bodies[i].name;
    EXPECT_LT((Xa[i].matrix() - Xb[j].matrix()).cwiseAbs().maxCoeff(), tol) << what << ": body " << a.bodies[i].name;
  }
}

/// Values for @p b's coordinates taken by name from @p qa of @p a (mimic coordinates of b are
/// evaluated from their couplers).
std::vector<double> mapCoordinates(const Model& a, const std::vector<double>& qa, const Model& b) {
  std::vector<double> qb(b.coordinates.size(), 0.0);
  for (size_t k = 0; k < b.coordinates.size(); ++k) {
    const int i = a.findCoordinate(b.coordinates[k].name);
    if (i >= 0) qb[k] = qa[i];
  }
  for (const CoordinateCoupler& cc : b.couplers) {
    double x = qb[cc.independents[0]];
    qb[cc.dependent] = cc.scale_factor * cc.function->calcValue(&x);
  }
  return qb;
}

TEST(Urdf, RoundTripOfTheOsimChainKeepsMassesAndKinematics) {
  const ModelPtr m = readOsim(fixturePath("fixtures/chain40000.osim"));
  std::vector<std::string> lost;
  const std::string dir = test::scratchDir("urdf_chain");
  writeUrdf(*m, dir + "/chain.urdf", &lost);
  const ModelPtr u = readUrdf(dir + "/chain.urdf");
  for (size_t b = 1; b < m->bodies.size(); ++b) {
    EXPECT_EQ(body(*u, m->bodies[b].name).mass, m->bodies[b].mass);
    EXPECT_TRUE(body(*u, m->bodies[b].name).mass_center.isApprox(m->bodies[b].mass_center));
    EXPECT_LT((body(*u, m->bodies[b].name).inertia - m->bodies[b].inertia).norm(), 1e-15);
  }
  // Every coordinate keeps its name; the coupler became a mimic: q_c_tz = q_slide + 0.02.
  for (const Coordinate& c : m->coordinates) EXPECT_GE(u->findCoordinate(c.name), 0) << c.name;
  ASSERT_EQ(u->couplers.size(), 1u);
  EXPECT_EQ(u->coordinates[u->couplers[0].dependent].name, "q_c_tz");
  EXPECT_NEAR(u->couplers[0].function->calcValue(0.3), 0.32, 1e-15);
  // What URDF cannot hold is reported.
  EXPECT_TRUE(contains(lost, "translation1: SimmSpline of q_c_rot frozen at 0"));
  EXPECT_TRUE(contains(lost, "6 marker(s) dropped"));
  EXPECT_TRUE(contains(lost, "not clamped in the model written as URDF joint limits: q_slide, q_gx, q_gy, q_gz, q_ux, "
                            "q_uy, q_c_rot, q_c_tz"));
  EXPECT_TRUE(contains(lost, "default values dropped (URDF's zero pose has every joint at 0): q_c_tz = 0.02"));
  EXPECT_EQ(lost.size(), 4u) << join(lost);

  // Kinematics agree wherever the frozen spline is at its default (q_c_rot = 0).
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1.2, 1.2);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<double> q(m->coordinates.size());
    for (double& v : q) v = U(rng);
    q[m->findCoordinate("q_c_rot")] = 0.0;
    q[m->findCoordinate("q_c_tz")] = q[m->findCoordinate("q_slide")] + 0.02;
    expectSameKinematics(*m, q, *u, mapCoordinates(*m, q, *u), 1e-12, "trial " + std::to_string(trial));
  }
}

TEST(Urdf, RoundTripOfAReverseJointIsExact) {
  const ModelPtr m = readOsim(fixturePath("fixtures/reverse30000.osim"));
  std::vector<std::string> lost;
  const ModelPtr u = parseUrdf(formatUrdf(*m, &lost), fixturePath("fixtures/reverse.urdf"));
  for (double q : {0.0, M_PI / 2, -0.7, 2.5}) {
    const auto qa = test::coordinateValues(*m, {{"q_rev", q}});
    expectSameKinematics(*m, qa, *u, mapCoordinates(*m, qa, *u), 1e-12, "q_rev " + std::to_string(q));
  }
  // The hand-derived point: q_rev = pi/2 puts P's origin at (0, 0.8, 0).
  const auto qu = test::coordinateValues(*u, {{"q_rev", M_PI / 2}});
  EXPECT_LT((origin(*u, qu, "P") - Vec3(0, 0.8, 0)).norm(), 1e-12);
}

TEST(Urdf, UrdfToModelToUrdfIsStable) {
  const ModelPtr m = readUrdf(fixturePath("fixtures/chain.urdf"));
  std::vector<std::string> lost;
  const ModelPtr u = parseUrdf(formatUrdf(*m, &lost), fixturePath("fixtures/again.urdf"));
  const auto q = test::coordinateValues(*m, {{"j_rev", 0.4}, {"j_pri", -0.2}, {"j_cont", 2.0}});
  expectSameKinematics(*m, q, *u, mapCoordinates(*m, q, *u), 1e-12, "urdf twice");
  EXPECT_EQ(u->coordinates[u->findCoordinate("j_rev")].range_max, 2.0);
  EXPECT_TRUE(lost.empty()) << join(lost);
}

TEST(Urdf, RealModelsExport) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/model/jw_all_body_scaled.osim");
  const ModelPtr m = readOsim(test::dataPath("kgc4-jw/model/jw_all_body_scaled.osim"));
  std::vector<std::string> lost;
  const ModelPtr u = parseUrdf(formatUrdf(*m, &lost), "jw.urdf");
  double mass_m = 0, mass_u = 0;
  for (const Body& b : m->bodies) mass_m += b.mass;
  for (const Body& b : u->bodies) mass_u += b.mass;
  EXPECT_NEAR(mass_u, mass_m, 1e-12);
  EXPECT_TRUE(contains(lost, "54 marker(s) dropped"));
  // JW's joints (reverse knees included) have identity or constant axes and linear couplers:
  // the URDF reproduces the kinematics exactly for any coordinates.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-0.6, 0.6);
  for (int trial = 0; trial < 10; ++trial) {
    std::vector<double> q(m->coordinates.size());
    for (double& v : q) v = U(rng);
    for (const CoordinateCoupler& cc : m->couplers) {
      double x = q[cc.independents[0]];
      q[cc.dependent] = cc.scale_factor * cc.function->calcValue(&x);
    }
    expectSameKinematics(*m, q, *u, mapCoordinates(*m, q, *u), 1e-12, "jw trial " + std::to_string(trial));
  }
}

}  // namespace
}  // namespace kneesim::model
