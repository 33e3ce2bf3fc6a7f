// The goniometer calibration (io/goniometer.hpp): closed-form line recovery, unit detection, and
// JW's files: ngait_og3's GON (degrees) is the provider's conversion of the C3D's goniometer channel
// (volts); stairupf1's GON is that channel itself, in volts; chairrise1's is in volts too. The line
// from goniometer degrees to the model's IK flexion is checked against IK in the workflow test
// (KneeContactWorkflow.JwPaperWorkflow), where IK runs.
#include "io/goniometer.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "io/c3d.hpp"
#include "io/knee_forces.hpp"
#include "support/test_data.hpp"

namespace kneesim::io {
namespace {

using ::testing::HasSubstr;

// Frame means of the C3D's analog channel @p label, one per marker frame.
std::vector<double> frameMeans(const C3dFile& c, const std::string& label) {
  const int ch = c.analog.findChannel(label);
  EXPECT_GE(ch, 0) << label;
  const int spf = c.analog.samples_per_frame;
  std::vector<double> v(size_t(c.markers.getNumFrames()), NAN);
  for (int f = 0; f < c.markers.getNumFrames() && (f + 1) * spf <= int(c.analog.data.rows()); ++f) {
    double s = 0;
    for (int j = 0; j < spf; ++j) s += c.analog.data(f * spf + j, ch);
    v[size_t(f)] = s / spf;
  }
  return v;
}

struct Line {
  double a = 0, b = 0, r = 0, rms = 0;
};
// y = a + b x by least squares over the pairs (x[i + lag], y[i]).
Line fitLine(const std::vector<double>& x, const std::vector<double>& y, int lag = 0) {
  std::vector<double> xs, ys;
  for (size_t i = 0; i < y.size(); ++i) {
    const long j = long(i) + lag;
    if (j < 0 || j >= long(x.size()) || !std::isfinite(x[size_t(j)]) || !std::isfinite(y[i])) continue;
    xs.push_back(x[size_t(j)]);
    ys.push_back(y[i]);
  }
  const double n = double(xs.size());
  double mx = 0, my = 0;
  for (size_t i = 0; i < xs.size(); ++i) mx += xs[i] / n, my += ys[i] / n;
  double sxx = 0, sxy = 0, syy = 0;
  for (size_t i = 0; i < xs.size(); ++i) {
    sxx += (xs[i] - mx) * (xs[i] - mx);
    sxy += (xs[i] - mx) * (ys[i] - my);
    syy += (ys[i] - my) * (ys[i] - my);
  }
  Line l;
  l.b = sxy / sxx;
  l.a = my - l.b * mx;
  l.r = sxy / std::sqrt(sxx * syy);
  double ss = 0;
  for (size_t i = 0; i < xs.size(); ++i) ss += std::pow(ys[i] - l.a - l.b * xs[i], 2);
  l.rms = std::sqrt(ss / n);
  return l;
}

TEST(Goniometer, UnitsAreDetectedFromTheRange) {
  EXPECT_TRUE(isGoniometerInVolts({5.3, 6.1, 7.0, NAN}));
  EXPECT_FALSE(isGoniometerInVolts({2.8, 20.0, 64.7}));  // degrees of a gait cycle
  EXPECT_FALSE(isGoniometerInVolts({4.0, 9.5}));         // spans 5.5 units: a knee in degrees
  EXPECT_FALSE(isGoniometerInVolts({NAN}));
  GoniometerCalibration c;
  c.units = "degrees";
  EXPECT_FALSE(usesVolts({5.3, 6.0}, c));
  c.units = "volts";
  EXPECT_TRUE(usesVolts({20.0, 60.0}, c));
}

// Two trials made from one line, flexion = -3 + 1.2 goniometer deg: one recorded in volts (through
// the provider's conversion, inverted), one in degrees. The pooled fit recovers the line exactly and
// the flexion of a third signal in volts follows both steps.
TEST(Goniometer, PooledFitRecoversTheLineAcrossUnits) {
  GoniometerPairs volts{"in_volts", {}, {}}, degrees{"in_degrees", {}, {}};
  for (int i = 0; i <= 40; ++i) {
    const double gdeg = 2 + 1.5 * i;  // 2..62 goniometer degrees
    degrees.goniometer.push_back(gdeg);
    degrees.flexion_deg.push_back(-3 + 1.2 * gdeg);
    const double gdeg2 = 5 + 1.6 * i;
    volts.goniometer.push_back((gdeg2 - kJwGoniometerOffsetDeg) / kJwGoniometerDegreesPerVolt);
    volts.flexion_deg.push_back(-3 + 1.2 * gdeg2);
  }
  volts.goniometer.push_back(NAN);  // skipped
  volts.flexion_deg.push_back(10);
  const GoniometerCalibration c = fitGoniometerCalibration({volts, degrees});
  EXPECT_NEAR(c.gain, 1.2, 1e-12);
  EXPECT_NEAR(c.offset_deg, -3, 1e-10);
  EXPECT_NEAR(c.r, 1.0, 1e-12);
  EXPECT_LT(c.rms_deg, 1e-10);
  EXPECT_EQ(c.frames, 82);
  EXPECT_THAT(c.source, HasSubstr("in_volts (volts), in_degrees (degrees)"));
  std::string note;
  const std::vector<double> f = calcKneeFlexionDeg({6.0, 7.0}, c, &note);
  EXPECT_NEAR(f[0], -3 + 1.2 * (kJwGoniometerDegreesPerVolt * 6.0 + kJwGoniometerOffsetDeg), 1e-10);
  EXPECT_NEAR(f[1], -3 + 1.2 * (kJwGoniometerDegreesPerVolt * 7.0 + kJwGoniometerOffsetDeg), 1e-10);
  EXPECT_THAT(note, HasSubstr("V): goniometer deg = 38.1828 V - 200.218"));
  // A signal in degrees skips the first step.
  EXPECT_NEAR(calcKneeFlexionDeg({30.0}, c)[0], -3 + 1.2 * 30, 1e-12);
  // Too few pairs, no spread: one line each.
  try {
    fitGoniometerCalibration({{"short", {1, 2, 3}, {1, 2, 3}}}, {}, {"setup.xml", 4, "goniometer"});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("setup.xml:4: goniometer: goniometer calibration on short (degrees): expected at "
                                    "least 10 frames"));
  }
  EXPECT_THROW(fitGoniometerCalibration({{"flat", std::vector<double>(20, 30.0), std::vector<double>(20, 5.0)}}),
               InputError);
}

// The provider's conversion, found in the data: ngait_og3's CSV GON (degrees, flexion positive)
// against the C3D's analog goniometer channel (volts) at the same frames is the line 38.18 V -
// 200.2 (r = 0.996, 1.7 deg RMS; 1.0 deg when the CSV is compared with the previous frame: the two
// recordings are offset by about 5 ms). stairupf1's CSV GON is the C3D channel itself (volts).
TEST(Goniometer, JwProviderConversionIsTheCsvAgainstTheC3dChannel) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  const C3dFile og3 = readC3d(test::dataPath("kgc4-jw/markers/jw_ngait_og3.c3d"));
  const KneeForces kf3 = readKneeForces(test::dataPath("kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv"));
  ASSERT_EQ(og3.markers.getNumFrames(), kf3.getNumSamples());  // row i is frame first + i
  const std::vector<double> v3 = frameMeans(og3, "goniometer");
  const Line l = fitLine(v3, kf3.goniometer), lag = fitLine(v3, kf3.goniometer, -1);
  std::printf("[ gon      ] ngait_og3: CSV GON = %.4f V %+.3f (r = %.5f, %.2f deg RMS); previous frame: %.4f V %+.3f "
              "(r = %.5f, %.2f deg RMS)\n", l.b, l.a, l.r, l.rms, lag.b, lag.a, lag.r, lag.rms);
  EXPECT_NEAR(l.b, kJwGoniometerDegreesPerVolt, 1e-3);
  EXPECT_NEAR(l.a, kJwGoniometerOffsetDeg, 1e-2);
  EXPECT_GT(l.r, 0.996);
  EXPECT_LT(l.rms, 1.7);
  EXPECT_GT(lag.r, l.r);
  EXPECT_LT(lag.rms, 1.1);
  EXPECT_FALSE(isGoniometerInVolts(kf3.goniometer));

