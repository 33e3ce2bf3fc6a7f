// The distance_fcl providers (plugins/distance_fcl) through DistanceField: closed forms (point to
// plane, point to sphere), the exact MeshDistance on analytic shapes and on JW's implant, poses
// in sequences that exercise the provider's memory of earlier calls, and bad input. "fcl" and
// "fcl_pruned" are exact (to rounding); "fcl_sdf" interpolates a cached grid and is checked
// against its stated tolerance.
#include <gtest/gtest.h>
#include <dlfcn.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <random>

#include "contact/condyle.hpp"
#include "contact/contact_area.hpp"
#include "contact/distance.hpp"
#include "contact/mesh_distance.hpp"
#include "contact/seating.hpp"
#include "core/error.hpp"
#include "plugin/registry.hpp"
#include "support/test_data.hpp"
#include "contact/shapes.hpp"

namespace kneesim::contact {
namespace {

using Eigen::Vector3d;

const kneesim_distance_provider& loadProvider(plugin::Registry& reg, const std::string& name = "fcl") {
  reg.loadPlugin("distance_fcl");
  return reg.getDistanceProvider(name);
}

Eigen::Isometry3d makePose(const Vector3d& axis_angle, const Vector3d& p) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  if (axis_angle.norm() > 0) X.linear() = Eigen::AngleAxisd(axis_angle.norm(), axis_angle.normalized()).toRotationMatrix();
  X.translation() = p;
  return X;
}

TEST(DistanceFcl, RegistersFastAndNaiveProviders) {
  plugin::Registry reg;
  reg.loadPlugin("distance_fcl");
  ASSERT_NE(reg.findDistanceProvider("fcl"), nullptr);
  ASSERT_NE(reg.findDistanceProvider("fcl_pruned"), nullptr);
  ASSERT_NE(reg.findDistanceProvider("fcl_naive"), nullptr);
  ASSERT_NE(reg.findDistanceProvider("fcl_sdf"), nullptr);
  EXPECT_NE(reg.findOrigin("fcl").find("libkneesim_distance_fcl.so"), std::string::npos);
}

// JW's femoral component and insert (metres), seated on the condyles' common cylinder, and the
// insert's articular vertices, medial then lateral: the points of the JW tests.
struct JwImplant {
  io::TriangleMesh fem, ins;
  SeatingSetup setup;
  std::vector<Vector3d> pts;
};
JwImplant loadJwImplant() {
  const std::string dir = "kgc4-jw/implant/";
  JwImplant jw;
  jw.fem = io::readStl(test::dataPath(dir + "femoral_component.stl"), {1.0, true, 0.01, 0.5});
  jw.ins = io::readStl(test::dataPath(dir + "tibial_insert.stl"), {1.0, true, 0.01, 0.5});
  jw.setup = makeSeatingSetup(jw.fem, jw.ins, fitCondyles(jw.fem, ArticularSelection{}).both.cylinder);
  jw.pts = getPositions(jw.setup.insert_medial_I);
  for (const Vector3d& p : getPositions(jw.setup.insert_lateral_I)) jw.pts.push_back(p);
  return jw;
}

// The block of the plane tests: its top is the plane y = 0 (100 x 100 mm, 50 mm deep, 1 mm grid);
// the points lie over its middle, off the grid nodes.
struct PlaneCase {
  io::TriangleMesh block;
  std::vector<Vector3d> pts;
  PlaneCase() {
    std::vector<double> xs, zs;
    test::appendNodes(xs, -0.05, 0.05, 1e-3);
    test::appendNodes(zs, -0.05, 0.05, 1e-3);
    block = test::makeHeightField(xs, zs, -0.05, [](double, double) { return 0.0; });
    for (int i = -10; i <= 10; ++i)
      for (int k = -10; k <= 10; ++k) pts.emplace_back(i * 1.37e-3, 0.0, k * 1.29e-3);
  }
};

// Moves the plane case's points by poses up and down through the surface, with small tilts and
// jumps that break coherence: within the 4 mm search radius (less margin) every distance is the
// height to tol and its closest point the foot on the plane; beyond it (plus margin) every point is
// on its side, penetration deeper than the radius included.
void expectPlaneThroughMovingPoses(DistanceField& field, const std::vector<Vector3d>& pts, double tol, double margin) {
  const double max_d = 4e-3;
  std::vector<double> d;
  std::vector<Vector3d> closest;
  const double heights[] = {8e-3, 6e-3, 4.5e-3, 3e-3, 1e-3, 0.2e-3, -0.5e-3, -2e-3, -3.9e-3, -4.2e-3, -7e-3,
                            -3e-3, 2e-3, 7.5e-3, -7.5e-3, 0.0, 3.99e-3};
  int frame = 0, near = 0, far_in = 0, far_out = 0;
  for (double h : heights) {
    const Eigen::Isometry3d X = makePose(Vector3d(0.02 * std::sin(frame), 0.3 * frame, 0.015), Vector3d(0, h, 0));
    field.calcDistances(X, max_d, d, &closest);
    for (size_t i = 0; i < pts.size(); ++i) {
      const Vector3d p = X * pts[i];
      const double exact = p.y();
      if (std::abs(exact) <= max_d - margin) {
        ++near;
        ASSERT_NEAR(d[i], exact, tol) << "frame " << frame << " point " << i;
        ASSERT_NEAR((closest[i] - Vector3d(p.x(), 0, p.z())).norm(), 0.0, tol);
      } else if (exact > max_d + margin) {
        ++far_out;
        ASSERT_GT(d[i], max_d) << "frame " << frame << " point " << i;
      } else if (exact < -max_d - margin) {
        ++far_in;
        ASSERT_LT(d[i], -max_d) << "frame " << frame << " point " << i;
      }
    }
    ++frame;
  }
  EXPECT_GT(near, 3000);
  EXPECT_GT(far_in, 1000);
  EXPECT_GT(far_out, 1000);
}

// A block whose top is the plane y = 0 (100 x 100 mm, 50 mm deep, 1 mm grid): points over its
// middle within 20 mm of the centre, at heights -8..8 mm, are closer to the top than to any side
// or the bottom, so their signed distance is exactly their height. The block is carried by the
// pose: the points are fixed in Q and the pose X_TQ moves them, as a moving insert would.
class DistanceProviders : public ::testing::TestWithParam<std::string> {};
INSTANTIATE_TEST_SUITE_P(Fcl, DistanceProviders, ::testing::Values("fcl", "fcl_pruned"));

TEST_P(DistanceProviders, PointToPlaneMatchesHeightThroughMovingPoses) {
  plugin::Registry reg;
  const PlaneCase pc;
  DistanceField field(loadProvider(reg, GetParam()), pc.block, pc.pts);
  ASSERT_EQ(field.getNumPoints(), int(pc.pts.size()));
  expectPlaneThroughMovingPoses(field, pc.pts, 1e-12, 0.0);
}

// A sphere of radius 30 mm (UV mesh, 80 x 160): distances agree with the exact MeshDistance on the
// same mesh to rounding, and with the true sphere |p - c| - R within the facets' sag
// R (1 - cos(pi / 80)) = 23 um. Points on shells inside and outside, the centre included (30 mm
// deep: the inside test of last resort).
TEST_P(DistanceProviders, PointToSphereMatchesExactMeshDistanceAndClosedForm) {
  plugin::Registry reg;
  const double R = 0.03;
  const Vector3d c(0.01, -0.02, 0.005);
  const io::TriangleMesh sphere = test::makeSphere(c, R, 80, 160);
  const MeshDistance exact(sphere);
  const double sag = R * (1 - std::cos(M_PI / 80));
  std::vector<Vector3d> pts = {Vector3d::Zero()};
  std::mt19937 rng(7);
  std::normal_distribution<double> g;
  for (int i = 0; i < 2000; ++i) {
    const Vector3d u = Vector3d(g(rng), g(rng), g(rng)).normalized();
    pts.push_back((R + (i % 41 - 20) * 0.5e-3) * u);  // radii R - 10 mm .. R + 10 mm, around Q's origin
  }
  DistanceField fast(loadProvider(reg, GetParam()), sphere, pts);
  DistanceField naive(loadProvider(reg, "fcl_naive"), sphere, pts);
  const double max_d = 5e-3;
  std::vector<double> d, dn;
  int checked = 0;
  for (int frame = 0; frame < 12; ++frame) {
    // The query shell's centre wanders around the sphere's centre by up to 2 mm and turns.
    const Eigen::Isometry3d X =
        makePose(Vector3d(0.1 * frame, -0.05 * frame, 0.2), c + 2e-3 * Vector3d(std::sin(frame), std::cos(2.0 * frame), 0.3));
    fast.calcDistances(X, max_d, d);
    naive.calcDistances(X, max_d, dn);
    for (size_t i = 0; i < pts.size(); ++i) {
      const Vector3d p = X * pts[i];
      const double ref = exact.calcSignedDistance(p);
      if (std::abs(ref) <= max_d) {
        ASSERT_NEAR(d[i], ref, 1e-12) << frame << " " << i;
        ASSERT_NEAR(dn[i], ref, 1e-12) << frame << " " << i;
        ASSERT_NEAR(d[i], (p - c).norm() - R, sag + 1e-12);
        ++checked;
      } else {
        ASSERT_TRUE(ref > 0 ? d[i] > max_d : d[i] < -max_d) << frame << " " << i << " " << ref << " " << d[i];
        ASSERT_NEAR(dn[i], ref, 1e-12);  // the naive provider always has the exact value
      }
    }
    EXPECT_LT(d[0], -max_d);  // the centre, 30 mm inside
  }
  EXPECT_GT(checked, 10000);
}

// An unbounded search radius gives every point its exact distance.
TEST_P(DistanceProviders, InfiniteSearchRadiusIsExactEverywhere) {
  plugin::Registry reg;
  const io::TriangleMesh box = test::makeBox(Vector3d(-0.01, -0.02, -0.03), Vector3d(0.02, 0.01, 0.0));
  const MeshDistance exact(box);
  std::vector<Vector3d> pts;
  for (int i = 0; i < 300; ++i) pts.emplace_back(-0.03 + 1e-4 * i, 0.013 * std::sin(i), -0.04 + 2.1e-4 * i);
  DistanceField field(loadProvider(reg, GetParam()), box, pts);
  std::vector<double> d;
  field.calcDistances(Eigen::Isometry3d::Identity(), std::numeric_limits<double>::infinity(), d);
  for (size_t i = 0; i < pts.size(); ++i) ASSERT_NEAR(d[i], exact.calcSignedDistance(pts[i]), 1e-12) << i;
}

TEST(DistanceFcl, BadInputIsAnInputError) {
  plugin::Registry reg;
  const kneesim_distance_provider& fcl = loadProvider(reg);
  io::TriangleMesh open = test::makeBox(Vector3d::Zero(), Vector3d::Ones() * 0.01);
  open.source_file = "open_box.stl";
  open.triangles.pop_back();
  const std::vector<Vector3d> pts = {Vector3d(0.02, 0, 0)};
  try {
    DistanceField f(fcl, open, pts);
    FAIL() << "an open mesh was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("open_box.stl"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("closed"), std::string::npos) << e.what();
  }
  io::TriangleMesh empty;
  empty.source_file = "empty.stl";
  EXPECT_THROW(DistanceField(fcl, empty, pts), InputError);

  const io::TriangleMesh box = test::makeBox(Vector3d::Zero(), Vector3d::Ones() * 0.01);
  DistanceField f(fcl, box, pts);
  std::vector<double> d;
  Eigen::Isometry3d skew = Eigen::Isometry3d::Identity();
  skew.linear()(0, 1) = 0.5;
  EXPECT_THROW(f.calcDistances(skew, 1e-3, d), InputError);
  EXPECT_THROW(f.calcDistances(Eigen::Isometry3d::Identity(), 0.0, d), InputError);
  EXPECT_THROW(f.calcDistances(Eigen::Isometry3d::Identity(), std::nan(""), d), InputError);
  f.calcDistances(Eigen::Isometry3d::Identity(), 1e-3, d);  // still usable
  EXPECT_GT(d[0], 1e-3);
}

// The C table itself, as a plugin author's caller would use it: every provider refuses null or
// negative arguments with a one-line reason and stays usable after refusing a bad pose.
TEST(DistanceFcl, EveryProviderRefusesBadArgumentsThroughItsCTable) {
  plugin::Registry reg;
  reg.loadPlugin("distance_fcl");
  const io::TriangleMesh box = test::makeBox(Vector3d::Zero(), Vector3d::Ones() * 0.01);
  std::vector<double> v;
  std::vector<int> tri;
  for (const auto& x : box.vertices) v.insert(v.end(), {x[0], x[1], x[2]});
  for (const auto& t : box.triangles) tri.insert(tri.end(), {t[0], t[1], t[2]});
  const kneesim_mesh_view view{box.getNumVertices(), v.data(), box.getNumTriangles(), tri.data()};
  const double p_Q[3] = {0.02, 0.005, 0.005};  // 10 mm outside the +x face of the 10 mm box
  const double I[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  for (const char* name : {"fcl", "fcl_pruned", "fcl_naive", "fcl_sdf"}) {
    SCOPED_TRACE(name);
    const kneesim_distance_provider& pr = reg.getDistanceProvider(name);
    char err[256] = "";
    EXPECT_EQ(pr.create(nullptr, 1, p_Q, err, int(sizeof err)), nullptr);
    EXPECT_STREQ(err, "expected a target mesh, got none");
    EXPECT_EQ(pr.create(&view, -1, p_Q, err, int(sizeof err)), nullptr);
    EXPECT_STREQ(err, "expected query points, got -1");
    EXPECT_EQ(pr.create(&view, 1, nullptr, err, int(sizeof err)), nullptr);
    EXPECT_STREQ(err, "expected query points, got 1");
    void* ctx = pr.create(&view, 1, p_Q, err, int(sizeof err));
    ASSERT_NE(ctx, nullptr) << err;
    double d = 0;
    EXPECT_EQ(pr.compute(nullptr, I, 0.02, &d, nullptr, err, int(sizeof err)), 1);
    EXPECT_STREQ(err, "expected a context, a pose and an output array, got a null pointer");
    EXPECT_EQ(pr.compute(ctx, I, 0.02, nullptr, nullptr, err, int(sizeof err)), 1);
    EXPECT_STREQ(err, "expected a context, a pose and an output array, got a null pointer");
    double nan_pose[12];
    std::copy(I, I + 12, nan_pose);
    nan_pose[3] = std::nan("");
    EXPECT_EQ(pr.compute(ctx, nan_pose, 0.02, &d, nullptr, err, int(sizeof err)), 1);
    EXPECT_STREQ(err, "expected a finite pose X_TQ, got a non-finite entry");
    EXPECT_EQ(pr.compute(ctx, I, -1.0, &d, nullptr, err, int(sizeof err)), 1);
    EXPECT_EQ(std::string(err).rfind("expected a positive max_distance, got -1", 0), 0u) << err;
    ASSERT_EQ(pr.compute(ctx, I, 0.02, &d, nullptr, err, int(sizeof err)), 0) << err;
    EXPECT_NEAR(d, 0.010, 2e-5);  // fcl_sdf's stated tolerance is 20 um; the others are exact
    pr.destroy(ctx);
  }
}

// JW's insert articular vertices against the femoral component, seated at several flexion
// angles and then pushed 1.5 mm into the insert: the provider agrees with MeshDistance exactly
// for every point within the search radius, and on the side of every other point.
TEST_P(DistanceProviders, JwInsertAgainstFemoralComponentMatchesMeshDistance) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/implant/femoral_component.stl");
  plugin::Registry reg;
  const JwImplant jw = loadJwImplant();
  const auto& [fem, ins, setup, pts] = jw;
  Seater seater(setup);
  const std::vector<SeatingResult> seats = seater.calcHingeKinematics({0.0, 20 * kDegree, 45 * kDegree});
  const MeshDistance exact(fem);
  DistanceField field(loadProvider(reg, GetParam()), fem, pts);
  const double max_d = 4e-3;
  std::vector<double> d;
  int near = 0, inside = 0;
  for (const SeatingResult& s : seats)
    for (double push : {0.0, 1.5e-3}) {
      Eigen::Isometry3d X_IF = s.X_IF;
      X_IF.translation().y() -= push;  // the femur sinks into the insert
      const Eigen::Isometry3d X_FI = X_IF.inverse();
      field.calcDistances(X_FI, max_d, d);
      for (size_t i = 0; i < pts.size(); ++i) {
        const double ref = exact.calcSignedDistance(X_FI * pts[i]);
        if (std::abs(ref) <= max_d) {
          ASSERT_NEAR(d[i], ref, 1e-12) << i;
          ++near;
          inside += ref < 0;
        } else {
          ASSERT_TRUE(ref > 0 ? d[i] > max_d : d[i] < -max_d) << i;
        }
      }
    }
  std::printf("[ JW fcl   ] %zu insert articular points, %d within 4 mm over 6 poses, %d of them inside\n", pts.size(),
              near, inside);
  EXPECT_GT(near, 1000);
  EXPECT_GT(inside, 100);
}

// The "fcl" provider walks its tree with eight points per AVX2 packet where the CPU allows, and
// one point at a time otherwise (or with KNEESIM_DISTANCE_FCL_SCALAR set): both find the closest
// triangle exactly, so their distances agree to rounding on JW's implant over a flexion sequence.
TEST(DistanceFcl, PacketAndScalarSearchesAgreeOnJw) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/implant/femoral_component.stl");
  plugin::Registry reg;
  const JwImplant jw = loadJwImplant();
  const auto& [fem, ins, setup, pts] = jw;
  const std::vector<SeatingResult> seats = Seater(setup).calcHingeKinematics({0.0, 10 * kDegree, 30 * kDegree});
  const kneesim_distance_provider& fcl = loadProvider(reg);
  DistanceField packets(fcl, fem, pts);
  ::setenv("KNEESIM_DISTANCE_FCL_SCALAR", "1", 1);
  DistanceField scalar(fcl, fem, pts);
  ::unsetenv("KNEESIM_DISTANCE_FCL_SCALAR");
  std::vector<double> a, b;
  int near = 0;
  for (const SeatingResult& s : seats) {
    const Eigen::Isometry3d X_FI = s.X_IF.inverse();
    packets.calcDistances(X_FI, 4e-3, a);
    scalar.calcDistances(X_FI, 4e-3, b);
    for (size_t i = 0; i < pts.size(); ++i) {
      if (std::isinf(a[i])) {
        ASSERT_EQ(a[i], b[i]) << i;
      } else {
        ASSERT_NEAR(a[i], b[i], 1e-15) << i;  // two triangles sharing the closest point: rounding apart
      }
      near += std::abs(a[i]) <= 4e-3;
    }
  }
  EXPECT_GT(near, 6000);
}

