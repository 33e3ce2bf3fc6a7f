// Muscle paths against OpenSim's stored lengths, closed-form wrap geometry and finite
// differences of the length; and the hot loop's allocations.
#include "muscle/path.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "io/storage.hpp"
#include "model/osim_reader.hpp"
#include "muscle/static_optimization.hpp"
#include "support/allocation_counter.hpp"
#include "support/chain_model.hpp"
#include "support/jw_muscle_model.hpp"
#include "support/test_data.hpp"

using namespace kneesim;
using kneesim::test::dataPath;

namespace {

/// Coordinates of row @p r of an OpenSim 4 states table (columns /jointset/<joint>/<coord>/value).
Eigen::VectorXd coordinatesOf(const model::Model& m, const io::Storage& st, int r) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(int(m.coordinates.size()));
  for (size_t c = 0; c < m.coordinates.size(); ++c) {
    const model::Coordinate& co = m.coordinates[c];
    q[int(c)] = co.default_value;
    for (size_t k = 1; k < st.labels.size(); ++k) {
      const std::string& l = st.labels[k];
      const std::string tail = "/" + co.name + "/value";
      if (l == co.name || (l.size() > tail.size() && l.compare(l.size() - tail.size(), tail.size(), tail) == 0)) {
        double v = st.data(r, int(k));
        if (st.in_degrees && co.motion_type == model::MotionType::Rotational) v *= M_PI / 180.0;
        q[int(c)] = v;
      }
    }
  }
  return q;
}

}  // namespace

// OpenSim's testGeometryPathWrapping: the 18 muscles of gait10dof18musc (path points,
// conditional points on the hip, moving quadriceps insertions on the tibia) along a gait cycle,
// against the lengths OpenSim 4.4 stored, within OpenSim's own tolerance (1e-6 m).
TEST(PathSet, Gait1018MuscleLengthsMatchOpenSim) {
  KNEESIM_REQUIRE_DATA("opensim-dynamics-tests/wrapping/walk_gait1018_subject01.osim");
  const auto model = model::readOsim(dataPath("opensim-dynamics-tests/wrapping/walk_gait1018_subject01.osim"));
  ASSERT_EQ(model->muscles.size(), 18u);
  const io::Storage motion =
      io::readStorage(dataPath("opensim-dynamics-tests/wrapping/walk_gait1018_state_reference.mot"));
  const io::Storage ref = io::readStorage(
      dataPath("opensim-dynamics-tests/wrapping/std_testGeometryPathWrapping_walk_gait1018_muscle_lengths.sto"));
  ASSERT_EQ(motion.getNumRows(), ref.getNumRows());
  sim::System system(model);
  auto sws = system.createWorkspace();
  muscle::PathSet paths(system);
  auto ws = paths.createWorkspace();
  std::vector<double> max_err(model->muscles.size(), 0.0), sum_sq(model->muscles.size(), 0.0);
  for (int r = 0; r < motion.getNumRows(); ++r) {
    ASSERT_NEAR(motion.data(r, 0), ref.data(r, 0), 1e-6);
    const Eigen::VectorXd q = coordinatesOf(*model, motion, r);
    system.realizePosition(*sws, q);
    paths.realize(*sws, q, *ws);
    for (size_t i = 0; i < model->muscles.size(); ++i) {
      const int col = ref.findColumn("/forceset/" + model->muscles[i].name + "|length");
      ASSERT_GE(col, 0) << model->muscles[i].name;
      const double err = std::abs(paths.getLength(*ws, int(i)) - ref.data(r, col));
      max_err[i] = std::max(max_err[i], err);
      sum_sq[i] += err * err;
    }
  }
  for (size_t i = 0; i < model->muscles.size(); ++i) {
    EXPECT_LT(max_err[i], 1e-6) << model->muscles[i].name;  // OpenSim's own tolerance
    RecordProperty(model->muscles[i].name + "_max_error_m", std::to_string(max_err[i]));
    std::printf("%-14s max %.3g m  rms %.3g m\n", model->muscles[i].name.c_str(), max_err[i],
                std::sqrt(sum_sq[i] / motion.getNumRows()));
  }
}

