#include "contact/mesh_distance.hpp"

#include <gtest/gtest.h>

#include <random>

#include "contact/shapes.hpp"
#include "core/error.hpp"

namespace kneesim::contact {
namespace {

using Eigen::Vector3d;

// Closed-form signed distance of an axis-aligned box (Quilez): the reference for the tree.
double boxSdf(const Vector3d& p, const Vector3d& lo, const Vector3d& hi) {
  const Vector3d c = 0.5 * (lo + hi), h = 0.5 * (hi - lo);
  const Vector3d q = (p - c).cwiseAbs() - h;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

TEST(TestShapes, AreClosedAndOutward) {
  for (const io::TriangleMesh& m :
       {test::makeBox(Vector3d(0, 0, 0), Vector3d(1, 2, 3)), test::makeSphere(Vector3d(1, 2, 3), 0.5, 18, 36),
        test::makeHeightField({-1, -0.5, 0, 0.2, 1}, {-2, -1, 0, 1, 1.5, 2}, -1,
                              [](double x, double z) { return 0.1 * x * x + 0.05 * z; })}) {
    EXPECT_EQ(m.calcEdgeReport().open, 0) << m.source_file;
    EXPECT_GT(m.calcVolume(), 0) << m.source_file;
  }
  EXPECT_NEAR(test::makeBox(Vector3d(0, 0, 0), Vector3d(1, 2, 3)).calcVolume(), 6.0, 1e-12);
  // Flat top at 0.5 over 2 x 4, bottom at -1: volume 2 * 4 * 1.5.
  EXPECT_NEAR(test::makeHeightField({-1, 0, 1}, {-2, 0.5, 2}, -1, [](double, double) { return 0.5; }).calcVolume(), 12.0,
              1e-12);
}

TEST(MeshDistance, MatchesClosedFormBoxEverywhere) {
  const Vector3d lo(-0.01, 0.0, -0.02), hi(0.03, 0.01, 0.02);
  const MeshDistance md(test::makeBox(lo, hi));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.04, 0.05);
  int inside = 0;
  for (int i = 0; i < 5000; ++i) {
    const Vector3d p(u(rng), u(rng) * 0.5, u(rng));
    const double expected = boxSdf(p, lo, hi);
    inside += expected < 0;
    MeshDistanceQuery q;
    ASSERT_TRUE(md.calcSignedDistance(p, 1.0, q));
    ASSERT_NEAR(q.distance, expected, 1e-15) << p.transpose();
    EXPECT_NEAR((q.closest - p).norm(), std::abs(expected), 1e-15);
  }
  EXPECT_GT(inside, 100);  // both signs exercised
  // Points exactly off an edge and a corner use edge and vertex pseudonormals.
  EXPECT_NEAR(md.calcSignedDistance(Vector3d(0.04, 0.02, 0.0)), std::sqrt(2.0) * 0.01, 1e-15);
  EXPECT_NEAR(md.calcSignedDistance(Vector3d(0.04, 0.02, 0.03)), std::sqrt(3.0) * 0.01, 1e-15);
  EXPECT_NEAR(md.calcSignedDistance(Vector3d(0.029, 0.009, 0.0)), -0.001, 1e-15);
}

TEST(MeshDistance, SphereWithinFacetSagAndBoundedSearch) {
  const double r = 0.02;
  const MeshDistance md(test::makeSphere(Vector3d::Zero(), r, 90, 180));
  // The facets of a 2-degree UV sphere lie at most r (1 - cos(1 deg) ^ 2) inside it.
  const double sag = r * (1 - std::pow(std::cos(M_PI / 180), 2));
  for (double d : {-0.015, -0.001, 0.0005, 0.01}) {
    const Vector3d p = (r + d) * Vector3d(0.3, -0.5, 0.7).normalized();
    const double got = md.calcSignedDistance(p);
    EXPECT_LE(got, d + sag + 1e-15);
    EXPECT_GE(got, d - 1e-15);
  }
  MeshDistanceQuery q;
  EXPECT_FALSE(md.calcSignedDistance(Vector3d(0, 0.05, 0), 0.01, q));
  EXPECT_TRUE(std::isinf(q.distance));
  EXPECT_TRUE(md.calcSignedDistance(Vector3d(0, 0.025, 0), 0.01, q));
  EXPECT_NEAR(q.distance, 0.005, 1e-15);  // the pole is a vertex
  EXPECT_NEAR(q.normal.y(), 1.0, 1e-12);
}

TEST(MeshDistance, RayHits) {
  const MeshDistance md(test::makeBox(Vector3d(0, 0, 0), Vector3d(1, 1, 1)));
  EXPECT_NEAR(md.calcRayHit(Vector3d(0.5, 0.5, 0.5), Vector3d(1, 0, 0), 0, 10), 0.5, 1e-15);
  EXPECT_NEAR(md.calcRayHit(Vector3d(-2, 0.3, 0.4), Vector3d(2, 0, 0), 0, 10), 1.0, 1e-15);  // t in units of d
  EXPECT_TRUE(std::isinf(md.calcRayHit(Vector3d(-2, 0.3, 0.4), Vector3d(-1, 0, 0), 0, 10)));
  EXPECT_TRUE(std::isinf(md.calcRayHit(Vector3d(-2, 0.3, 0.4), Vector3d(1, 0, 0), 0, 1.5)));
  // Leaving the surface from a surface point: only the far side is hit.
  EXPECT_NEAR(md.calcRayHit(Vector3d(0, 0.3, 0.4), Vector3d(1, 0, 0), 1e-9, 10), 1.0, 1e-15);
}

TEST(MeshDistance, EmptyMeshIsAnInputError) {
  io::TriangleMesh empty;
  empty.source_file = "empty.stl";
  EXPECT_THROW(MeshDistance{empty}, InputError);
}

}  // namespace
}  // namespace kneesim::contact