// ---- fcl_sdf: the cached distance grid ---------------------------------------------------------

// The grid's counters (kneesim_distance_fcl_get_sdf_stats): nodes evaluated, side queries, cells,
// exact cells, far cells, points interpolated, points exact, points far, resets, blocks.
std::vector<long long> getSdfStats(const plugin::Registry& reg, const DistanceField& f) {
  void* h = dlopen(reg.findOrigin("fcl_sdf").c_str(), RTLD_NOW | RTLD_NOLOAD);
  using Fn = int (*)(void*, long long*, int);
  Fn fn = h ? reinterpret_cast<Fn>(dlsym(h, "kneesim_distance_fcl_get_sdf_stats")) : nullptr;
  std::vector<long long> v(10, -1);
  if (fn) v.resize(size_t(fn(f.getProviderContext(), v.data(), 10)));
  if (h) dlclose(h);
  return v;
}

// On a plane the signed distance is linear, so trilinear interpolation reproduces it: the grid's
// values are exact to the float rounding of its nodes (4 mm * 2^-24 = 2.4e-10 m), through
// moving poses, penetration beyond the search radius included. Nearly every point is
// interpolated: the grid, not the exact fallback, is what is tested.
TEST(DistanceFclSdf, PlaneIsInterpolatedExactlyThroughMovingPoses) {
  plugin::Registry reg;
  const PlaneCase pc;
  DistanceField field(loadProvider(reg, "fcl_sdf"), pc.block, pc.pts);
  expectPlaneThroughMovingPoses(field, pc.pts, 1e-9, 1e-9);
  if (HasFatalFailure()) return;
  const std::vector<long long> s = getSdfStats(reg, field);
  ASSERT_EQ(s.size(), 10u);
  EXPECT_GT(s[5], 3000);        // points interpolated
  EXPECT_LT(s[6], s[5] / 100);  // points computed exactly: under 1% of them
}

