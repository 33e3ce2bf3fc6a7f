// The knee's net load in clinical terms from a load in the tibial frame, by hand.
#include "dynamics/knee_loads.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

namespace kneesim::dynamics {
namespace {

TEST(KneeLoads, ClinicalComponentsFromTheTibialFrame) {
  // JW's implant frame: x posterior, y superior, z medial. The femur pushes the tibial component
  // down with 700 N and backwards with 50 N, medially with 20 N; moments 30 (about z, medial: a
  // flexing moment), 12 (about x, posterior: so -12 about anterior), 4 (about y: internal rotation).
  const KneeAxes a = parseKneeAxes("posterior superior medial");
  Eigen::MatrixX3d F(1, 3), M(1, 3);
  F << 50, -700, 20;
  M << 12, 4, 30;
  const io::Storage s = makeKneeLoadTable({0.5}, F, M, a);
  ASSERT_EQ(s.labels.size(), 7u);
  EXPECT_EQ(s.labels[1], "knee_axial_force");
  EXPECT_DOUBLE_EQ(s.data(0, 0), 0.5);
  EXPECT_DOUBLE_EQ(s.data(0, s.findColumn("knee_axial_force")), 700);  // compression positive
  EXPECT_DOUBLE_EQ(s.data(0, s.findColumn("knee_ap_force")), -50);     // anterior positive
  EXPECT_DOUBLE_EQ(s.data(0, s.findColumn("knee_ml_force")), 20);
  EXPECT_DOUBLE_EQ(s.data(0, s.findColumn("knee_flexion_moment")), 30);
  EXPECT_DOUBLE_EQ(s.data(0, s.findColumn("knee_adduction_moment")), -12);
  EXPECT_DOUBLE_EQ(s.data(0, s.findColumn("knee_rotation_moment")), 4);
  // Another frame naming the same directions gives the same numbers.
  const KneeAxes b = parseKneeAxes("Superior Lateral anterior");
  Eigen::MatrixX3d F2(1, 3), M2(1, 3);
  F2 << -700, -20, -50;
  M2 << 4, -30, -12;
  EXPECT_EQ(makeKneeLoadTable({0.5}, F2, M2, b).data, s.data);
}

TEST(KneeLoads, AxesMustNameThreeDirections) {
  EXPECT_THROW(parseKneeAxes("posterior superior"), std::invalid_argument);
  EXPECT_THROW(parseKneeAxes("posterior anterior medial"), std::invalid_argument);
  EXPECT_THROW(parseKneeAxes("posterior up medial"), std::invalid_argument);
}

}  // namespace
}  // namespace kneesim::dynamics
