// Kinematics of the Simbody builder against positions derived by hand.
#include "sim/system.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include <map>
#include <random>
#include <string>

#include "core/error.hpp"
#include "model/kinematics.hpp"
#include "model/osim_reader.hpp"
#include "model/osim_writer.hpp"
#include "model/urdf.hpp"
#include "support/chain_model.hpp"
#include "support/test_data.hpp"

namespace kneesim::sim {
namespace {

using test::makeChain;

using model::Pose;
using model::Vec3;

Vec3 rotZ(double a, const Vec3& v) { return Vec3(std::cos(a) * v.x() - std::sin(a) * v.y(), std::sin(a) * v.x() + std::cos(a) * v.y(), v.z()); }

TEST(System, ChainMatchesHandDerivedKinematics) {
  auto model = makeChain(false, 40000);
  System sys(model);
  auto ws = sys.createWorkspace();
  const double q0 = 0.3, q1 = -0.07, q2 = 0.6;
  Eigen::VectorXd q(3);
  q << q0, q1, q2;
  sys.realizePosition(*ws, q);
  const Vec3 base(0, 1, 0);
  // mA: (0,1,0) + Rz(q0)(0.5,0,0)
  EXPECT_LT((sys.findStationLocation(*ws, 1, Vec3(0.5, 0, 0)) - (base + rotZ(q0, Vec3(0.5, 0, 0)))).norm(), 1e-12);
  // mB: B's (0,0,0.2) is A's (0.2,0,0); B's origin is A's (0.5,0,-q1).
  EXPECT_LT((sys.findStationLocation(*ws, 2, Vec3(0, 0, 0.2)) - (base + rotZ(q0, Vec3(0.7, 0, -q1)))).norm(), 1e-12);
  // mC in B: (0.1 q2 + 0.05 + 0.1 cos q2, 0.1 sin q2, 0) =: (a, b, 0); B's (a,b,0) is A's (0.5, b, -q1 - a).
  const double a = 0.1 * q2 + 0.05 + 0.1 * std::cos(q2), b = 0.1 * std::sin(q2);
  EXPECT_LT((sys.findStationLocation(*ws, 3, Vec3(0.1, 0, 0)) - (base + rotZ(q0, Vec3(0.5, b, -q1 - a)))).norm(), 1e-12);
}

TEST(System, ReversedCustomJointOfOpenSim3InvertsTheTransform) {
  // OpenSim 3.x `reverse`: X_FM = T(q)^-1. C's origin in B is -R(q2)^T t with t = (0.1 q2 + 0.05, 0, 0).
  const double q2 = 0.6;
  Eigen::VectorXd q(3);
  q << 0.0, 0.0, q2;
  {
    System sys(makeChain(true, 30000));
    auto ws = sys.createWorkspace();
    sys.realizePosition(*ws, q);
    const Vec3 c_in_B = -rotZ(-q2, Vec3(0.1 * q2 + 0.05, 0, 0));
    // B's (x,y,0) is A's (0.5, y, -x) when q1 = 0.
    const Vec3 expected = Vec3(0, 1, 0) + Vec3(0.5, c_in_B.y(), -c_in_B.x());
    EXPECT_LT((sys.findStationLocation(*ws, 3, Vec3::Zero()) - expected).norm(), 1e-12);
  }
  {
    // Format 40000 keeps the joint's meaning: same as forward.
    System fwd(makeChain(false, 40000)), rev(makeChain(true, 40000));
    auto w1 = fwd.createWorkspace(), w2 = rev.createWorkspace();
    fwd.realizePosition(*w1, q);
    rev.realizePosition(*w2, q);
    EXPECT_LT((fwd.findStationLocation(*w1, 3, Vec3(0.1, 0.2, 0.3)) - rev.findStationLocation(*w2, 3, Vec3(0.1, 0.2, 0.3))).norm(), 1e-14);
  }
}

TEST(System, StationJacobianMatchesFiniteDifferences) {
  System sys(makeChain(true, 30000));
  auto ws = sys.createWorkspace();
  Eigen::VectorXd q(3);
  q << 0.4, 0.1, -0.8;
  const std::vector<int> bodies = {1, 2, 3};
  const std::vector<Vec3> stations = {Vec3(0.5, 0, 0), Vec3(0, 0.1, 0.2), Vec3(0.1, -0.05, 0.02)};
  Eigen::MatrixXd J(9, 3);
  sys.realizePosition(*ws, q);
  sys.calcStationJacobian(*ws, bodies, stations, J);
  const double h = 1e-6;
  for (int c = 0; c < 3; ++c) {
    Eigen::VectorXd qp = q, qm = q;
    qp[c] += h;
    qm[c] -= h;
    for (int i = 0; i < 3; ++i) {
      sys.realizePosition(*ws, qp);
      const Vec3 pp = sys.findStationLocation(*ws, bodies[i], stations[i]);
      sys.realizePosition(*ws, qm);
      const Vec3 pm = sys.findStationLocation(*ws, bodies[i], stations[i]);
      EXPECT_LT((J.block<3, 1>(3 * i, c) - (pp - pm) / (2 * h)).norm(), 1e-8) << "coordinate " << c << " station " << i;
    }
  }
}

// ------------------------------------------------------------------------------------------
// The hand-written fixtures of tests/model/fixtures (README.md there derives every number by
// hand) through the Simbody system: readers, builder, mobilizers and Simbody together.

/// Coordinates of @p m at their defaults, overridden by @p values (by name).
Eigen::VectorXd coordinates(const model::Model& m, const std::map<std::string, double>& values) {
  Eigen::VectorXd q(m.coordinates.size());
  for (size_t i = 0; i < m.coordinates.size(); ++i) q[i] = m.coordinates[i].default_value;
  for (const auto& [name, v] : values) {
    const int c = m.findCoordinate(name);
    EXPECT_GE(c, 0) << name;
    if (c >= 0) q[c] = v;
  }
  return q;
}

Vec3 markerPosition(const System& sys, const Workspace& ws, const std::string& name) {
  const model::Model& m = sys.getModel();
  const int k = m.findMarker(name);
  EXPECT_GE(k, 0) << name;
  return sys.findStationLocation(ws, m.markers[k].body, m.markers[k].p_BM);
}

TEST(System, Chain40000GivesHandDerivedMarkerPositions) {
  System sys(model::readOsim(test::sourcePath("tests/model/fixtures/chain40000.osim")));
  const model::Model& m = sys.getModel();
  auto ws = sys.createWorkspace();
  const double h = M_PI / 2, f = 0.24674011002723395;  // f = 0.1 (pi/2)^2, SIMM's 3-point spline
  // Configuration Z: all zero but q_c_tz = 0.02, which the coupler asks for.
  sys.realizePosition(*ws, coordinates(m, {{"q_c_tz", 0.02}}));
  const std::map<std::string, Vec3> zero = {{"mA", {0, 1, 0.2}},   {"mA2", {-0.1, 0.9, 0.1}}, {"mB", {0.1, 0.9, 0}},
                                            {"mC", {-0.3, 1, 0.1}}, {"mD", {-0.4, 1, 0.1}},   {"mE", {-0.4, 0.88, -0.1}}};
  for (const auto& [name, p] : zero)
    EXPECT_LT((markerPosition(sys, *ws, name) - p).norm(), 1e-9) << name << ": " << markerPosition(sys, *ws, name).transpose();
  EXPECT_LT(std::abs(sys.calcCouplerErrors(*ws)[0]), 1e-15);
  // Configuration P.
  sys.realizePosition(*ws, coordinates(m, {{"q_pin", h}, {"q_slide", 0.3}, {"q_gx", h}, {"q_gy", M_PI}, {"q_gz", h},
                                           {"q_ux", h}, {"q_uy", h}, {"q_c_rot", h}, {"q_c_tz", 0.32}}));
  const std::map<std::string, Vec3> posed = {{"mA", {-0.2, 1, 0}},      {"mA2", {-0.1, 0.9, -0.1}},
                                             {"mB", {-0.3, 0.9, 0.1}},  {"mC", {-0.4, 0.9, -0.2}},
                                             {"mD", {-0.4, 0.9, -0.3}}, {"mE", {-0.1, 0.48, -0.2 - f}}};
  for (const auto& [name, p] : posed)
    EXPECT_LT((markerPosition(sys, *ws, name) - p).norm(), 1e-9) << name << ": " << markerPosition(sys, *ws, name).transpose();
  // The coupler q_c_tz = 2 (0.5 q_slide + 0.01) holds at 0.32, and Simbody sees a violation otherwise.
  EXPECT_LT(std::abs(sys.calcCouplerErrors(*ws)[0]), 1e-15);
  sys.realizePosition(*ws, coordinates(m, {{"q_slide", 0.3}, {"q_c_tz", 0.30}}));
  EXPECT_NEAR(sys.calcCouplerErrors(*ws)[0], 0.02, 1e-15);
}

TEST(System, Reverse30000GivesHandDerivedMarkerPositions) {
  System sys(model::readOsim(test::sourcePath("tests/model/fixtures/reverse30000.osim")));
  auto ws = sys.createWorkspace();
  sys.realizePosition(*ws, coordinates(sys.getModel(), {{"q_rev", 0.0}}));
  EXPECT_LT((markerPosition(sys, *ws, "mP") - Vec3(-0.2, 0.6, 0)).norm(), 1e-9);
  EXPECT_LT((markerPosition(sys, *ws, "mQ") - Vec3(-0.3, 0.6, 0)).norm(), 1e-9);
  sys.realizePosition(*ws, coordinates(sys.getModel(), {{"q_rev", M_PI / 2}}));
  EXPECT_LT((markerPosition(sys, *ws, "mP") - Vec3(0.1, 0.7, 0)).norm(), 1e-9);
  EXPECT_LT((markerPosition(sys, *ws, "mQ") - Vec3(0.1, 0.8, 0)).norm(), 1e-9);
}

TEST(System, UrdfChainGivesHandDerivedLinkPositions) {
  System sys(model::readUrdf(test::sourcePath("tests/model/fixtures/chain.urdf")));
  const model::Model& m = sys.getModel();
  auto ws = sys.createWorkspace();
  // Link origins and the point P4 = (0.1, 0, 0) of l4, configurations Z and P.
  const std::map<std::string, std::pair<Vec3, Vec3>> links = {{"l1", {{0, 0, 0.5}, {0, 0, 0.5}}},
                                                              {"l2", {{0, 0.2, 0.5}, {0.3, 0.2, 0.5}}},
                                                              {"l3", {{0.1, 0.2, 0.5}, {0.3, 0.2, 0.4}}},
                                                              {"l4", {{0, 0.2, 0.5}, {0.3, 0.2, 0.5}}}};
  sys.realizePosition(*ws, coordinates(m, {}));
  for (const auto& [name, p] : links)
    EXPECT_LT((sys.findStationLocation(*ws, m.findBody(name), Vec3::Zero()) - p.first).norm(), 1e-9) << name;
  EXPECT_LT((sys.findStationLocation(*ws, m.findBody("l4"), Vec3(0.1, 0, 0)) - Vec3(-0.1, 0.2, 0.5)).norm(), 1e-9);
  sys.realizePosition(*ws, coordinates(m, {{"j_rev", M_PI / 2}, {"j_pri", 0.3}, {"j_cont", M_PI / 2}}));
  for (const auto& [name, p] : links)
    EXPECT_LT((sys.findStationLocation(*ws, m.findBody(name), Vec3::Zero()) - p.second).norm(), 1e-9) << name;
  EXPECT_LT((sys.findStationLocation(*ws, m.findBody("l4"), Vec3(0.1, 0, 0)) - Vec3(0.4, 0.2, 0.5)).norm(), 1e-9);
  // R_l4 = [1 0 0; 0 0 1; 0 -1 0] in configuration P.
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  EXPECT_LT((sys.getBodyPose(*ws, m.findBody("l4")).linear() - R).norm(), 1e-9);
}

// Station Jacobians against central differences, for every joint type, including those whose
// q are Euler angles with qdot != u (Gimbal; Ball and Free with Simbody's Euler angles).
void expectJacobianMatchesDifferences(const System& sys, const Eigen::VectorXd& q) {
  const model::Model& m = sys.getModel();
  auto ws = sys.createWorkspace();
  std::vector<int> bodies;
  std::vector<Vec3> stations;
  for (size_t b = 1; b < m.bodies.size(); ++b) {
    bodies.push_back(int(b));
    stations.push_back(Vec3(0.05 * b, -0.1, 0.03));
  }
  Eigen::MatrixXd J(3 * bodies.size(), q.size());
  sys.realizePosition(*ws, q);
  sys.calcStationJacobian(*ws, bodies, stations, J);
  const double h = 1e-6;
  for (int c = 0; c < q.size(); ++c) {
    Eigen::VectorXd qp = q, qm = q;
    qp[c] += h;
    qm[c] -= h;
    for (size_t i = 0; i < bodies.size(); ++i) {
      sys.realizePosition(*ws, qp);
      const Vec3 pp = sys.findStationLocation(*ws, bodies[i], stations[i]);
      sys.realizePosition(*ws, qm);
      const Vec3 pm = sys.findStationLocation(*ws, bodies[i], stations[i]);
      EXPECT_LT((J.block<3, 1>(3 * i, c) - (pp - pm) / (2 * h)).norm(), 1e-8)
          << "coordinate " << m.coordinates[c].name << ", body " << m.bodies[bodies[i]].name;
    }
  }
}

TEST(System, StationJacobianOfGimbalUniversalAndCustomJoints) {
  System sys(model::readOsim(test::sourcePath("tests/model/fixtures/chain40000.osim")));
  Eigen::VectorXd q(sys.getNumCoordinates());
  q << 0.3, 0.1, 0.4, -0.7, 1.1, 0.2, -0.5, 0.8, 0.05;
  expectJacobianMatchesDifferences(sys, q);
}

TEST(System, StationJacobianOfBallAndFreeJoints) {
  // ground -Free-> A -Ball-> B, coordinates in OpenSim's order (rx ry rz [tx ty tz]).
  auto m = std::make_shared<model::Model>();
  m->bodies.resize(3);
  const char* names[] = {"ground", "A", "B"};
  for (int i = 0; i < 3; ++i) {
    m->bodies[i].name = names[i];
    m->bodies[i].mass = i ? 1.0 : 0.0;
    m->bodies[i].inertia = model::Mat3::Identity() * (i ? 0.01 : 0.0);
  }
  auto joint = [&](const char* name, model::JointType type, int parent, int child, int n) {
    model::Joint j;
    j.name = name;
    j.type = type;
    j.parent_body = parent;
    j.child_body = child;
    j.X_PF = model::poseFromXYZ(Vec3(0.2, -0.1, 0.3), Vec3(0.1, 0.2, 0.0));
    j.X_BM = model::poseFromXYZ(Vec3(-0.3, 0.0, 0.1), Vec3(0.0, -0.1, 0.05));
    for (int k = 0; k < n; ++k) {
      model::Coordinate c;
      c.name = std::string(name) + std::to_string(k);
      c.motion_type = k < 3 ? model::MotionType::Rotational : model::MotionType::Translational;
      c.joint = int(m->joints.size());
      m->coordinates.push_back(c);
      j.coordinates.push_back(int(m->coordinates.size()) - 1);
    }
    m->joints.push_back(j);
  };
  joint("free", model::JointType::Free, 0, 1, 6);
  joint("ball", model::JointType::Ball, 1, 2, 3);
  m->finalize();
  System sys(m);
  EXPECT_FALSE(sys.isQDotEqualToU());
  Eigen::VectorXd q(9);
  q << 0.3, -0.4, 0.7, 0.1, 0.9, -0.2, -0.6, 0.5, 1.2;
  expectJacobianMatchesDifferences(sys, q);
}

// kneesim's Custom mobilizer for CustomJoints against Simbody's FunctionBased mobilizer, which
// OpenSim uses: the same marker positions and Jacobians on the models of OpenSim's IK tests
// (SimmSpline-coupled knees, NaturalCubicSpline and PiecewiseLinear axes, reversed joints).
void expectSameAsFunctionBased(const std::string& path, int samples) {
  SCOPED_TRACE(path);
  const model::ModelPtr m = model::readOsim(path);
  System lean(m), reference(m, SystemOptions{true});
  auto w1 = lean.createWorkspace(), w2 = reference.createWorkspace();
  std::vector<int> bodies;
  std::vector<Vec3> stations;
  for (const auto& mk : m->markers) {
    bodies.push_back(mk.body);
    stations.push_back(mk.p_BM);
  }
  Eigen::MatrixXd J1(3 * bodies.size(), m->coordinates.size()), J2 = J1;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int s = 0; s < samples; ++s) {
    Eigen::VectorXd q = lean.getDefaultCoordinates();
    for (int c = 0; c < q.size(); ++c) q[c] += 0.5 * u(rng);
    lean.realizePosition(*w1, q);
    reference.realizePosition(*w2, q);
    for (size_t i = 0; i < bodies.size(); ++i)
      ASSERT_LT((lean.findStationLocation(*w1, bodies[i], stations[i]) -
                 reference.findStationLocation(*w2, bodies[i], stations[i])).norm(), 1e-12)
          << m->markers[i].name;
    lean.calcStationJacobian(*w1, bodies, stations, J1);
    reference.calcStationJacobian(*w2, bodies, stations, J2);
    ASSERT_LT((J1 - J2).cwiseAbs().maxCoeff(), 1e-12);
    const Eigen::VectorXd e1 = lean.calcCouplerErrors(*w1), e2 = reference.calcCouplerErrors(*w2);
    ASSERT_EQ(e1.size(), Eigen::Index(m->couplers.size()));
    if (e1.size() > 0) {
      ASSERT_LT((e1 - e2).cwiseAbs().maxCoeff(), 1e-12);
    }
  }
}

TEST(System, CustomMobilizerMatchesSimbodyFunctionBasedOnFixtures) {
  expectSameAsFunctionBased(test::sourcePath("tests/model/fixtures/chain40000.osim"), 20);
  expectSameAsFunctionBased(test::sourcePath("tests/model/fixtures/reverse30000.osim"), 20);
}

TEST(System, CustomMobilizerMatchesSimbodyFunctionBasedOnOpenSimModels) {
  KNEESIM_REQUIRE_DATA("opensim-ik-tests/subject01_simbody.osim");
  expectSameAsFunctionBased(test::dataPath("opensim-ik-tests/subject01_simbody.osim"), 20);
  expectSameAsFunctionBased(test::dataPath("opensim-ik-tests/constraintTest_ikOnly.osim"), 20);
  expectSameAsFunctionBased(test::dataPath("kgc4-jw/model/jw_all_body_scaled.osim"), 20);
}

// Body accelerations from J qddot + Jdot qdot against central differences of the body
// velocities along q(t) = q0 + v t + a t^2 / 2, on the fixture with Pin, Slider, Gimbal,
// Universal and a SIMM-spline CustomJoint; the mobility axes against differences of the poses.
TEST(System, BodyAccelerationsAndAxesMatchFiniteDifferences) {
  System sys(model::readOsim(test::sourcePath("tests/model/fixtures/chain40000.osim")));
  const model::Model& m = sys.getModel();
  auto ws = sys.createWorkspace();
  sys.setCouplersEnabled(*ws, false);
  const int n = sys.getNumCoordinates();
  Eigen::VectorXd q0(n), v(n), a(n);
  for (int c = 0; c < n; ++c) {
    q0[c] = 0.3 * std::sin(1.0 + c);
    v[c] = 0.8 * std::cos(2.0 + c);
    a[c] = 1.5 * std::sin(3.0 * c);
  }
  auto velocities = [&](double t, SpatialColumns& V) {
    sys.realizeVelocity(*ws, q0 + v * t + 0.5 * a * t * t, v + a * t);
    for (size_t b = 0; b < m.bodies.size(); ++b) V.col(b) = sys.getBodyVelocity(*ws, int(b));
  };
  const double h = 1e-5;
  SpatialColumns Vp(6, m.bodies.size()), Vm(6, m.bodies.size()), A(6, m.bodies.size());
  velocities(h, Vp);
  velocities(-h, Vm);
  sys.realizeVelocity(*ws, q0, v);
  TreeKinematics kin;
  sys.calcTreeKinematics(*ws, kin);
  calcBodyAccelerations(m, kin, a, A);
  for (size_t b = 1; b < m.bodies.size(); ++b)
    EXPECT_LT((A.col(b) - (Vp.col(b) - Vm.col(b)) / (2 * h)).norm(), 1e-6) << m.bodies[b].name;
  for (int c = 0; c < n; ++c) {
    const int b = m.joints[m.coordinates[c].joint].child_body, p = m.joints[m.coordinates[c].joint].parent_body;
    Eigen::VectorXd e = Eigen::VectorXd::Zero(n);
    e[c] = 1;
    sys.realizeVelocity(*ws, q0, e);
    Eigen::Matrix<double, 6, 1> rel = sys.getBodyVelocity(*ws, b) - sys.getBodyVelocity(*ws, p);
    const Eigen::Vector3d r = sys.getBodyPose(*ws, b).translation() - sys.getBodyPose(*ws, p).translation();
    rel.tail<3>() -= sys.getBodyVelocity(*ws, p).head<3>().cross(r);  // the parent's rotation carries b
    EXPECT_LT((sys.getMobilityAxis(*ws, c) - rel).norm(), 1e-12) << m.coordinates[c].name;
  }
}

// ScapulothoracicJoint (Simbody's Ellipsoid, Pin and Weld chained through two massless bodies)
// and EllipsoidJoint against the plain-Eigen kinematics written from OpenSim's source
// (tests/model/kinematics.hpp), at poses away from every axis; their station Jacobians against
// central differences (the Ellipsoid mobilizer has qdot != u).
TEST(System, ScapulothoracicAndEllipsoidJointsMatchOpenSimsDefinition) {
  auto model = model::readOsim(test::sourcePath("tests/model/fixtures/shoulder40000.osim"));
  System sys(model);
  auto ws = sys.createWorkspace();
  const model::Model& m = *model;
  for (int trial = 0; trial < 3; ++trial) {
    std::vector<double> q(m.coordinates.size());
    for (size_t c = 0; c < q.size(); ++c) q[c] = 0.4 * std::sin(1.3 * double(c) + 0.9 * trial) + 0.05 * trial;
    Eigen::VectorXd qe = Eigen::Map<const Eigen::VectorXd>(q.data(), Eigen::Index(q.size()));
    sys.realizePosition(*ws, qe);
    const std::vector<Pose> X = test::bodyPoses(m, q);
    for (size_t b = 1; b < m.bodies.size(); ++b) {
      const Pose S = sys.getBodyPose(*ws, int(b));
      EXPECT_LT((S.translation() - X[b].translation()).norm(), 1e-12) << m.bodies[b].name;
      EXPECT_LT((S.linear() - X[b].linear()).norm(), 1e-12) << m.bodies[b].name;
    }
    expectJacobianMatchesDifferences(sys, qe);
  }
}

// A joint whose child is already another joint's child, from a body no joint has as child
// (dennis_hopper's knee: parent shank, child thigh, the hip's child): OpenSim's multibody graph
// uses it from the thigh, as Simbody's Reverse mobilizer, and its coordinate keeps the file's
// sense: X_{b_offset a_offset} = Rz(qb). By hand, b's origin is Rz(qa) ((1,0,0) + Rz(-qb) (0,-0.5,0)).
TEST(System, JointWrittenChildToParentIsUsedFromItsChild) {
  auto pin = [](const std::string& name, const std::string& parent, const std::string& child,
                const std::string& frames, const std::string& q) {
    return "<PinJoint name=\"" + name + "\"><socket_parent_frame>" + parent + "</socket_parent_frame>"
           "<socket_child_frame>" + child + "</socket_child_frame><coordinates><Coordinate name=\"" + q +
           "\"/></coordinates><frames>" + frames + "</frames></PinJoint>\n";
  };
  auto frame = [](const std::string& name, const std::string& parent, const std::string& t) {
    return "<PhysicalOffsetFrame name=\"" + name + "\"><socket_parent>" + parent + "</socket_parent><translation>" +
           t + "</translation></PhysicalOffsetFrame>";
  };
  auto body = [](const std::string& name) {
    return "<Body name=\"" + name + "\"><mass>1</mass><inertia>1 1 1 0 0 0</inertia></Body>\n";
  };
  const std::string text =
      "<OpenSimDocument Version=\"40000\"><Model name=\"m\"><BodySet><objects>\n" + body("a") + body("b") +
      "</objects></BodySet><JointSet><objects>\n" + pin("ja", "/ground", "/bodyset/a", "", "qa") +
      pin("jb", "b_offset", "a_offset",
          frame("b_offset", "/bodyset/b", "0 0.5 0") + frame("a_offset", "/bodyset/a", "1 0 0"), "qb") +
      "</objects></JointSet></Model></OpenSimDocument>\n";
  model::ModelPtr mp = model::parseOsim(text, "reversed.osim");
  for (int pass = 0; pass < 2; ++pass) {  // as read, then written and read again
    const model::Model& m = *mp;
    const model::Joint& jb = m.joints[m.findJoint("jb")];
    EXPECT_TRUE(jb.reversed_in_tree);
    EXPECT_EQ(m.bodies[jb.parent_body].name, "a");
    EXPECT_EQ(m.bodies[jb.child_body].name, "b");
    System sys(mp);
    auto ws = sys.createWorkspace();
    const int b = m.findBody("b");
    const std::vector<std::array<double, 3>> cases = {
        {0, 0, 0}, {0, M_PI / 2, 0}, {M_PI / 2, M_PI / 2, 0}, {0.3, -0.7, 0}};
    for (const auto& c : cases) {
      const double qa = c[0], qb = c[1];
      sys.realizePosition(*ws, coordinates(m, {{"qa", qa}, {"qb", qb}}));
      const Vec3 inner = Vec3(1, 0, 0) + Vec3(0.5 * std::sin(-qb), -0.5 * std::cos(-qb), 0);  // Rz(-qb) (0,-0.5,0)
      const Vec3 want(inner.x() * std::cos(qa) - inner.y() * std::sin(qa),
                      inner.x() * std::sin(qa) + inner.y() * std::cos(qa), 0);
      const Vec3 got = sys.findStationLocation(*ws, b, Vec3::Zero());
      EXPECT_LT((got - want).norm(), 1e-12) << "pass " << pass << " qa " << qa << " qb " << qb << ": " << got.transpose();
      // The tests' plain forward kinematics agree.
      const auto X_G = test::bodyPoses(m, test::coordinateValues(m, {{"qa", qa}, {"qb", qb}}));
      EXPECT_LT((X_G[b].translation() - want).norm(), 1e-12);
    }
    const std::string written = model::formatOsim(m);
    EXPECT_NE(written.find("<socket_parent_frame>b_offset</socket_parent_frame>"), std::string::npos) << written;
    mp = model::parseOsim(written, "reversed_written.osim");
  }
}

}  // namespace
}  // namespace kneesim::sim