  const C3dFile st = readC3d(test::dataPath("kgc4-jw/markers/jw_stairupf1.c3d"));
  const KneeForces kfs = readKneeForces(test::dataPath("kgc4-jw/knee-forces/jw_stairupf1_knee_forces.csv"));
  const Line s = fitLine(frameMeans(st, "goniometer"), kfs.goniometer);
  std::printf("[ gon      ] stairupf1: CSV GON = %.4f x C3D goniometer %+.4f V (r = %.5f)\n", s.b, s.a, s.r);
  EXPECT_NEAR(s.b, 1.0, 0.01);
  EXPECT_NEAR(s.a, 0.0, 0.05);
  EXPECT_GT(s.r, 0.998);
  EXPECT_TRUE(isGoniometerInVolts(kfs.goniometer));
  const KneeForces chair = readKneeForces(test::dataPath("kgc4-jw/knee-forces/jw_chairrise1_knee_forces.csv"));
  EXPECT_TRUE(isGoniometerInVolts(chair.goniometer));
  // The chair rise in the goniometer's own degrees (step 1 only) spans 9-98 deg.
  const std::vector<double> gdeg = toGoniometerDegrees(chair.goniometer, GoniometerCalibration{});
  EXPECT_NEAR(*std::min_element(gdeg.begin(), gdeg.end()), 9.07, 0.05);
  EXPECT_NEAR(*std::max_element(gdeg.begin(), gdeg.end()), 97.99, 0.05);
}

// The knee-force files' GRFz column is force plate 1's vertical force / 2000: under the left foot in
// ngait_og3, under the right foot in stairupf1 (io::kJwCsvGrfNewtonsPerUnit).
TEST(Goniometer, JwCsvGrfColumnIsForcePlateOneOver2000) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  for (const char* trial : {"ngait_og3", "stairupf1"}) {
    const C3dFile c = readC3d(test::dataPath(std::string("kgc4-jw/markers/jw_") + trial + ".c3d"));
    const KneeForces kf = readKneeForces(test::dataPath(std::string("kgc4-jw/knee-forces/jw_") + trial + "_knee_forces.csv"));
    std::vector<double> fz = frameMeans(c, "Fz1");
    for (double& x : fz) x = -x / kJwCsvGrfNewtonsPerUnit;  // the plate's Fz points down
    const Line l = fitLine(fz, kf.grfz);
    std::printf("[ grf      ] %s: CSV GRFz = %.5f x (-Fz1 / 2000) %+.5f (r = %.5f)\n", trial, l.b, l.a, l.r);
    EXPECT_NEAR(l.b, 1.0, 0.01) << trial;
    EXPECT_NEAR(l.a, 0.0, 0.002) << trial;
    EXPECT_GT(l.r, 0.998) << trial;
  }
}

}  // namespace
}  // namespace kneesim::io