namespace {

/// Whether the generalised-force method gives -dL/dq (to the 0.1 degree tangency OpenSim's
/// cylinder iterates to, about 1e-5 m) for path @p mu: OpenSim's
/// ellipsoid paths follow a plane section rather than a geodesic, and with several wrap
/// objects its passes stop once the length changes by less than 0.5 mm, so in those cases the
/// tangent points are not quite where the length is stationary and the two differ slightly.
bool isExactPath(const model::Model& m, const model::Muscle& mu) {
  for (const model::PathWrap& w : mu.path.wraps)
    if (m.wrap_objects[w.wrap_object].shape == model::WrapShape::Ellipsoid) return false;
  return mu.path.wraps.size() <= 1;
}

/// Generalised forces of each path against central differences of its length, -dL/dq, over
/// every coordinate moved alone at @p q. Returns the largest difference over the paths for
/// which isExactPath() is @p exact.
double maxMomentArmError(const sim::System& system, const Eigen::VectorXd& q, double h, std::string& worst,
                         bool exact = true) {
  const model::Model& m = system.getModel();
  auto sws = system.createWorkspace();
  muscle::PathSet paths(system);
  auto ws = paths.createWorkspace();
  const int n = int(m.coordinates.size()), np = paths.getNumPaths();
  Eigen::MatrixXd G(n, np), L_plus(n, np), L_minus(n, np);
  system.realizePosition(*sws, q);
  paths.realize(*sws, q, *ws);
  for (int i = 0; i < np; ++i) paths.calcGeneralizedForces(*sws, *ws, i, G.col(i));
  for (int c = 0; c < n; ++c)
    for (int s : {1, -1}) {
      Eigen::VectorXd qs = q;
      qs[c] += s * h;
      system.realizePosition(*sws, qs);
      paths.realize(*sws, qs, *ws);
      for (int i = 0; i < np; ++i) (s > 0 ? L_plus : L_minus)(c, i) = paths.getLength(*ws, i);
    }
  double worst_err = 0;
  for (int c = 0; c < n; ++c)
    for (int i = 0; i < np; ++i) {
      if (isExactPath(m, m.muscles[i]) != exact) continue;
      const double fd = -(L_plus(c, i) - L_minus(c, i)) / (2 * h);
      const double err = std::abs(G(c, i) - fd);
      if (err > worst_err) {
        worst_err = err;
        worst = m.muscles[i].name + " about " + m.coordinates[c].name + ": " + std::to_string(G(c, i)) + " vs " +
                std::to_string(fd);
      }
    }
  return worst_err;
}

}  // namespace

// Hand-derived: a path from the ground origin to B's origin in the test chain, where
// p_B = (0.5 cos q0, 1 + 0.5 sin q0, -q1): L^2 = 1.25 + sin q0 + q1^2, so
// -dL/dq0 = -cos q0 / (2 L) and -dL/dq1 = -q1 / L.
TEST(PathSet, ChainMomentArmsMatchHandDerivation) {
  auto m = test::makeChain(false, 40000);
  model::Muscle mu;
  mu.name = "m";
  mu.type = "Thelen2003Muscle";
  model::PathPoint a, b;
  a.body = 0;
  b.body = 2;
  mu.path.points = {a, b};
  m->muscles.push_back(mu);
  m->finalize();
  sim::System system(m);
  auto sws = system.createWorkspace();
  muscle::PathSet paths(system);
  auto ws = paths.createWorkspace();
  Eigen::VectorXd q = Eigen::VectorXd::Zero(3), g(3);
  q << 0.7, 0.2, 0.3;
  system.realizePosition(*sws, q);
  paths.realize(*sws, q, *ws);
  paths.calcGeneralizedForces(*sws, *ws, 0, g);
  const double L = std::sqrt(1.25 + std::sin(0.7) + 0.04);
  EXPECT_NEAR(paths.getLength(*ws, 0), L, 1e-14);
  EXPECT_NEAR(g[0], -std::cos(0.7) / (2 * L), 1e-14);
  EXPECT_NEAR(g[1], -0.2 / L, 1e-14);
  EXPECT_NEAR(g[2], 0.0, 1e-14);
}