// A sphere of radius 30 mm (UV mesh, 80 x 160, facets 2.25 deg apart): within the search radius
// every distance agrees with the exact MeshDistance to the provider's stated tolerance (20 um;
// the largest error is printed), beyond it every point is on its side; the centre, 30 mm deep,
// is found inside. An unbounded search radius takes the exact path.
TEST(DistanceFclSdf, SphereMatchesMeshDistanceWithinTolerance) {
  plugin::Registry reg;
  const double R = 0.03;
  const Vector3d c(0.01, -0.02, 0.005);
  const io::TriangleMesh sphere = test::makeSphere(c, R, 80, 160);
  const MeshDistance exact(sphere);
  std::vector<Vector3d> pts = {Vector3d::Zero()};
  std::mt19937 rng(7);
  std::normal_distribution<double> g;
  for (int i = 0; i < 2000; ++i) {
    const Vector3d u = Vector3d(g(rng), g(rng), g(rng)).normalized();
    pts.push_back((R + (i % 41 - 20) * 0.5e-3) * u);
  }
  DistanceField field(loadProvider(reg, "fcl_sdf"), sphere, pts);
  const double max_d = 5e-3, tolerance = 20e-6;
  std::vector<double> d;
  double worst = 0;
  int checked = 0;
  for (int frame = 0; frame < 12; ++frame) {
    const Eigen::Isometry3d X =
        makePose(Vector3d(0.1 * frame, -0.05 * frame, 0.2), c + 2e-3 * Vector3d(std::sin(frame), std::cos(2.0 * frame), 0.3));
    field.calcDistances(X, max_d, d);
    for (size_t i = 0; i < pts.size(); ++i) {
      const double ref = exact.calcSignedDistance(X * pts[i]);
      if (std::abs(ref) <= max_d) {
        worst = std::max(worst, std::abs(d[i] - ref));
        ASSERT_NEAR(d[i], ref, tolerance) << frame << " " << i;
        ++checked;
      } else {
        ASSERT_TRUE(ref > 0 ? d[i] > max_d - tolerance : d[i] < -max_d + tolerance) << frame << " " << i;
      }
    }
    EXPECT_LT(d[0], -max_d);
  }
  std::printf("[ sphere   ] fcl_sdf: largest |error| %.2f um over %d distances within 5 mm\n", worst * 1e6, checked);
  EXPECT_GT(checked, 10000);
  const std::vector<long long> s = getSdfStats(reg, field);
  EXPECT_GT(s[5], 9 * s[6]);  // at least 90% of the near points were interpolated

  field.calcDistances(Eigen::Isometry3d::Identity(), std::numeric_limits<double>::infinity(), d);
  for (size_t i = 0; i < pts.size(); ++i) ASSERT_NEAR(d[i], exact.calcSignedDistance(pts[i]), 1e-12) << i;
}

