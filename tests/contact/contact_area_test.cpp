// Contact area against closed forms: a sphere of radius R held at gap g above a plane (negative:
// pressed into it) leaves the plane closer than t to the sphere on the disc r^2 < (R+t)^2 - (R+g)^2,
// so S = pi ((R+t)^2 - (R+g)^2); its half discs have centroids 4 r_t / (3 pi) from the diameter.
// The discretisation error is bounded from the meshes: the faceted sphere lies up to its sag
// e = R (1 - cos(pi / nlat)) inside the true one, and linear interpolation over insert triangles
// with edges up to h misplaces the level line by at most h^2 / (8 (R+g)); either shifts the
// distance by delta and the area by about 2 pi (R+t) delta.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "contact/contact_area.hpp"
#include "contact/seating.hpp"
#include "contact/shapes.hpp"
#include "core/error.hpp"
#include "plugin/registry.hpp"
#include "support/test_data.hpp"

namespace kneesim::contact {
namespace {

using Eigen::Vector3d;

constexpr double kR = 0.03;        // sphere radius
constexpr double kH = 0.5e-3;      // insert grid step
constexpr int kLat = 180, kLon = 360;

// A flat insert: top y = 0 over x in [-25, 25] mm, z in [-40, 40] mm, 10 mm thick.
io::TriangleMesh makeFlatInsert() {
  std::vector<double> xs, zs;
  test::appendNodes(xs, -0.025, 0.025, kH);
  test::appendNodes(zs, -0.04, 0.04, kH);
  io::TriangleMesh m = test::makeHeightField(xs, zs, -0.01, [](double, double) { return 0.0; });
  m.source_file = "flat_insert";
  return m;
}

io::TriangleMesh makeBall(const Vector3d& c) {
  io::TriangleMesh m = test::makeSphere(c, kR, kLat, kLon);
  m.source_file = "ball";
  return m;
}

double discArea(double t, double g) { return M_PI * ((kR + t) * (kR + t) - (kR + g) * (kR + g)); }

// The closed-form error bound for threshold t and gap g (see the file comment).
double areaBound(double t, double g) {
  const double sag = kR * (1 - std::cos(M_PI / kLat));
  const double h = std::sqrt(2.0) * kH;  // longest edge: the cells' diagonals
  return 2 * M_PI * (kR + t) * (sag + h * h / (8 * (kR + g)));
}

Eigen::Isometry3d translation(const Vector3d& p) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = p;
  return X;
}

TEST(ContactArea, ChannelNames) {
  EXPECT_EQ(areaChannelName(4e-3), "S@4mm");
  EXPECT_EQ(areaChannelName(2.5e-3), "S@2.5mm");
  EXPECT_EQ(areaChannelName(0.003), "S@3mm");
  EXPECT_EQ(parseAreaRule("vertex_areas"), AreaRule::vertex_areas);
  EXPECT_THROW(parseAreaRule("triangles"), InputError);
}

// One sphere centred over the split plane, above, touching and pressed in: total area at five
// thresholds against the disc, the two half discs and their centroids, and the minimum distance.
TEST(ContactArea, SphereOnPlaneMatchesDiscArea) {
  ContactAreaOptions o;
  o.extra_thresholds = {2e-3, 3e-3, 5e-3, 6e-3};
  const ContactAreaCalculator calc(makeFlatInsert(), makeBall(Vector3d::Zero()), o);
  // The top face but its outermost ring of cells: the rim vertices' area-weighted normals are
  // dominated by the 10 mm sides (beyond 75 degrees from up), so those cells are not articular.
  EXPECT_NEAR(calc.getArticularArea(), 0.049 * 0.079, 1e-12);
  EXPECT_NEAR(calc.getArticularArea(CondyleSide::medial), 0.049 * 0.0395, 1e-12);
  auto ws = calc.createWorkspace();
  ContactFrame f;
  double worst = 0;
  for (double g : {1e-3, 0.0, -1.2e-3}) {
    const Vector3d x0(1.5e-3, kR + g, 0.0);  // a grid node under the sphere's lowest vertex
    calc.calcFrame(*ws, translation(x0), f);
    const double t = o.threshold;
    EXPECT_NEAR(f.S, discArea(t, g), areaBound(t, g)) << g;
    // The split plane halves the disc (up to the grid's diagonals, which are not mirror-symmetric).
    EXPECT_NEAR(f.S_medial, f.S / 2, areaBound(t, g) / 2);
    EXPECT_NEAR(f.S_lateral, f.S / 2, areaBound(t, g) / 2);
    EXPECT_NEAR(f.S_medial + f.S_lateral, f.S, 1e-15);
    // The plane's node under the sphere's pole; inside, the facets near the pole lie up to the
    // sag closer than the pole.
    const double sag = kR * (1 - std::cos(M_PI / kLat));
    EXPECT_NEAR(f.dmin, g, g < 0 ? sag : 1e-12);
    EXPECT_NEAR(f.dmin_medial, g, g < 0 ? sag : 1e-12);
    EXPECT_GE(f.dmin, g - 1e-12);  // the faceted sphere lies inside the true one
    const double r_t = std::sqrt((kR + t) * (kR + t) - (kR + g) * (kR + g));
    const double c = 4 * r_t / (3 * M_PI);  // centroid of a half disc from its diameter
    // The area error, all at the rim, moves the centroid by about (bound / S) r_t.
    const double tol_c = areaBound(t, g) / f.S * r_t;
    EXPECT_NEAR((f.centroid_medial - Vector3d(x0.x(), 0, c)).norm(), 0, tol_c) << g;
    EXPECT_NEAR((f.centroid_lateral - Vector3d(x0.x(), 0, -c)).norm(), 0, tol_c) << g;
    std::printf("[ area     ] centroid errors %.2e / %.2e m (tolerance %.2e m)\n",
                (f.centroid_medial - Vector3d(x0.x(), 0, c)).norm(), (f.centroid_lateral - Vector3d(x0.x(), 0, -c)).norm(),
                tol_c);
    for (size_t k = 0; k < o.extra_thresholds.size(); ++k) {
      const double te = o.extra_thresholds[k];
      EXPECT_NEAR(f.S_extra[k], discArea(te, g), areaBound(te, g)) << g << " " << te;
      worst = std::max(worst, std::abs(f.S_extra[k] - discArea(te, g)) / areaBound(te, g));
    }
    std::printf("[ area     ] g = %+.1f mm: S = %.3f mm^2, disc %.3f mm^2, bound %.3f mm^2\n", g * 1e3, f.S * 1e6,
                discArea(t, g) * 1e6, areaBound(t, g) * 1e6);
  }
  std::printf("[ area     ] worst error / bound over the extra thresholds: %.2f\n", worst);
  // Nothing closer than the threshold: the sphere 5 mm up.
  calc.calcFrame(*ws, translation(Vector3d(0, kR + 5e-3, 0)), f);
  EXPECT_EQ(f.S, 0.0);
  EXPECT_NEAR(f.dmin, 5e-3, 1e-12);
  EXPECT_TRUE(std::isnan(f.centroid_medial.x()));
  EXPECT_NEAR(f.S_extra[3], discArea(6e-3, 5e-3), areaBound(6e-3, 5e-3));
}

// Vertex areas: coarser (an error of the order of the boundary length times h/2), but close.
TEST(ContactArea, VertexAreaRuleIsWithinHalfAStepOfTheDisc) {
  ContactAreaOptions o;
  o.rule = AreaRule::vertex_areas;
  const ContactAreaCalculator calc(makeFlatInsert(), makeBall(Vector3d::Zero()), o);
  auto ws = calc.createWorkspace();
  ContactFrame f;
  calc.calcFrame(*ws, translation(Vector3d(0, kR, 0)), f);
  const double r_t = std::sqrt((kR + 4e-3) * (kR + 4e-3) - kR * kR);
  EXPECT_NEAR(f.S, discArea(4e-3, 0), 2 * M_PI * r_t * kH / 2);
  std::printf("[ area     ] vertex areas: S = %.3f mm^2, disc %.3f mm^2\n", f.S * 1e6, discArea(4e-3, 0) * 1e6);
}

// Two spheres, one per compartment, one above the plane and one pressed in: each compartment gets
// its own disc, minimum distance and centroid; the "fcl" provider and the exact MeshDistance agree.
TEST(ContactArea, TwoSpheresSplitMedialLateral) {
  io::TriangleMesh femur = makeBall(Vector3d(0, 0, 0.02));
  test::appendMesh(femur, makeBall(Vector3d(0, -0.0013, -0.02)));  // lateral ball 1.3 mm lower
  femur.source_file = "two_balls";
  const double g_m = 0.5e-3, g_l = g_m - 1.3e-3;
  plugin::Registry reg;
  reg.loadPlugin("distance_fcl");
  ContactAreaOptions o;
  o.extra_thresholds = {3e-3};
  const ContactAreaCalculator exact(makeFlatInsert(), femur, o);
  const ContactAreaCalculator fcl(makeFlatInsert(), femur, o, &reg.getDistanceProvider("fcl"));
  EXPECT_EQ(fcl.getDistanceMethod(), "fcl");
  EXPECT_EQ(exact.getDistanceMethod(), "MeshDistance");
  auto ws_e = exact.createWorkspace();
  auto ws_f = fcl.createWorkspace();
  ContactFrame fe, ff;
  for (double dx : {0.0, 1e-3, -2.5e-3}) {
    const Eigen::Isometry3d X_IF = translation(Vector3d(dx, kR + g_m, 0));
    exact.calcFrame(*ws_e, X_IF, fe);
    fcl.calcFrame(*ws_f, X_IF, ff);
    const double t = o.threshold;
    EXPECT_NEAR(fe.S_medial, discArea(t, g_m), areaBound(t, g_m));
    EXPECT_NEAR(fe.S_lateral, discArea(t, g_l), areaBound(t, g_l));
    EXPECT_NEAR(fe.S, fe.S_medial + fe.S_lateral, 1e-15);
    EXPECT_NEAR(fe.dmin_medial, g_m, 1e-12);
    EXPECT_NEAR(fe.dmin_lateral, g_l, kR * (1 - std::cos(M_PI / kLat)));  // inside: within the sag
    EXPECT_EQ(fe.dmin, fe.dmin_lateral);
    EXPECT_NEAR((fe.centroid_medial - Vector3d(dx, 0, 0.02)).norm(), 0, 0.02e-3);
    EXPECT_NEAR((fe.centroid_lateral - Vector3d(dx, 0, -0.02)).norm(), 0, 0.02e-3);
    EXPECT_NEAR(fe.S_extra[0], discArea(3e-3, g_m) + discArea(3e-3, g_l), areaBound(3e-3, g_m) + areaBound(3e-3, g_l));
    // Same distances, same areas.
    EXPECT_NEAR(ff.S, fe.S, 1e-15);
    EXPECT_NEAR(ff.S_medial, fe.S_medial, 1e-15);
    EXPECT_NEAR(ff.dmin_lateral, fe.dmin_lateral, 1e-15);
    EXPECT_NEAR(ff.S_extra[0], fe.S_extra[0], 1e-15);
    for (size_t i = 0; i < ws_e->getDistances().size(); ++i) {
      const double a = ws_e->getDistances()[i], b = ws_f->getDistances()[i];
      if (std::abs(a) <= exact.getSearchRadius()) {
        ASSERT_NEAR(b, a, 1e-12) << i;
      }
    }
  }
}

// A sphere sinking at constant speed v: dS/dt = 2 pi (R + g) v, from the central differences.
TEST(ContactArea, SeriesDerivativeMatchesSinkingSphere) {
  const ContactAreaCalculator calc(makeFlatInsert(), makeBall(Vector3d::Zero()));
  auto ws = calc.createWorkspace();
  const double v = 0.02;  // m/s
  std::vector<double> time;
  std::vector<Eigen::Isometry3d> poses;
  for (int k = 0; k <= 10; ++k) {
    time.push_back(0.01 * k);
    poses.push_back(translation(Vector3d(0, kR + 1e-3 - v * time.back(), 0)));
  }
  int calls = 0;
  const ContactSeries s = calcContactSeries(calc, *ws, time, poses, [&](int done, int total) {
    EXPECT_LE(done, total);
    ++calls;
  });
  EXPECT_GT(calls, 0);
  ASSERT_EQ(s.frames.size(), 11u);
  for (int k = 1; k < 10; ++k) {
    const double g = 1e-3 - v * time[size_t(k)];
    // S is quadratic in g, so the central difference is exact up to the discretisation noise.
    EXPECT_NEAR(s.dS_dt[size_t(k)], 2 * M_PI * (kR + g) * v, 0.02 * 2 * M_PI * kR * v) << k;
  }
  const auto channels = getContactChannels(s);
  EXPECT_EQ(channels.front().first, "time");
  EXPECT_EQ(channels.back().first, "dS_lateral_dt");
  EXPECT_EQ(channels.size(), 1u + 12u + 3u);
}

TEST(ContactArea, BadInputIsAnInputError) {
  ContactAreaOptions bad;
  bad.threshold = -1e-3;
  EXPECT_THROW(ContactAreaCalculator(makeFlatInsert(), makeBall(Vector3d::Zero()), bad), InputError);
  bad.threshold = 4e-3;
  bad.extra_thresholds = {std::nan("")};
  EXPECT_THROW(ContactAreaCalculator(makeFlatInsert(), makeBall(Vector3d::Zero()), bad), InputError);
  ContactAreaOptions sideways;  // medial along superior: not a set of anatomical directions
  sideways.insert_directions.medial = Vector3d::UnitY();
  EXPECT_THROW(ContactAreaCalculator(makeFlatInsert(), makeBall(Vector3d::Zero()), sideways), InputError);
  ContactAreaOptions shifted;  // an insert facing down: its "articular" bottom has no triangles on top
  shifted.insert_directions.superior = -Vector3d::UnitY();
  shifted.insert_directions.medial = -Vector3d::UnitZ();
  shifted.max_normal_angle = 10 * kDegree;
  const ContactAreaCalculator upside_down(makeFlatInsert(), makeBall(Vector3d::Zero()), shifted);
  EXPECT_NEAR(upside_down.getArticularArea(), 0.049 * 0.079, 1e-12);  // the bottom face instead
  const ContactAreaCalculator calc(makeFlatInsert(), makeBall(Vector3d::Zero()));
  auto ws = calc.createWorkspace();
  ContactFrame f;
  Eigen::Isometry3d skew = translation(Vector3d(0, kR, 0));
  skew.linear()(0, 1) = 0.3;
  EXPECT_THROW(calc.calcFrame(*ws, skew, f), InputError);
}

// JW's implant seated by the hinge kinematics: the "fcl" provider and MeshDistance give the same
// areas; the design is symmetric, so the compartments' areas are alike.
TEST(ContactArea, JwHingeKinematicsFclMatchesMeshDistance) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/implant/femoral_component.stl");
  const std::string dir = "kgc4-jw/implant/";
  io::TriangleMesh fem = io::readStl(test::dataPath(dir + "femoral_component.stl"), {1.0, true, 0.01, 0.5});
  io::TriangleMesh ins = io::readStl(test::dataPath(dir + "tibial_insert.stl"), {1.0, true, 0.01, 0.5});
  const CondyleFits fits = fitCondyles(fem, ArticularSelection{});
  Seater seater(makeSeatingSetup(fem, ins, fits.both.cylinder));
  const auto seats = seater.calcHingeKinematics({0.0, 30 * kDegree, 60 * kDegree});
  plugin::Registry reg;
  reg.loadPlugin("distance_fcl");
  ContactAreaOptions o;
  o.extra_thresholds = {2e-3, 3e-3, 5e-3, 6e-3};
  const ContactAreaCalculator exact(ins, fem, o);
  const ContactAreaCalculator fcl(ins, fem, o, &reg.getDistanceProvider("fcl"));
  std::printf("[ JW area  ] articular surface %.1f mm^2 (medial %.1f, lateral %.1f), %zu vertices, %zu triangles, "
              "search radius %.3f mm\n",
              exact.getArticularArea() * 1e6, exact.getArticularArea(CondyleSide::medial) * 1e6,
              exact.getArticularArea(CondyleSide::lateral) * 1e6, exact.getArticularVertices().size(),
              exact.getArticularTriangles().size(), exact.getSearchRadius() * 1e3);
  auto ws_e = exact.createWorkspace();
  auto ws_f = fcl.createWorkspace();
  ContactFrame fe, ff;
  for (const SeatingResult& s : seats) {
    exact.calcFrame(*ws_e, s.X_IF, fe);
    fcl.calcFrame(*ws_f, s.X_IF, ff);
    std::printf("[ JW area  ] %4.0f deg: S %.1f mm^2 (medial %.1f, lateral %.1f), S@2/3/5/6mm %.1f %.1f %.1f %.1f, "
                "dmin %.4f / %.4f mm\n",
                s.flexion / kDegree, fe.S * 1e6, fe.S_medial * 1e6, fe.S_lateral * 1e6, fe.S_extra[0] * 1e6,
                fe.S_extra[1] * 1e6, fe.S_extra[2] * 1e6, fe.S_extra[3] * 1e6, fe.dmin_medial * 1e3,
                fe.dmin_lateral * 1e3);
    EXPECT_NEAR(ff.S, fe.S, 1e-12);
    EXPECT_NEAR(ff.S_medial, fe.S_medial, 1e-12);
    EXPECT_NEAR(ff.S_extra[3], fe.S_extra[3], 1e-12);
    EXPECT_NEAR(ff.dmin, fe.dmin, 1e-12);
    EXPECT_NEAR(fe.S_medial / fe.S_lateral, 1.0, 0.2);
    // Seated: both condyles touch (gap 0 to the seating tolerance, over the vertices).
    EXPECT_NEAR(fe.dmin_medial, 0.0, 0.05e-3);
    EXPECT_NEAR(fe.dmin_lateral, 0.0, 0.05e-3);
    EXPECT_LT(fe.S_extra[0], fe.S_extra[1]);
    EXPECT_LT(fe.S, fe.S_extra[2]);
  }
}

}  // namespace
}  // namespace kneesim::contact
