// Ground reactions from C3D force plates: a synthetic pair of plates with hand-set loads (centre
// of pressure, free moment, threshold, rotation, foot assignment, summing, bad input), and JW's
// real trials (the right foot's plate, the body weight).
#include "dynamics/c3d_loads.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "support/input_error.hpp"
#include "support/test_data.hpp"

namespace kneesim::dynamics {
namespace {

using Vec3 = Eigen::Vector3d;

constexpr int kFrames = 100, kPerFrame = 10;  // 100 Hz markers, 1000 Hz analog

/// Two 1 m x 1 m type-2 plates side by side on the floor (z up), plate 1 centred at the origin,
/// plate 2 at x = 1; their frames are the lab's and their sensors sit at the surface centres.
/// Plate 1 carries F1 at cop1 with free moment tz1 from 0.20 to 0.70 s; plate 2 carries F2 at
/// cop2 from 0.50 to 0.90 s. Foot "r" (RHeel, RToe) stands over cop1, foot "l" over cop2.
io::C3dFile makePlates(const Vec3& F1, const Vec3& cop1, double tz1, const Vec3& F2, const Vec3& cop2) {
  io::C3dFile c;
  c.path = "synthetic.c3d";
  c.markers.labels = {"RHeel", "RToe", "LHeel", "LToe"};
  c.markers.rate = 100;
  c.markers.original_units = "mm";
  for (int f = 0; f < kFrames; ++f) {
    c.markers.time.push_back(f / 100.0);
    c.markers.frame_numbers.push_back(f + 1);
    for (const Vec3& p : {cop1 + Vec3(-0.1, 0, 0.05), cop1 + Vec3(0.1, 0, 0.05), cop2 + Vec3(-0.1, 0, 0.05),
                          cop2 + Vec3(0.1, 0, 0.05)})
      c.markers.positions.push_back(p);
  }
  io::AnalogTable& a = c.analog;
  a.rate = 1000;
  a.samples_per_frame = kPerFrame;
  const char* names[6] = {"Fx", "Fy", "Fz", "Mx", "My", "Mz"};
  for (int p = 0; p < 2; ++p)
    for (int k = 0; k < 6; ++k) {
      a.labels.push_back(std::string(names[k]) + std::to_string(p + 1));
      a.units.push_back(k < 3 ? "N" : "Nmm");
      a.descriptions.push_back("force plate");
    }
  a.data.setZero(kFrames * kPerFrame, 12);
  for (int s = 0; s < kFrames * kPerFrame; ++s) {
    const double t = s / 1000.0;
    a.time.push_back(t);
    auto put = [&](int p, const Vec3& F, const Vec3& cop_local, double tz) {
      const Vec3 M = cop_local.cross(F) + Vec3(0, 0, tz);  // about the surface centre, N m
      for (int k = 0; k < 3; ++k) {
        a.data(s, 6 * p + k) = F[k];
        a.data(s, 6 * p + 3 + k) = 1000 * M[k];  // N mm
      }
    };
    if (t >= 0.2 && t <= 0.7) put(0, F1, cop1, tz1);
    if (t >= 0.5 && t <= 0.9) put(1, F2, cop2 - Vec3(1, 0, 0), 0.0);
  }
  for (int p = 0; p < 2; ++p) {
    io::ForcePlate fp;
    fp.type = 2;
    const double x0 = p;
    fp.corners_m << x0 + 0.5, x0 - 0.5, x0 - 0.5, x0 + 0.5,  // c1 (+x,+y), c2 (-x,+y), c3, c4 (+x,-y)
        0.5, 0.5, -0.5, -0.5, 0, 0, 0, 0;
    fp.origin_m.setZero();
    fp.cal_matrix.setIdentity();
    for (int k = 0; k < 6; ++k) fp.channels.push_back(6 * p + k);
    c.plates.push_back(fp);
  }
  return c;
}

PlateLoadOptions twoFeet() {
  PlateLoadOptions o;
  o.cutoff_hz = -1;
  o.feet = {{"r", "calcn_r", {"RHeel", "RToe"}, {}}, {"l", "", {"LHeel", "LToe"}, {}}};
  return o;
}

Vec3 at(const io::Storage& s, int row, const std::string& prefix) {
  return Vec3(s.data(row, s.findColumn(prefix + "x")), s.data(row, s.findColumn(prefix + "y")),
              s.data(row, s.findColumn(prefix + "z")));
}

TEST(C3dLoads, ForcePointAndFreeMomentPerFootFromItsPlate) {
  const Vec3 F1(30, -20, 650), cop1(0.12, -0.07, 0), F2(-10, 5, 400), cop2(1.2, 0.1, 0);
  const GroundReactions g = calcGroundReactions(makePlates(F1, cop1, 2.5, F2, cop2), twoFeet());
  ASSERT_EQ(g.assignments.size(), 2u);
  EXPECT_EQ(g.assignments[0].plate, 0);
  EXPECT_EQ(g.assignments[0].foot, "r");
  EXPECT_NEAR(g.assignments[0].start, 0.2, 1e-12);
  EXPECT_NEAR(g.assignments[0].end, 0.7, 1e-12);
  EXPECT_EQ(g.assignments[1].foot, "l");
  const io::Storage& s = g.grf;
  const int loaded = 400, before = 100;
  EXPECT_LT((at(s, loaded, "r_ground_force_v") - F1).norm(), 1e-9);
  EXPECT_LT((at(s, loaded, "r_ground_force_p") - cop1).norm(), 1e-12);
  EXPECT_LT((at(s, loaded, "r_ground_torque_") - Vec3(0, 0, 2.5)).norm(), 1e-9);
  EXPECT_LT((at(s, 600, "l_ground_force_p") - cop2).norm(), 1e-12);
  // Unloaded: no force, the first centre of pressure held before it.
  EXPECT_EQ(at(s, before, "r_ground_force_v").norm(), 0.0);
  EXPECT_LT((at(s, before, "r_ground_force_p") - cop1).norm(), 1e-12);
  // Only the foot with a body becomes an ExternalForce.
  ASSERT_EQ(g.loads.forces.size(), 1u);
  EXPECT_EQ(g.loads.forces[0].applied_to_body, "calcn_r");
  EXPECT_EQ(g.loads.forces[0].point_identifier, "r_ground_force_p");
}

TEST(C3dLoads, OneFootOnTwoPlatesGetsTheirResultant) {
  // Both plates under foot "r": where both carry load the resultant acts between the two centres
  // of pressure, at the force-weighted mean (no free moment from vertical forces).
  const Vec3 F1(0, 0, 300), cop1(0.3, 0, 0), F2(0, 0, 100), cop2(0.7, 0, 0);
  PlateLoadOptions o = twoFeet();
  o.feet.resize(1);
  const GroundReactions g = calcGroundReactions(makePlates(F1, cop1, 0.0, F2, cop2), o);
  const int both = 600;
  EXPECT_LT((at(g.grf, both, "r_ground_force_v") - Vec3(0, 0, 400)).norm(), 1e-9);
  EXPECT_LT((at(g.grf, both, "r_ground_force_p") - Vec3(0.4, 0, 0)).norm(), 1e-12);
  EXPECT_LT(at(g.grf, both, "r_ground_torque_").norm(), 1e-9);
}

TEST(C3dLoads, ThresholdFilterAndRotation) {
  const Vec3 F1(0, 0, 15), cop1(0.1, 0.1, 0), F2(0, 0, 500), cop2(1.1, 0.0, 0);
  PlateLoadOptions o = twoFeet();
  // 15 N is below the 20 N threshold: plate 1 is never loaded.
  GroundReactions g = calcGroundReactions(makePlates(F1, cop1, 0.0, F2, cop2), o);
  ASSERT_EQ(g.assignments.size(), 1u);
  EXPECT_EQ(g.assignments[0].foot, "l");
  EXPECT_EQ(at(g.grf, 400, "r_ground_force_v").norm(), 0.0);
  // Z-up lab to a Y-up model: -90 deg about x takes (x, y, z) to (x, z, -y).
  o.rotation_deg = Vec3(-90, 0, 0);
  o.cutoff_hz = 30;
  g = calcGroundReactions(makePlates(F1, cop1, 0.0, F2, cop2), o);
  EXPECT_LT((at(g.grf, 700, "l_ground_force_v") - Vec3(0, 500, 0)).norm(), 1e-3);  // far from the steps
  EXPECT_LT((at(g.grf, 700, "l_ground_force_p") - Vec3(1.1, 0, 0)).norm(), 1e-6);
}

TEST(C3dLoads, BadInputIsOneLine) {
  const Vec3 F(0, 0, 500), c1(0.1, 0, 0), c2(1.1, 0, 0);
  io::C3dFile c = makePlates(F, c1, 0, F, c2);
  c.plates[1].type = 4;
  c.plates[1].has_cal_matrix = false;
  EXPECT_EQ(test::inputErrorOf([&] { calcGroundReactions(c, twoFeet()); }),
            "synthetic.c3d: FORCE_PLATFORM[2]/CAL_MATRIX: expected a calibration matrix for a TYPE 4 plate, got none");
  c = makePlates(F, c1, 0, F, c2);
  c.plates[0].type = 3;
  EXPECT_NE(test::inputErrorOf([&] { calcGroundReactions(c, twoFeet()); }).find("expected a six-component plate of TYPE 2 or 4, got TYPE 3"),
            std::string::npos);
  c = makePlates(F, c1, 0, F, c2);
  c.analog.data(300, 8) = std::nan("");
  EXPECT_EQ(test::inputErrorOf([&] { calcGroundReactions(c, twoFeet()); }),
            "synthetic.c3d: ANALOG[Fz2]: expected finite plate outputs, got nan at t = 0.3 s");
  c = makePlates(F, c1, 0, F, c2);
  PlateLoadOptions o = twoFeet();
  o.feet[1].markers = {"LHeel", "LAnkle"};
  EXPECT_NE(test::inputErrorOf([&] { calcGroundReactions(c, o); }).find("expected marker 'LAnkle' in synthetic.c3d, not found"),
            std::string::npos);
}

/// JW's trials: the plate under the right foot (its heel and toe markers) is plate 1 in the
/// stair ascent and plate 2 in gait (data/kgc4-jw/README.md, "stairs put the right foot on force
/// plate 0, gait on plate 1"), and in single support that foot carries about the body weight
/// (66.7 kg: 654 N), more at the peaks.
TEST(C3dLoads, JwRightFootPlates) {
  for (const auto& [trial, plate] : {std::pair<std::string, int>{"stairupf1", 0}, {"ngait_og3", 1}}) {
    const std::string path = test::dataPath("kgc4-jw/markers/jw_" + trial + ".c3d");
    KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_" + trial + ".c3d");
    PlateLoadOptions o = twoFeet();
    o.feet[0].body = "calcaneus";
    o.cutoff_hz = 30;
    const GroundReactions g = calcGroundReactions(io::readC3d(path), o);
    // The right foot's first stance; gait's next right step lands on plate 3.
    const PlateAssignment* first_right = nullptr;
    for (const PlateAssignment& a : g.assignments)
      if (a.foot == "r" && (!first_right || a.start < first_right->start)) first_right = &a;
    ASSERT_NE(first_right, nullptr) << trial;
    EXPECT_EQ(first_right->plate, plate) << trial;
    EXPECT_LT(first_right->distance_m, 0.05) << trial;  // the heel and toe markers over the plate's load
    double peak = 0;
    for (int s = 0; s < g.grf.getNumRows(); ++s) peak = std::max(peak, g.grf.data(s, g.grf.findColumn("r_ground_force_vz")));
    EXPECT_GT(peak, 654.0) << trial;
    EXPECT_LT(peak, 2.0 * 654.0) << trial;
  }
}

}  // namespace
}  // namespace kneesim::dynamics