// A call with a wider search radius than the grid's band rebuilds the grid: the distances out to
// the new radius are then within tolerance too.
TEST(DistanceFclSdf, WiderSearchRadiusRebuildsTheBand) {
  plugin::Registry reg;
  const io::TriangleMesh box = test::makeBox(Vector3d(-0.01, -0.02, -0.03), Vector3d(0.02, 0.01, 0.0));
  const MeshDistance exact(box);
  std::vector<Vector3d> pts;
  for (int i = 0; i < 300; ++i) pts.emplace_back(0.021 + 2e-5 * i, 0.013 * std::sin(i) - 0.005, -0.015 + 3e-5 * i);
  DistanceField field(loadProvider(reg, "fcl_sdf"), box, pts);
  std::vector<double> d;
  field.calcDistances(Eigen::Isometry3d::Identity(), 2e-3, d);
  int beyond_2mm = 0;
  for (size_t i = 0; i < pts.size(); ++i) {
    const double ref = exact.calcSignedDistance(pts[i]);
    if (ref > 2e-3) {
      ++beyond_2mm;
      EXPECT_GT(d[i], 2e-3 - 20e-6);
    }
  }
  EXPECT_GT(beyond_2mm, 100);
  field.calcDistances(Eigen::Isometry3d::Identity(), 8e-3, d);
  for (size_t i = 0; i < pts.size(); ++i) {
    const double ref = exact.calcSignedDistance(pts[i]);
    if (std::abs(ref) <= 8e-3) {
      ASSERT_NEAR(d[i], ref, 20e-6) << i;
    }
  }
  const std::vector<long long> s = getSdfStats(reg, field);
  EXPECT_EQ(s[8], 1);  // one reset
}

