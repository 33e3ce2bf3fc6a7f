#include "io/knee_forces.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "io_test_util.hpp"
#include "support/test_data.hpp"

namespace kneesim::io {
namespace {

using ::testing::HasSubstr;
using test_util::inputErrorOf;
using test_util::writeBytes;

constexpr double kLbf = 4.4482216152605;

TEST(KneeForces, FirstRowsOfGaitTrialMatchHandComputedEquation4) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv");
  const KneeForces k = readKneeForces(test::dataPath("kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv"));
  ASSERT_EQ(k.getNumSamples(), 291);  // frames 218..508 of jw_ngait_og3.c3d
  EXPECT_DOUBLE_EQ(k.time.front(), 1.806670);
  EXPECT_DOUBLE_EQ(k.time.back(), 4.223337);
  // Row 1: PM 14.528429, AM 15.605992, AL 12.029920, PL 9.730784 lbf (GON 60.561880, GRFz 0.000769).
  // medial  = 0.9871 AM + 0.9683 PM + 0.0387 AL + 0.0211 PL = 30.143430 lbf = 134.084657 N
  // lateral = 0.0129 AM + 0.0317 PM + 0.9613 AL + 0.9789 PL = 21.751695 lbf =  96.756360 N
  // Each cell's two coefficients sum to 1, so total = PM + AM + AL + PL = 51.895125 lbf.
  EXPECT_NEAR(k.am[0], 15.605992 * kLbf, 1e-9);
  EXPECT_NEAR(k.pm[0], 14.528429 * kLbf, 1e-9);
  EXPECT_NEAR(k.medial[0], 134.084657, 1e-5);
  EXPECT_NEAR(k.lateral[0], 96.756360, 1e-5);
  EXPECT_NEAR(k.total[0], 51.895125 * kLbf, 1e-6);
  EXPECT_DOUBLE_EQ(k.goniometer[0], 60.561880);
  EXPECT_DOUBLE_EQ(k.grfz[0], 0.000769);
  // Row 2: PM 14.162941, AM 13.842215, AL 11.083036, PL 7.990032 lbf.
  EXPECT_NEAR(k.medial[1], 124.439575, 1e-5);
  EXPECT_NEAR(k.lateral[1], 84.974798, 1e-5);
}

TEST(KneeForces, ReadsCrOnlyChairRiseWithGrfColumnAndStairAscent) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/knee-forces/jw_chairrise1_knee_forces.csv");
  const KneeForces c = readKneeForces(test::dataPath("kgc4-jw/knee-forces/jw_chairrise1_knee_forces.csv"));
  ASSERT_EQ(c.getNumSamples(), 2029);
  EXPECT_DOUBLE_EQ(c.time.front(), -0.001667);
  EXPECT_DOUBLE_EQ(c.time.back(), 16.898333);
  EXPECT_NEAR(c.pm[0], 3.953272 * kLbf, 1e-9);
  EXPECT_DOUBLE_EQ(c.grfz[0], 0.048029);  // the column is called GRF in this file
  EXPECT_DOUBLE_EQ(c.grfz.back(), 0.042582);
  const KneeForces s = readKneeForces(test::dataPath("kgc4-jw/knee-forces/jw_stairupf1_knee_forces.csv"));
  ASSERT_EQ(s.getNumSamples(), 617);  // frames 399..1015 of jw_stairupf1.c3d
  EXPECT_DOUBLE_EQ(s.time.front(), 3.316667);
}

TEST(KneeForces, CustomCoefficientsAreApplied) {
  const std::string dir = test::scratchDir("knee_coef");
  writeBytes(dir + "/k.csv", "Time(sec),PM,AM,AL,PL\r0,1,2,3,4,\r0.1,0,0,0,1,\r");
  KneeForceCoefficients c;
  for (int i = 0; i < 4; ++i) {
    c.medial[i] = i + 1;  // AM PM AL PL
    c.lateral[i] = 0.5;
  }
  const KneeForces k = readKneeForces(dir + "/k.csv", c);
  // medial = 1 AM + 2 PM + 3 AL + 4 PL = 2 + 2 + 9 + 16 = 29 lbf; lateral = 0.5 (1+2+3+4) = 5 lbf.
  EXPECT_NEAR(k.medial[0], 29 * kLbf, 1e-9);
  EXPECT_NEAR(k.lateral[0], 5 * kLbf, 1e-9);
  EXPECT_NEAR(k.total[1], (4 + 0.5) * kLbf, 1e-9);
  EXPECT_TRUE(std::isnan(k.goniometer[0]));  // no GON column
  EXPECT_TRUE(std::isnan(k.grfz[1]));
}