// Moving quadriceps insertions and conditional points: the generalised-force moment arms equal
// the length's derivative (central differences, h = 1e-6).
TEST(PathSet, Gait1018MomentArmsMatchFiniteDifferences) {
  KNEESIM_REQUIRE_DATA("opensim-dynamics-tests/wrapping/walk_gait1018_subject01.osim");
  const auto model = model::readOsim(dataPath("opensim-dynamics-tests/wrapping/walk_gait1018_subject01.osim"));
  const io::Storage motion =
      io::readStorage(dataPath("opensim-dynamics-tests/wrapping/walk_gait1018_state_reference.mot"));
  sim::System system(model);
  for (int r : {0, 40, 75, 120}) {
    std::string worst;
    EXPECT_LT(maxMomentArmError(system, coordinatesOf(*model, motion, r), 1e-6, worst), 1e-8) << worst;
  }
}

// arm26: cylinders with and without quadrants (exact), and ellipsoids (hybrid, quadrants,
// ranges, a muscle over three objects), whose moment arms differ from the length's derivative
// by up to 3e-4 m (see isExactPath(); OpenSim's MomentArmSolver reports the same numbers).
TEST(PathSet, Arm26MomentArmsMatchFiniteDifferences) {
  KNEESIM_REQUIRE_DATA("opensim-dynamics-tests/so/arm26.osim");
  const auto model = model::readOsim(dataPath("opensim-dynamics-tests/so/arm26.osim"));
  ASSERT_EQ(model->muscles.size(), 6u);
  const io::Storage motion = io::readStorage(dataPath("opensim-dynamics-tests/so/arm26_InverseKinematics.mot"));
  sim::System system(model);
  for (int r : {0, 30, 60, 90, 120}) {
    const Eigen::VectorXd q = coordinatesOf(*model, motion, r);
    std::string worst;
    EXPECT_LT(maxMomentArmError(system, q, 1e-5, worst), 2e-5) << "row " << r << ": " << worst;
    EXPECT_LT(maxMomentArmError(system, q, 1e-5, worst, false), 3e-4) << "row " << r << ": " << worst;
  }
}

// JW's UF model: 54 Schutte muscles, 40 path wraps over 29 ellipsoids and 7 cylinders.
TEST(PathSet, JwPathsWrapAndTheirMomentArmsMatchFiniteDifferences) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/model/jw_all_body_scaled.osim");
  const auto model = model::readOsim(dataPath("kgc4-jw/model/jw_all_body_scaled.osim"));
  ASSERT_EQ(model->muscles.size(), 54u);
  size_t wraps = 0;
  for (const model::Muscle& mu : model->muscles) wraps += mu.path.wraps.size();
  EXPECT_EQ(wraps, 40u);
  sim::System system(model);
  auto sws = system.createWorkspace();
  muscle::PathSet paths(system);
  auto ws = paths.createWorkspace();
  Eigen::VectorXd q = system.getDefaultCoordinates();
  for (double flexion : {0.0, 0.6, 1.2}) {  // JW's knee flexes negatively
    q[model->findCoordinate("hip_flexion")] = 0.3 * flexion;
    q[model->findCoordinate("knee_flexion")] = -flexion;
    q[model->findCoordinate("ankle_angle")] = 0.2 * flexion;
    system.realizePosition(*sws, q);
    paths.realize(*sws, q, *ws);
    int wrapped = 0;
    for (int i = 0; i < paths.getNumPaths(); ++i) {
      EXPECT_TRUE(paths.getLength(*ws, i) > 0.01 && paths.getLength(*ws, i) < 1.0) << model->muscles[i].name;
      for (const muscle::CurrentPoint& p : paths.getCurrentPath(*ws, i)) wrapped += p.point < 0;
    }
    EXPECT_GT(wrapped, 10) << "tangent points at knee flexion " << flexion;
    std::string worst;
    EXPECT_LT(maxMomentArmError(system, q, 1e-5, worst), 2e-5) << "knee flexion " << flexion << ": " << worst;
    const double inexact = maxMomentArmError(system, q, 1e-5, worst, false);
    std::printf("knee flexion %.1f: ellipsoid/multi-wrap paths differ from -dL/dq by up to %.3g m (%s)\n", flexion,
                inexact, worst.c_str());
  }
}