// JW's insert articular vertices against the femoral component, seated at several flexion angles
// and pushed 1.5 mm into the insert: within the search radius every distance agrees with
// MeshDistance to the stated tolerance (20 um), beyond it every point is on its side; the
// contact areas computed with "fcl_sdf" and with the exact "fcl" (S, S_medial, S_lateral at 4 mm,
// S at 1 and 2 mm) differ by under 2 mm^2 (of 1000-2700 mm^2) and dmin by under the tolerance.
TEST(DistanceFclSdf, JwMatchesMeshDistanceAndContactAreaWithinTolerance) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/implant/femoral_component.stl");
  plugin::Registry reg;
  const JwImplant jw = loadJwImplant();
  const auto& [fem, ins, setup, pts] = jw;
  const std::vector<SeatingResult> seats = Seater(setup).calcHingeKinematics({0.0, 20 * kDegree, 45 * kDegree});
  const MeshDistance exact(fem);
  DistanceField field(loadProvider(reg, "fcl_sdf"), fem, pts);
  const double max_d = 4e-3, tolerance = 20e-6;
  std::vector<double> d;
  double worst = 0;
  int near = 0;
  std::vector<Eigen::Isometry3d> poses;
  for (const SeatingResult& s : seats)
    for (double push : {0.0, 1.5e-3}) {
      Eigen::Isometry3d X_IF = s.X_IF;
      X_IF.translation().y() -= push;
      poses.push_back(X_IF);
      const Eigen::Isometry3d X_FI = X_IF.inverse();
      field.calcDistances(X_FI, max_d, d);
      for (size_t i = 0; i < pts.size(); ++i) {
        const double ref = exact.calcSignedDistance(X_FI * pts[i]);
        if (std::abs(ref) <= max_d) {
          worst = std::max(worst, std::abs(d[i] - ref));
          ASSERT_NEAR(d[i], ref, tolerance) << i;
          ++near;
        } else {
          ASSERT_TRUE(ref > 0 ? d[i] > max_d - tolerance : d[i] < -max_d + tolerance) << i;
        }
      }
    }
  const std::vector<long long> s = getSdfStats(reg, field);
  std::printf("[ JW sdf   ] %d distances within 4 mm, largest |error| %.2f um; %lld interpolated, %lld exact\n", near,
              worst * 1e6, s[5], s[6]);
  EXPECT_GT(near, 1000);
  EXPECT_GT(s[5], 4 * s[6]);  // mostly interpolated

  ContactAreaOptions o;
  o.extra_thresholds = {1e-3, 2e-3};
  const ContactAreaCalculator with_sdf(ins, fem, o, &reg.getDistanceProvider("fcl_sdf"));
  const ContactAreaCalculator with_fcl(ins, fem, o, &reg.getDistanceProvider("fcl"));
  auto ws_sdf = with_sdf.createWorkspace(), ws_fcl = with_fcl.createWorkspace();
  ContactFrame a, b;
  double worst_S = 0;
  for (const Eigen::Isometry3d& X_IF : poses) {
    with_sdf.calcFrame(*ws_sdf, X_IF, a);
    with_fcl.calcFrame(*ws_fcl, X_IF, b);
    EXPECT_GT(b.S, 500e-6);
    for (double e : {a.S - b.S, a.S_medial - b.S_medial, a.S_lateral - b.S_lateral, a.S_extra[0] - b.S_extra[0],
                     a.S_extra[1] - b.S_extra[1]}) {
      worst_S = std::max(worst_S, std::abs(e));
      EXPECT_LT(std::abs(e), 2e-6);
    }
    EXPECT_NEAR(a.dmin, b.dmin, tolerance);
  }
  std::printf("[ JW sdf   ] contact areas: largest |S_sdf - S_fcl| %.3f mm^2\n", worst_S * 1e6);
}

}  // namespace
}  // namespace kneesim::contact
