// Gait events from force plates: a synthetic two-plate walk with spikes and a short drop (events
// known by construction) and JW's ngait_og3 (heel strikes as the model tests found them).
#include "io/gait_events.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "io_test_util.hpp"
#include "support/test_data.hpp"

namespace kneesim::io {
namespace {

using ::testing::HasSubstr;
using test_util::inputErrorOf;

// Plate p spans x in [x0, x0 + 0.6], y in [0, 0.4] with its z axis down (corner order of the JW
// plates), so a vertical load is a negative Fz channel.
ForcePlate makePlate(double x0, int first_channel) {
  ForcePlate p;
  p.type = 2;
  p.corners_m.col(0) = Eigen::Vector3d(x0, 0.4, 0);
  p.corners_m.col(1) = Eigen::Vector3d(x0 + 0.6, 0.4, 0);
  p.corners_m.col(2) = Eigen::Vector3d(x0 + 0.6, 0.0, 0);
  p.corners_m.col(3) = Eigen::Vector3d(x0, 0.0, 0);
  p.origin_m = Eigen::Vector3d(0, 0, -0.04);
  for (int k = 0; k < 6; ++k) p.channels.push_back(first_channel + k);
  p.cal_matrix.setIdentity();
  return p;
}

// 2 s at 100 Hz (markers) and 1000 Hz (analog). Plate A (x 0..0.6): the right foot from 0.300 to
// 0.950 s with a 5-ms drop at 0.600 s (one contact) and a 1-ms spike at 0.970 s (not a contact).
// Plate B (x -0.6..0): the other foot from 0.500 to 0.800 s while the right heel is over plate A,
// then the right foot from 1.400 s to the end (no toe-off). The right heel is over A until 1.2 s,
// then over B.
C3dFile makeWalk() {
  C3dFile c;
  c.path = "walk.c3d";
  c.markers.rate = 100;
  c.markers.resize(200, 1);
  c.markers.labels[0] = "RHeel";
  for (int f = 0; f < 200; ++f) {
    c.markers.frame_numbers[size_t(f)] = f + 1;
    c.markers.time[size_t(f)] = f / 100.0;
    c.markers.updPosition(f, 0) = f < 120 ? Eigen::Vector3d(0.3, 0.2, 0.05) : Eigen::Vector3d(-0.3, 0.2, 0.05);
  }
  c.analog.rate = 1000;
  c.analog.samples_per_frame = 10;
  const char* names[6] = {"Fx", "Fy", "Fz", "Mx", "My", "Mz"};
  for (int p = 0; p < 2; ++p)
    for (int k = 0; k < 6; ++k) {
      c.analog.labels.push_back(std::string(names[k]) + std::to_string(p + 1));
      c.analog.units.push_back(k < 3 ? "N" : "Nmm");
      c.analog.descriptions.push_back("");
    }
  c.analog.data = Eigen::MatrixXd::Zero(2000, 12);
  for (int s = 0; s < 2000; ++s) {
    c.analog.time.push_back(s / 1000.0);
    const bool a = (s >= 300 && s < 950 && !(s >= 600 && s < 605)) || s == 970;
    const bool b = (s >= 500 && s < 800) || s >= 1400;
    c.analog.data(s, 2) = a ? -600.0 : -2.0;
    c.analog.data(s, 8) = b ? -650.0 : -1.0;
  }
  c.plates = {makePlate(0.0, 0), makePlate(-0.6, 6)};
  return c;
}

TEST(GaitEvents, SyntheticWalkWithSpikesAndADrop) {
  const C3dFile c = makeWalk();
  const std::vector<FootContact> r = findFootContacts(c);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].plate, 0);
  EXPECT_NEAR(r[0].strike, 0.300, 1e-12);
  EXPECT_NEAR(r[0].off, 0.950, 1e-12);  // the 5-ms drop does not end it, the 1-ms spike is not one
  EXPECT_EQ(r[1].plate, 1);
  EXPECT_NEAR(r[1].strike, 1.400, 1e-12);  // not the other foot's 0.5 s contact
  EXPECT_TRUE(std::isnan(r[1].off));
  const GaitCycle g = findGaitCycle(r);
  ASSERT_TRUE(g.isComplete());
  EXPECT_NEAR(g.getToeOffPercent(), 100 * 0.65 / 1.1, 1e-9);
  EXPECT_NEAR(g.getTime(50), 0.85, 1e-12);

  // Without the short-run rules the drop splits the contact: off at 0.600 s.
  FootContactOptions raw;
  raw.min_duration = 0;
  EXPECT_NEAR(findFootContacts(c, raw)[0].off, 0.600, 1e-12);

  FootContactOptions left;
  left.heel_marker = "LHeel";
  EXPECT_THAT(inputErrorOf([&] { findFootContacts(c, left); }), HasSubstr("heel marker 'LHeel'"));
  EXPECT_FALSE(findGaitCycle({r[0]}).isComplete());
  EXPECT_FALSE(findGaitCycle({}).isComplete());
}

// ngait_og3: right heel strikes at 2.066 and 3.197 s (the knee model tests' Figure 6 cycle), the
// first toe-off at 2.797 s: stance 64.5% of the cycle.
TEST(GaitEvents, JwNgait3) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_ngait_og3.c3d");
  const C3dFile c = readC3d(test::dataPath("kgc4-jw/markers/jw_ngait_og3.c3d"));
  const std::vector<FootContact> r = findFootContacts(c);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_NEAR(r[0].strike, 2.066, 0.001);
  EXPECT_NEAR(r[0].off, 2.797, 0.001);
  EXPECT_NEAR(r[1].strike, 3.197, 0.001);
  const GaitCycle g = findGaitCycle(r);
  std::printf("[ jw og3   ] right heel strike %.4f s, toe-off %.4f s (%.1f%% of the cycle), next heel strike %.4f s\n",
              g.strike, g.toe_off, g.getToeOffPercent(), g.next_strike);
  EXPECT_NEAR(g.getToeOffPercent(), 64.6, 0.3);
  FootContactOptions left;
  left.heel_marker = "LHeel";
  const std::vector<FootContact> l = findFootContacts(c, left);
  ASSERT_EQ(l.size(), 1u);
  EXPECT_NEAR(l[0].strike, 2.643, 0.001);  // the left foot on the middle plate, between the right strikes
}

}  // namespace
}  // namespace kneesim::io