// The hot loop allocates nothing: realising every path (wrapping included) and its generalised
// forces, frame after frame.
TEST(PathSet, RealizeAndGeneralizedForcesDoNotAllocate) {
  KNEESIM_REQUIRE_DATA("opensim-dynamics-tests/so/arm26.osim");
  const auto model = model::readOsim(dataPath("opensim-dynamics-tests/so/arm26.osim"));
  const io::Storage motion = io::readStorage(dataPath("opensim-dynamics-tests/so/arm26_InverseKinematics.mot"));
  sim::System system(model);
  auto sws = system.createWorkspace();
  muscle::PathSet paths(system);
  auto ws = paths.createWorkspace();
  std::vector<Eigen::VectorXd> qs;
  for (int r = 0; r < motion.getNumRows(); ++r) qs.push_back(coordinatesOf(*model, motion, r));
  Eigen::VectorXd g(model->coordinates.size());
  auto run = [&] {
    for (const Eigen::VectorXd& q : qs) {
      system.realizePosition(*sws, q);
      paths.realize(*sws, q, *ws);
      for (int i = 0; i < paths.getNumPaths(); ++i) paths.calcGeneralizedForces(*sws, *ws, i, g);
    }
  };
  run();  // first use sizes Simbody's caches
  EXPECT_EQ(test::countAllocations(run), 0);
}

// JW's 44 leg muscles (35 path wraps over 16 ellipsoids and 2 cylinders) on the 24-DOF knee model: the paths and
// their generalised forces allocate nothing frame after frame, nor does a whole static-optimisation
// frame (inverse dynamics, muscle forces, the exponent-2 quadratic programme warm-started). A
// sim::System's own realizePosition() of this model does allocate (8 per frame: Simbody 3.7's
// coupler constraints, ConstraintImpl::calcPositionErrorsFromState), so it is left out of the first
// count; static optimisation's inverse dynamics does not go through it. (The counter replaces
// operator new for the whole test binary, so the frame's check lives here.)
TEST(PathSet, JwPathsAndAStaticOptimizationFrameDoNotAllocate) {
  KNEESIM_REQUIRE_BUNDLED_DATA(test::kJwUfModel);
  const model::ModelPtr model = test::makeJwMuscleModel();
  const auto id = std::make_shared<const dynamics::InverseDynamics>(model);
  const muscle::StaticOptimization so(id, muscle::SoOptions{});
  auto so_ws = so.createWorkspace();
  sim::System system(model);
  auto sws = system.createWorkspace();
  muscle::PathSet paths(system);
  auto ws = paths.createWorkspace();
  const int n = int(model->coordinates.size());
  std::vector<Eigen::VectorXd> qs;
  for (int k = 0; k < 20; ++k) {  // knee flexion 0..95 degrees, the hip and ankle moving too
    Eigen::VectorXd q = system.getDefaultCoordinates();
    q[model->findCoordinate("knee_flexion")] = 0.087 * k;
    q[model->findCoordinate("hip_flexion")] = 0.3 * std::sin(0.3 * k);
    q[model->findCoordinate("ankle_angle")] = 0.2 * std::cos(0.3 * k);
    qs.push_back(q);
  }
  Eigen::VectorXd g(n), qdot = Eigen::VectorXd::Constant(n, 0.1), qddot = Eigen::VectorXd::Zero(n);
  auto frames = [&](bool count) {
    long paths_allocations = 0;
    for (const Eigen::VectorXd& q : qs) {
      system.realizePosition(*sws, q);
      auto one = [&] {
        paths.realize(*sws, q, *ws);
        for (int i = 0; i < paths.getNumPaths(); ++i) paths.calcGeneralizedForces(*sws, *ws, i, g);
      };
      if (count) paths_allocations += test::countAllocations(one); else one();
    }
    return paths_allocations;
  };
  frames(false);  // first use sizes Simbody's caches
  EXPECT_EQ(frames(true), 0);
  auto solve = [&] {
    for (const Eigen::VectorXd& q : qs) so.solveFrame(*so_ws, 0.0, q, qdot, qddot, nullptr);
  };
  solve();
  EXPECT_EQ(test::countAllocations(solve), 0);
  EXPECT_GT(so_ws->getForces().head(44).sum(), 0.0);  // the muscles did carry the frame
}