TEST(KneeForces, MissingChannelAndBadTimesAreErrors) {
  const std::string dir = test::scratchDir("knee_bad");
  writeBytes(dir + "/m.csv", "Time(sec),PM,AM,PL,GON,GRFz,\r0,1,2,3,4,5,\r");
  const std::string msg = inputErrorOf([&] { readKneeForces(dir + "/m.csv"); });
  EXPECT_THAT(msg, HasSubstr("m.csv:1: AL: expected the load-cell column 'AL'"));
  EXPECT_THAT(msg, HasSubstr("Time(sec), PM, AM, PL, GON, GRFz"));
  writeBytes(dir + "/t.csv", "PM,AM,AL,PL\n1,2,3,4\n");
  EXPECT_THAT(inputErrorOf([&] { readKneeForces(dir + "/t.csv"); }), HasSubstr("expected a time column"));
  writeBytes(dir + "/o.csv", "Time(sec),PM,AM,AL,PL\n0.1,1,2,3,4\n0.1,1,2,3,4\n");
  EXPECT_THAT(inputErrorOf([&] { readKneeForces(dir + "/o.csv"); }), HasSubstr("expected strictly increasing times"));
}

TEST(KneeForces, ResampleInterpolatesHoldsHalfASampleAndRejectsDisjointRanges) {
  const std::string dir = test::scratchDir("knee_resample");
  writeBytes(dir + "/k.csv", "Time(sec),PM,AM,AL,PL,GON,GRFz\n1.0,10,0,0,0,5,1\n1.1,20,0,0,0,6,2\n1.2,40,0,0,0,7,3\n");
  const KneeForces k = readKneeForces(dir + "/k.csv");
  const KneeForces r = resampleKneeForces(k, {0.9, 0.96, 1.0, 1.05, 1.15, 1.2, 1.24, 1.3});
  ASSERT_EQ(r.getNumSamples(), 8);
  EXPECT_TRUE(std::isnan(r.pm[0]));                // 0.1 s before the data
  EXPECT_NEAR(r.pm[1], 10 * kLbf, 1e-9);           // within half a sample: first value held
  EXPECT_NEAR(r.pm[2], 10 * kLbf, 1e-9);
  EXPECT_NEAR(r.pm[3], 15 * kLbf, 1e-9);           // midpoint
  EXPECT_NEAR(r.pm[4], 30 * kLbf, 1e-9);
  EXPECT_NEAR(r.total[4], 30 * kLbf, 1e-9);        // total follows the load cells (PM only)
  EXPECT_NEAR(r.medial[4], 0.9683 * 30 * kLbf, 1e-9);
  EXPECT_NEAR(r.goniometer[3], 5.5, 1e-12);
  EXPECT_NEAR(r.grfz[4], 2.5, 1e-12);
  EXPECT_NEAR(r.pm[5], 40 * kLbf, 1e-9);
  EXPECT_NEAR(r.pm[6], 40 * kLbf, 1e-9);           // 0.04 s after the end, held
  EXPECT_TRUE(std::isnan(r.pm[7]));
  const std::string msg = inputErrorOf([&] { resampleKneeForces(k, {2.0, 3.0}); });
  EXPECT_THAT(msg, HasSubstr("requested times 2.000000 to 3.000000 s do not overlap the knee-force data 1.000000 to 1.200000 s"));
}

TEST(KneeForces, RowsAlignWithTheC3dFramesOfTheTrial) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv");
  const KneeForces k = readKneeForces(test::dataPath("kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv"));
  // Row i is C3D frame 218 + i at t = (frame - 1) / 120 s; the file's clock is 1/600 s earlier.
  const KneeForces a = retimeToFrames(k, 218, 120.0);
  EXPECT_DOUBLE_EQ(a.time.front(), 217.0 / 120.0);
  EXPECT_DOUBLE_EQ(a.time.back(), 507.0 / 120.0);
  EXPECT_EQ(a.medial, k.medial);
  EXPECT_THAT(inputErrorOf([&] { retimeToFrames(k, 115, 120.0); }), HasSubstr("does this file belong to that trial?"));
  // Resampling at the C3D frame times without re-timing: the last frame (4.225 s) lies 1/600 s
  // past the data and takes the last row; frame 300 lies 1/5 of the way between rows 82 and 83.
  std::vector<double> times;
  for (int f = 218; f <= 508; ++f) times.push_back((f - 1) / 120.0);
  const KneeForces r = resampleKneeForces(k, times);
  EXPECT_DOUBLE_EQ(r.total.back(), k.total.back());
  const double t = times[82];
  const double w = (t - k.time[82]) / (k.time[83] - k.time[82]);
  EXPECT_NEAR(w, 0.2, 1e-3);
  EXPECT_NEAR(r.total[82], (1 - w) * k.total[82] + w * k.total[83], 1e-9);
}

}  // namespace
}  // namespace kneesim::io