TEST(PathSet, OpenSim1MusclePointSetsGiveTheSamePathsAsGeometryPaths) {
  // arm26 as OpenSim 1.9 wrote it (MusclePointSet, MuscleWrapSet) and as OpenSim 2.3 wrote it
  // (GeometryPath): the same lengths at any pose.
  KNEESIM_REQUIRE_DATA("opensim-dynamics-tests/id/arm26.osim");
  KNEESIM_REQUIRE_DATA("opensim-dynamics-tests/so/arm26.osim");
  const auto old_model = model::readOsim(dataPath("opensim-dynamics-tests/id/arm26.osim"));
  const auto new_model = model::readOsim(dataPath("opensim-dynamics-tests/so/arm26.osim"));
  ASSERT_EQ(old_model->muscles.size(), 6u);
  ASSERT_EQ(new_model->muscles.size(), 6u);
  const sim::System old_sys(old_model), new_sys(new_model);
  const muscle::PathSet old_paths(old_sys), new_paths(new_sys);
  auto old_sws = old_sys.createWorkspace();
  auto new_sws = new_sys.createWorkspace();
  auto old_ws = old_paths.createWorkspace();
  auto new_ws = new_paths.createWorkspace();
  for (double elbow : {0.1, 1.0, 2.0}) {
    Eigen::VectorXd q(2);
    q << 0.3, elbow;
    old_sys.realizePosition(*old_sws, q);
    new_sys.realizePosition(*new_sws, q);
    old_paths.realize(*old_sws, q, *old_ws);
    new_paths.realize(*new_sws, q, *new_ws);
    for (int i = 0; i < 6; ++i) {
      EXPECT_EQ(old_model->muscles[i].path.wraps.size(), new_model->muscles[i].path.wraps.size());
      // 1e-7: the two files round some point coordinates differently (1e-8 m).
      EXPECT_NEAR(old_paths.getLength(*old_ws, i), new_paths.getLength(*new_ws, i), 1e-7) << old_model->muscles[i].name;
    }
  }
}

TEST(Couplers, AccelerationOfAChainOfCouplersIsTheHandDerivedCurvature) {
  // q1 free; q2 = f(q1) = 0.5 q1^2 + 0.2 q1; q3 = 2 g(q2), g(x) = x^2 - x. With q1'' = 0:
  // q2'' = f'' q1'^2 = q1'^2; q3'' = 2 (g' q2'' + g'' q2'^2), q2' = f' q1'.
  model::Model m;
  m.coordinates.resize(3);
  model::CoordinateCoupler a, b;
  a.dependent = 1;
  a.independents = {0};
  a.function = std::make_shared<model::PolynomialFunction>(std::vector<double>{0.5, 0.2, 0.0});
  b.dependent = 2;
  b.independents = {1};
  b.function = std::make_shared<model::PolynomialFunction>(std::vector<double>{1.0, -1.0, 0.0});
  b.scale_factor = 2.0;
  m.couplers = {b, a};  // the chain out of order: the passes must still settle it
  const double q1 = 0.7, u1 = 1.3;
  const double q2 = 0.5 * q1 * q1 + 0.2 * q1, u2 = (q1 + 0.2) * u1;
  Eigen::VectorXd q(3), u(3), d(3);
  q << q1, q2, 2 * (q2 * q2 - q2);
  u << u1, u2, 2 * (2 * q2 - 1) * u2;
  muscle::calcCouplingAcceleration(m, q, u, d);
  const double a2 = u1 * u1;
  EXPECT_NEAR(d[0], 0.0, 1e-15);
  EXPECT_NEAR(d[1], a2, 1e-12);
  EXPECT_NEAR(d[2], 2 * ((2 * q2 - 1) * a2 + 2 * u2 * u2), 1e-12);
}
