#include "io/c3d.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <random>

#include "io_test_util.hpp"
#include "support/memory_limit.hpp"
#include "support/test_data.hpp"

namespace kneesim::io {
namespace {

using ::testing::HasSubstr;
using test_util::inputErrorOf;
using test_util::readBytes;
using test_util::writeBytes;

const double kNaN = std::numeric_limits<double>::quiet_NaN();

struct JwTrial {
  const char* file;
  int first, last, labels;
};
// First/last frames from the files' headers (og3's 218-508 is also stated by the data README
// and matches the 291 rows of its knee-force file; stairupf1's 617 frames match its 617 rows).
const JwTrial kJwTrials[] = {{"kgc4-jw/markers/jw_ngait_og1.c3d", 115, 441, 56},
                             {"kgc4-jw/markers/jw_ngait_og3.c3d", 218, 508, 56},
                             {"kgc4-jw/markers/jw_ngait_og7.c3d", 180, 506, 56},
                             {"kgc4-jw/markers/jw_stairupf1.c3d", 399, 1015, 55},
                             {"kgc4-jw/markers/jw_1legstand1.c3d", 1, 1211, 56}};

TEST(C3d, ReadsEveryJwTrial) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_ngait_og3.c3d");
  for (const JwTrial& trial : kJwTrials) {
    SCOPED_TRACE(trial.file);
    const C3dFile c = readC3d(test::dataPath(trial.file));
    EXPECT_EQ(c.processor, "Intel");
    EXPECT_EQ(c.first_frame, trial.first);
    EXPECT_EQ(c.last_frame, trial.last);
    const MarkerTable& m = c.markers;
    EXPECT_EQ(m.getNumFrames(), trial.last - trial.first + 1);
    EXPECT_EQ(m.getNumMarkers(), trial.labels);
    EXPECT_DOUBLE_EQ(m.rate, 120.0);
    EXPECT_EQ(m.original_units, "mm");
    EXPECT_EQ(m.frame_numbers.front(), trial.first);
    EXPECT_EQ(m.frame_numbers.back(), trial.last);
    EXPECT_DOUBLE_EQ(m.time.front(), (trial.first - 1) / 120.0);
    // Marker names (stairupf1 prefixes them with "JW:"; findMarker strips the prefix).
    for (const char* name : {"RAsis", "LAsis", "RThighSuperior", "RShankLateral", "RHeel", "Sternum"})
      EXPECT_GE(m.findMarker(name), 0) << name;
    if (trial.labels == 56) {
      EXPECT_EQ(m.labels.front(), "Sternum");
      for (const char* name : {"Oglobal", "Xglobal", "Yglobal", "Zglobal", "Sacral", "RPatella"})
        EXPECT_GE(m.findMarker(name), 0) << name;
      // The lab-frame markers sit at the origin and 200 mm along each axis in every frame.
      for (int f : {0, m.getNumFrames() - 1}) {
        EXPECT_NEAR((m.getPosition(f, m.findMarker("Oglobal")) - Eigen::Vector3d(0, 0, 0)).norm(), 0, 1e-9);
        EXPECT_NEAR((m.getPosition(f, m.findMarker("Xglobal")) - Eigen::Vector3d(0.2, 0, 0)).norm(), 0, 1e-9);
        EXPECT_NEAR((m.getPosition(f, m.findMarker("Yglobal")) - Eigen::Vector3d(0, 0.2, 0)).norm(), 0, 1e-9);
        EXPECT_NEAR((m.getPosition(f, m.findMarker("Zglobal")) - Eigen::Vector3d(0, 0, 0.2)).norm(), 0, 1e-9);
      }
    }
    // Analog: 36 channels at 1200 Hz, 10 samples per frame.
    const AnalogTable& a = c.analog;
    EXPECT_DOUBLE_EQ(a.rate, 1200.0);
    EXPECT_EQ(a.samples_per_frame, 10);
    ASSERT_EQ(a.getNumChannels(), 36);
    EXPECT_EQ(a.data.rows(), 10 * m.getNumFrames());
    const char* fp_labels[] = {"Fx1", "Fy1", "Fz1", "Mx1", "My1", "Mz1", "Fx2", "Fy2", "Fz2",
                               "Mx2", "My2", "Mz2", "Fx3", "Fy3", "Fz3", "Mx3", "My3", "Mz3"};
    for (int i = 0; i < 18; ++i) EXPECT_EQ(a.labels[i], fp_labels[i]);
    EXPECT_EQ(a.units[2], "N");
    EXPECT_EQ(a.units[3], "Nmm");
    EXPECT_EQ(a.findChannel("load cell"), 34);
    EXPECT_EQ(a.findChannel("goniometer"), 35);
    for (const char* emg : {"semimem", "bifeml", "vasmed", "vaslat", "rf", "medgas", "latgas", "tfl", "tibant",
                            "peronl", "soleus", "addmag", "gmax", "gmed", "sartorius"})
      EXPECT_GE(a.findChannel(emg), 18) << emg;
    EXPECT_EQ(a.units[18], "V");
    EXPECT_THAT(a.descriptions[0], HasSubstr("Bertec Force Plate"));
    EXPECT_DOUBLE_EQ(a.time.front(), (trial.first - 1) / 120.0);
    EXPECT_NEAR(a.time[10] - a.time[0], 1.0 / 120.0, 1e-12);
    // Three Bertec type-2 plates on channels 1-6, 7-12, 13-18; plate 1 spans x -600..0 mm,
    // y -250..650 mm at z = -6 mm.
    ASSERT_EQ(c.plates.size(), 3u);
    for (int p = 0; p < 3; ++p) {
      EXPECT_EQ(c.plates[p].type, 2);
      ASSERT_EQ(c.plates[p].channels.size(), 6u);
      for (int k = 0; k < 6; ++k) EXPECT_EQ(c.plates[p].channels[k], 6 * p + k);
    }
    EXPECT_NEAR((c.plates[0].corners_m.col(0) - Eigen::Vector3d(-0.6, 0.65, -0.006)).norm(), 0, 1e-9);
    EXPECT_NEAR((c.plates[0].corners_m.col(2) - Eigen::Vector3d(0.0, -0.25, -0.006)).norm(), 0, 1e-9);
    // Raw parameter access.
    const C3dParameter* used = c.findParameter("point", "used");
    ASSERT_NE(used, nullptr);
    EXPECT_EQ(used->values.at(0), trial.labels);
    const C3dParameter* company = c.findParameter("MANUFACTURER", "COMPANY");
    ASSERT_NE(company, nullptr);
    EXPECT_EQ(company->strings.at(0), "Vicon");
  }
}

TEST(C3d, Og3ValuesMatchTheBytesOfTheFile) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_ngait_og3.c3d");
  const C3dFile c = readC3d(test::dataPath("kgc4-jw/markers/jw_ngait_og3.c3d"));
  // Reference values decoded by hand (Python struct.unpack('<f')) from the file: data starts at
  // block 23 (byte 11264), a frame is (56 x 4 + 360) floats = 2336 bytes; RAsis is point 6
  // (bytes 11360..11375 in frame 218); analog sample k of channel i is at
  // 11264 + (k / 10) 2336 + 56 16 + ((k % 10) 36 + i) 4.
  const MarkerTable& m = c.markers;
  const int rasis = m.findMarker("RAsis");
  ASSERT_EQ(rasis, 6);
  EXPECT_NEAR(m.getPosition(0, rasis).x(), 1.0979720458984375, 1e-12);
  EXPECT_NEAR(m.getPosition(0, rasis).y(), 0.2918853759765625, 1e-12);
  EXPECT_NEAR(m.getPosition(0, rasis).z(), 1.0155758056640625, 1e-12);
  EXPECT_NEAR(m.getPosition(290, rasis).x(), -1.8714149169921875, 1e-12);
  EXPECT_NEAR(m.getPosition(290, rasis).z(), 1.0074297485351562, 1e-12);
  EXPECT_DOUBLE_EQ(c.analog.data(1234, 2), -640.31982421875);  // Fz1, N
  EXPECT_DOUBLE_EQ(c.analog.data(0, 34), 0.008392333984375);   // load cell, V
  EXPECT_DOUBLE_EQ(c.analog.data(0, 35), 6.77032470703125);    // goniometer, V
  EXPECT_DOUBLE_EQ(c.analog.data(1234, 35), 6.54144287109375);
  for (const auto& [name, gaps] : m.calcGapCounts()) EXPECT_EQ(gaps, 0) << name;
  EXPECT_EQ(c.residuals.size(), m.positions.size());
  EXPECT_DOUBLE_EQ(c.residuals[0], 0.0);
}

TEST(C3d, CountsGapsPerMarkerInStairAscent) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  const C3dFile c = readC3d(test::dataPath("kgc4-jw/markers/jw_stairupf1.c3d"));
  // Frames with a negative residual word, counted per point with Python from the file.
  const std::map<std::string, int> expected = {{"JW:RShankLateral", 305}, {"JW:LHindfoot", 280}, {"JW:LToe", 276},
                                               {"JW:RThighInferior", 291}, {"JW:RToeMedial", 296}, {"*49", 617},
                                               {"*50", 617}, {"*51", 617}, {"*52", 617}, {"*53", 617}, {"*54", 617}};
  int total = 0;
  for (const auto& [name, gaps] : c.markers.calcGapCounts()) {
    auto it = expected.find(name);
    EXPECT_EQ(gaps, it == expected.end() ? 0 : it->second) << name;
    total += gaps;
  }
  EXPECT_EQ(total, 5150);
  const int rsl = c.markers.findMarker("RShankLateral");
  int missing = 0;
  for (int f = 0; f < c.markers.getNumFrames(); ++f)
    if (c.markers.isMissing(f, rsl)) {
      ++missing;
      EXPECT_TRUE(std::isnan(c.residuals[size_t(f) * 55 + size_t(rsl)]));
    }
  EXPECT_EQ(missing, 305);
  EXPECT_EQ(c.markers.labels[0], "synch_bar:synch_bar1");
}

TEST(C3d, SingleLegStanceCarriesBodyWeightAndCopFollowsThePlateGeometry) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_1legstand1.c3d");
  const C3dFile c = readC3d(test::dataPath("kgc4-jw/markers/jw_1legstand1.c3d"));
  std::vector<PlateWrench> w;
  for (int p = 0; p < 3; ++p) w.push_back(calcPlateWrench(c, p));
  const size_t n = w[0].force.size();
  ASSERT_EQ(n, size_t(12110));
  double mean_fz = 0;
  for (size_t s = 0; s < n; ++s) mean_fz += (w[0].force[s].z() + w[1].force[s].z() + w[2].force[s].z()) / double(n);
  // JW weighs 66.7 kg (data README): 654.3 N. Standing sway keeps the mean within a few percent.
  EXPECT_NEAR(mean_fz, 66.7 * 9.81, 0.03 * 66.7 * 9.81);

  // Sample 5000, plate 1: the plate frame has x_P = -X, y_P = +Y, z_P = -Z (corners), its
  // centre at (-300, 200, -6) mm and ORIGIN = 0, so by hand COP = centre + (My/Fz, Mx/Fz, 0)
  // in lab axes with the moments converted from N mm, and the lab force is (-Fx, Fy, -Fz).
  const auto& a = c.analog.data;
  const double fx = a(5000, 0), fy = a(5000, 1), fz = a(5000, 2), mx = a(5000, 3) * 1e-3, my = a(5000, 4) * 1e-3;
  EXPECT_NEAR(fz, -618.95751953125, 1e-9);
  EXPECT_NEAR((w[0].force[5000] - Eigen::Vector3d(-fx, fy, -fz)).norm(), 0, 1e-9);
  const Eigen::Vector3d cop(-0.300 + my / fz, 0.200 + mx / fz, -0.006);
  EXPECT_NEAR((w[0].cop[5000] - cop).norm(), 0, 1e-6);
  EXPECT_NEAR(w[0].cop[5000].x(), -0.09612, 1e-4);  // -300 mm + 126192.6/618.96 mm
  EXPECT_NEAR(w[0].cop[5000].y(), 0.26747, 1e-4);
  EXPECT_TRUE(std::isfinite(w[0].free_moment[5000].z()));
  EXPECT_NEAR(w[0].free_moment[5000].head<2>().norm(), 0, 1e-12);
  // The third plate is never loaded: zero force, no COP.
  for (size_t s = 0; s < n; s += 997) {
    EXPECT_LT(w[2].force[s].norm(), 1.0);
    EXPECT_TRUE(std::isnan(w[2].cop[s].x()));
  }
  EXPECT_THAT(inputErrorOf([&] { calcPlateWrench(c, 3); }), HasSubstr("expected a plate index 0..2"));
}

// ---------------------------------------------------------------------------------------------
// Synthetic files written by writeC3d.

C3dFile makeSynthetic(int frames, int markers, int channels, int spf) {
  C3dFile c;
  MarkerTable& m = c.markers;
  m.rate = 100;
  m.resize(frames, markers);
  for (int i = 0; i < markers; ++i) m.labels[i] = "M" + std::to_string(i + 1);
  for (int f = 0; f < frames; ++f) {
    m.frame_numbers[f] = 5 + f;
    m.time[f] = (4 + f) / 100.0;
    for (int i = 0; i < markers; ++i)
      m.updPosition(f, i) = Eigen::Vector3d(0.1 * i + 0.001 * f, -0.25 + 0.0005 * f * i, 1.0 - 0.01 * i);
  }
  if (markers > 1 && frames > 2) m.updPosition(2, 1) = Eigen::Vector3d(kNaN, kNaN, kNaN);
  c.analog.rate = 100.0 * spf;
  c.analog.data.resize(frames * spf, channels);
  for (int i = 0; i < channels; ++i) {
    c.analog.labels.push_back("A" + std::to_string(i + 1));
    c.analog.units.push_back(i % 2 ? "V" : "N");
    c.analog.descriptions.push_back("channel " + std::to_string(i + 1));
    for (int s = 0; s < frames * spf; ++s) c.analog.data(s, i) = 100.0 * std::sin(0.01 * s + i) + 3.0 * i;
  }
  return c;
}

// Offset of the first data byte of parameter @p name of group number @p gid in a file written
// by writeC3d (groups are numbered POINT 1, ANALOG 2, FORCE_PLATFORM 3, TRIAL 4 there).
size_t findParameterData(const std::string& b, int gid, const std::string& name) {
  const std::string key = std::string(1, char(name.size())) + char(gid) + name;
  const size_t at = b.find(key, 512);
  if (at == std::string::npos) return 0;
  const size_t p = at + key.size() + 2;  // skip the offset word
  const int nd = uint8_t(b[p + 1]);
  return p + 2 + size_t(nd);
}

void putLe16(std::string& b, size_t at, int v) {
  b[at] = char(v & 0xFF);
  b[at + 1] = char((v >> 8) & 0xFF);
}

void expectSameMarkers(const MarkerTable& a, const MarkerTable& b, double tol) {
  ASSERT_EQ(a.getNumFrames(), b.getNumFrames());
  ASSERT_EQ(a.getNumMarkers(), b.getNumMarkers());
  EXPECT_EQ(a.labels, b.labels);
  EXPECT_EQ(a.frame_numbers, b.frame_numbers);
  for (int f = 0; f < a.getNumFrames(); ++f) {
    EXPECT_NEAR(a.time[f], b.time[f], 1e-12);
    for (int i = 0; i < a.getNumMarkers(); ++i) {
      ASSERT_EQ(a.isMissing(f, i), b.isMissing(f, i)) << "frame " << f << " marker " << i;
      if (!a.isMissing(f, i)) {
        const double err = (a.getPosition(f, i) - b.getPosition(f, i)).cwiseAbs().maxCoeff();
        EXPECT_LE(err, tol) << "frame " << f << " marker " << i;
      }
    }
  }
}

TEST(C3d, RoundTripsEveryProcessorInFloatAndIntegerFormat) {
  const std::string dir = test::scratchDir("c3d_formats");
  const C3dFile src = makeSynthetic(7, 3, 4, 4);
  for (const char* proc : {"Intel", "DEC", "MIPS"})
    for (bool is_float : {true, false}) {
      SCOPED_TRACE(std::string(proc) + (is_float ? " float" : " integer"));
      C3dWriteOptions o;
      o.processor = proc;
      o.float_format = is_float;
      o.point_scale = 0.05;  // mm per count
      const std::string path = dir + "/" + proc + (is_float ? "_f" : "_i") + ".c3d";
      writeC3d(path, src, o);
      const C3dFile c = readC3d(path);
      EXPECT_EQ(c.processor, proc);
      EXPECT_EQ(c.first_frame, 5);
      EXPECT_EQ(c.last_frame, 11);
      EXPECT_EQ(c.markers.original_units, "mm");
      EXPECT_EQ(c.header.scale < 0, is_float);
      // Floats keep 24 bits (1e-7 relative of ~1 m); integers are rounded to 0.05 mm.
      expectSameMarkers(c.markers, src.markers, is_float ? 2e-7 : 0.5 * 0.05e-3 + 1e-12);
      ASSERT_EQ(c.analog.data.rows(), 28);
      ASSERT_EQ(c.analog.getNumChannels(), 4);
      EXPECT_EQ(c.analog.labels, src.analog.labels);
      EXPECT_EQ(c.analog.units, src.analog.units);
      EXPECT_EQ(c.analog.descriptions, src.analog.descriptions);
      EXPECT_DOUBLE_EQ(c.analog.rate, 400.0);
      EXPECT_NEAR(c.analog.time[1] - c.analog.time[0], 1.0 / 400.0, 1e-15);
      // Integer analog: SCALE = max|x| / 32000, so the rounding error is below max|x| / 64000.
      const double atol = is_float ? 1e-5 : 109.0 / 64000.0;
      EXPECT_LE((c.analog.data - src.analog.data).cwiseAbs().maxCoeff(), atol);
    }
}

TEST(C3d, ProcessorByteAndFloatEncodingsMatchTheStandard) {
  const std::string dir = test::scratchDir("c3d_bytes");
  const C3dFile src = makeSynthetic(2, 1, 0, 0);  // rate 100 Hz
  // 100.0 as IEEE single is 0x42C80000. As a VAX F-float it is 0.78125 x 2^7: exponent 128 + 7 =
  // 0x87, fraction .1001 after the hidden bit -> word0 = 0x87 << 7 | 0x48 = 0x43C8, word1 = 0,
  // each word little-endian: C8 43 00 00.
  const std::map<std::string, std::vector<uint8_t>> expected = {{"Intel", {0x00, 0x00, 0xC8, 0x42}},
                                                                {"MIPS", {0x42, 0xC8, 0x00, 0x00}},
                                                                {"DEC", {0xC8, 0x43, 0x00, 0x00}}};
  const std::map<std::string, int> proc_byte = {{"Intel", 84}, {"DEC", 85}, {"MIPS", 86}};
  for (const auto& [proc, bytes] : expected) {
    C3dWriteOptions o;
    o.processor = proc;
    writeC3d(dir + "/x.c3d", src, o);
    const std::string b = readBytes(dir + "/x.c3d");
    ASSERT_GE(b.size(), 1024u);
    EXPECT_EQ(b.size() % 512, 0u);
    EXPECT_EQ(uint8_t(b[1]), 0x50);
    EXPECT_EQ(uint8_t(b[512 + 3]), proc_byte.at(proc)) << proc;
    for (int k = 0; k < 4; ++k) EXPECT_EQ(uint8_t(b[20 + k]), bytes[k]) << proc << " byte " << k;  // header frame rate
    EXPECT_DOUBLE_EQ(readC3d(dir + "/x.c3d").markers.rate, 100.0);
  }
}

TEST(C3d, LongLabelListsFramesBeyond32767AndLockedParametersSurvive) {
  const std::string dir = test::scratchDir("c3d_big");
  // 300 markers need POINT:LABELS and LABELS2.
  C3dFile many = makeSynthetic(3, 300, 0, 0);
  C3dParameter locked;
  locked.group = "SUBJECTS";
  locked.name = "NAMES";
  locked.type = -1;
  locked.dims = {8, 1};
  locked.strings = {"JW"};
  locked.locked = true;
  many.parameters.push_back(locked);
  many.groups.push_back({1, "SUBJECTS", "subject group", false});
  writeC3d(dir + "/many.c3d", many);
  const C3dFile c = readC3d(dir + "/many.c3d");
  ASSERT_NE(c.findParameter("POINT", "LABELS2"), nullptr);
  EXPECT_EQ(c.findParameter("POINT", "LABELS")->strings.size(), 255u);
  expectSameMarkers(c.markers, many.markers, 2e-7);
  EXPECT_EQ(c.markers.labels[299], "M300");
  const C3dParameter* names = c.findParameter("SUBJECTS", "NAMES");
  ASSERT_NE(names, nullptr);
  EXPECT_TRUE(names->locked);
  EXPECT_EQ(names->strings, std::vector<std::string>{"JW"});
  EXPECT_FALSE(c.findParameter("POINT", "USED")->locked);
  bool found_group = false;
  for (const auto& g : c.groups) found_group = found_group || (g.name == "SUBJECTS" && g.description == "subject group");
  EXPECT_TRUE(found_group);

  // 40000 frames: POINT:FRAMES is a 16-bit word read as unsigned (-25536 signed).
  C3dFile longer = makeSynthetic(40000, 1, 0, 0);
  writeC3d(dir + "/long.c3d", longer);
  const C3dFile l = readC3d(dir + "/long.c3d");
  EXPECT_EQ(l.findParameter("POINT", "FRAMES")->values.at(0), 40000 - 65536);
  EXPECT_EQ(l.findParameter("POINT", "FRAMES")->getUnsigned(0), 40000);
  EXPECT_EQ(l.markers.getNumFrames(), 40000);
  EXPECT_EQ(l.last_frame, 40004);
  EXPECT_NEAR(l.markers.getPosition(39999, 0).x(), 0.001 * 39999, 0.05e-3);

  // 70000 frames: beyond the header's 16 bits; TRIAL fields carry first and last frame.
  C3dFile longest = makeSynthetic(70000, 1, 0, 0);
  writeC3d(dir + "/longest.c3d", longest);
  const C3dFile x = readC3d(dir + "/longest.c3d");
  EXPECT_EQ(x.header.last_frame, 65535);
  EXPECT_EQ(x.markers.getNumFrames(), 70000);
  EXPECT_EQ(x.last_frame, 70004);
  EXPECT_EQ(x.markers.frame_numbers.back(), 70004);
  EXPECT_NEAR(x.markers.getPosition(69999, 0).x(), 0.001 * 69999, 1e-5);
}

TEST(C3d, AnalogOffsetGenScaleAndUnsignedFormatAreApplied) {
  const std::string dir = test::scratchDir("c3d_analog");
  C3dFile src = makeSynthetic(3, 1, 1, 2);
  const double v[6] = {-1.0, 0.5, 0.25, -0.75, 0.0, 1.0};
  for (int s = 0; s < 6; ++s) src.analog.data(s, 0) = v[s];
  writeC3d(dir + "/a.c3d", src, {"Intel", false, 0.1, "mm"});
  std::string b = readBytes(dir + "/a.c3d");
  const C3dFile plain = readC3d(dir + "/a.c3d");
  const double scale = plain.findParameter("ANALOG", "SCALE")->values.at(0);
  EXPECT_DOUBLE_EQ(float(scale), float(1.0 / 32000.0));  // max |v| / 32000
  // Patch ANALOG:OFFSET[0] = 100 and GEN_SCALE = 2.0 (IEEE 0x40000000, little-endian).
  const size_t off = findParameterData(b, 2, "OFFSET");
  const size_t gen = findParameterData(b, 2, "GEN_SCALE");
  ASSERT_GT(off, 0u);
  ASSERT_GT(gen, 0u);
  putLe16(b, off, 100);
  b.replace(gen, 4, std::string("\x00\x00\x00\x40", 4));
  writeBytes(dir + "/b.c3d", b);
  const C3dFile c = readC3d(dir + "/b.c3d");
  for (int s = 0; s < 6; ++s) {
    const double raw = std::round(v[s] / scale);  // stored counts
    EXPECT_NEAR(c.analog.data(s, 0), (raw - 100) * scale * 2.0, 1e-12) << s;
  }
  // FORMAT = UNSIGNED: the same words read as 0..65535 (-32000 counts become 33536).
  const size_t fmt = findParameterData(b, 2, "FORMAT");
  ASSERT_GT(fmt, 0u);
  ASSERT_EQ(b.substr(fmt, 8), "SIGNED  ");
  b.replace(fmt, 8, "UNSIGNED");
  writeBytes(dir + "/u.c3d", b);
  const C3dFile u = readC3d(dir + "/u.c3d");
  EXPECT_NEAR(u.analog.data(0, 0), (33536 - 100) * scale * 2.0, 1e-9);
  EXPECT_NEAR(u.analog.data(1, 0), (16000 - 100) * scale * 2.0, 1e-9);
}

TEST(C3d, FloatPointFramesCountsFramesBeyondTheHeaderWithoutTrialFields) {
  const std::string dir = test::scratchDir("c3d_float_frames");
  writeC3d(dir + "/l.c3d", makeSynthetic(70000, 1, 0, 0));
  std::string b = readBytes(dir + "/l.c3d");
  // Rename the TRIAL parameters so only the header (first 5, last 65535) and the float
  // POINT:FRAMES = 70000 remain.
  for (const std::string name : {"ACTUAL_START_FIELD", "ACTUAL_END_FIELD"}) {
    const size_t at = b.find(name, 512);
    ASSERT_NE(at, std::string::npos);
    b[at] = 'X';
  }
  writeBytes(dir + "/m.c3d", b);
  const C3dFile c = readC3d(dir + "/m.c3d");
  EXPECT_EQ(c.findParameter("TRIAL", "ACTUAL_START_FIELD"), nullptr);
  EXPECT_EQ(c.findParameter("POINT", "FRAMES")->type, 4);
  EXPECT_EQ(c.first_frame, 5);
  EXPECT_EQ(c.markers.getNumFrames(), 70000);
  EXPECT_EQ(c.last_frame, 70004);
}

TEST(C3d, IntegerFileWithTooLargeCoordinateIsRejectedAndNothingIsWritten) {
  const std::string dir = test::scratchDir("c3d_range");
  C3dFile c = makeSynthetic(2, 1, 0, 0);
  c.markers.updPosition(1, 0).x() = 5.0;  // 5000 mm / 0.1 mm > 32767 counts
  const std::string msg = inputErrorOf([&] { writeC3d(dir + "/r.c3d", c, {"Intel", false, 0.1, "mm"}); });
  EXPECT_THAT(msg, HasSubstr("does not fit a 16-bit integer"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/r.c3d"));
}

// Analog channels of a type-2 plate under a known load, derived by hand in the plate frame.
// Plate: corners (0, 0.4), (0.6, 0.4), (0.6, 0), (0, 0) m at z = 0, so x_P = c1 - c2 = -X,
// y_P = c1 - c4 = +Y, z_P = -Z (as the JW plates), centre C = (0.3, 0.2, 0). ORIGIN stored as (0, 0, 40) mm (sensor
// 40 mm below the surface; the reader flips positive z to r_OC = (0, 0, -0.04) m).
// Load in the plate frame: F_P = (100, 0, -800) N at p = (-0.1, 0.05, 0) m from C, free
// moment Tz = 2 N m. Then M_C = p x F + Tz e_z = (0.05 (-800), -(-0.1)(-800), -0.05 100 + 2)
// = (-40, -80, -3) N m, and M_O = M_C - F x r_OC = M_C - (0, 4, 0) = (-40, -84, -3) N m.
// Expected in the lab: force R F_P = (-100, 0, 800) N, COP = C + R p = (0.4, 0.25, 0) m,
// free moment R (0, 0, 2) = (0, 0, -2) N m.
C3dFile makePlateFile(int type) {
  C3dFile c = makeSynthetic(2, 1, 6, 2);
  const double ch[6] = {100, 0, -800, -40000, -84000, -3000};  // N and N mm
  const char* labels[6] = {"Fx1", "Fy1", "Fz1", "Mx1", "My1", "Mz1"};
  for (int k = 0; k < 6; ++k) {
    c.analog.labels[k] = labels[k];
    c.analog.units[k] = k < 3 ? "N" : "Nmm";
    for (int s = 0; s < 4; ++s) c.analog.data(s, k) = ch[k];
  }
  c.analog.data(3, 2) = -5;  // last sample: nearly unloaded
  ForcePlate p;
  p.type = type;
  p.corners_m.col(0) = Eigen::Vector3d(0.0, 0.4, 0);
  p.corners_m.col(1) = Eigen::Vector3d(0.6, 0.4, 0);
  p.corners_m.col(2) = Eigen::Vector3d(0.6, 0.0, 0);
  p.corners_m.col(3) = Eigen::Vector3d(0.0, 0.0, 0);
  p.origin_m = Eigen::Vector3d(0, 0, 0.040);
  p.channels = {0, 1, 2, 3, 4, 5};
  p.cal_matrix.setIdentity();
  if (type == 4) {
    // Cross-talk row: Fx_out = Fx_raw - 0.125 Fz_raw. With Fx_raw = 0 and Fz_raw = -800 the
    // calibrated Fx is 100 N again; CAL_MATRIX's first index is the output row.
    p.cal_matrix(0, 2) = -0.125;
    p.has_cal_matrix = true;
    for (int s = 0; s < 4; ++s) c.analog.data(s, 0) = 0;
    c.analog.data(3, 0) = 100 - 0.125 * 5;  // keeps Fx = 100 N on the last sample too
  }
  c.plates.push_back(p);
  return c;
}

TEST(C3d, PlateWrenchOfKnownLoadOnType2And4Plates) {
  const std::string dir = test::scratchDir("c3d_plate");
  for (int type : {2, 4}) {
    SCOPED_TRACE("type " + std::to_string(type));
    writeC3d(dir + "/p.c3d", makePlateFile(type), {"MIPS", true, 0.1, "mm"});
    const C3dFile c = readC3d(dir + "/p.c3d");
    ASSERT_EQ(c.plates.size(), 1u);
    EXPECT_EQ(c.plates[0].type, type);
    EXPECT_EQ(c.plates[0].has_cal_matrix, type == 4);
    EXPECT_NEAR((c.plates[0].origin_m - Eigen::Vector3d(0, 0, 0.04)).norm(), 0, 1e-7);
    const PlateWrench w = calcPlateWrench(c, 0);
    ASSERT_EQ(w.force.size(), 4u);
    for (int s = 0; s < 3; ++s) {
      EXPECT_NEAR((w.force[s] - Eigen::Vector3d(-100, 0, 800)).norm(), 0, 1e-9);
      EXPECT_NEAR((w.cop[s] - Eigen::Vector3d(0.4, 0.25, 0)).norm(), 0, 1e-9);
      EXPECT_NEAR((w.free_moment[s] - Eigen::Vector3d(0, 0, -2)).norm(), 0, 1e-9);
    }
    EXPECT_NEAR(w.force[3].z(), 5, 1e-9);
    EXPECT_TRUE(std::isnan(w.cop[3].x()));  // |Fz| = 5 N < 10 N
    EXPECT_TRUE(std::isnan(w.free_moment[3].z()));
    EXPECT_FALSE(std::isnan(calcPlateWrench(c, 0, 1.0).cop[3].x()));
  }
}

TEST(C3d, CorruptedFilesOnlyEverThrowInputError) {
  // Random byte damage to header, parameters and data of small files of every processor and
  // format: the reader must either read them or throw InputError (never crash, never another
  // exception type such as bad_alloc).
  const std::string dir = test::scratchDir("c3d_fuzz");
  std::vector<std::string> originals;
  for (const char* proc : {"Intel", "DEC", "MIPS"})
    for (bool is_float : {true, false}) {
      writeC3d(dir + "/src.c3d", makePlateFile(is_float ? 2 : 4), {proc, is_float, 0.1, "mm"});
      originals.push_back(readBytes(dir + "/src.c3d"));
    }
  std::mt19937 rng(20240611);
  int read_ok = 0, rejected = 0;
  for (int iter = 0; iter < 3000; ++iter) {
    std::string b = originals[size_t(iter) % originals.size()];
    const int hits = 1 + int(rng() % 6);
    for (int h = 0; h < hits; ++h) {
      // Half the damage goes to the first 1.5 blocks (header and parameters), where it matters most.
      const size_t at = (rng() % 2) ? rng() % 768 : rng() % b.size();
      b[at] = char(rng() % 256);
    }
    if (rng() % 5 == 0) b.resize(rng() % b.size());
    writeBytes(dir + "/f.c3d", b);
    try {
      const C3dFile c = readC3d(dir + "/f.c3d");
      ++read_ok;
      for (int p = 0; p < int(c.plates.size()); ++p) {
        try {
          calcPlateWrench(c, p);
        } catch (const InputError&) {
        }
      }
    } catch (const InputError&) {
      ++rejected;
    } catch (const std::exception& e) {
      FAIL() << "iteration " << iter << ": expected InputError, got " << e.what();
    }
  }
  // Both outcomes must occur, or the damage is not exercising the reader.
  EXPECT_GT(read_ok, 100);
  EXPECT_GT(rejected, 100);
}

TEST(C3d, BadInputsAreOneLineErrors) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_ngait_og3.c3d");
  const std::string dir = test::scratchDir("c3d_bad");
  const std::string good = readBytes(test::dataPath("kgc4-jw/markers/jw_ngait_og3.c3d"));
  ASSERT_EQ(good.size(), 691040u);

  EXPECT_THAT(inputErrorOf([&] { readC3d(dir + "/none.c3d"); }), HasSubstr("none.c3d: cannot open"));

  std::string bad = good;
  bad[1] = 0x51;
  writeBytes(dir + "/key.c3d", bad);
  std::string msg = inputErrorOf([&] { readC3d(dir + "/key.c3d"); });
  EXPECT_THAT(msg, HasSubstr("key.c3d: header: expected the C3D key byte 0x50 at byte 2, got 0x51"));

  bad = good.substr(0, 20000);
  bad[0] = char(200);  // parameter block 200 of a 40-block file
  writeBytes(dir + "/ptr.c3d", bad);
  msg = inputErrorOf([&] { readC3d(dir + "/ptr.c3d"); });
  EXPECT_THAT(msg, HasSubstr("ptr.c3d: header: parameter section pointer (block 200, byte 101888)"));
  EXPECT_THAT(msg, HasSubstr("points past the end of the file (20000 bytes)"));

  bad = good;
  bad[512 + 3] = char(90);
  writeBytes(dir + "/proc.c3d", bad);
  EXPECT_THAT(inputErrorOf([&] { readC3d(dir + "/proc.c3d"); }), HasSubstr("expected processor type 84 (Intel), 85 (DEC) or 86 (MIPS)"));

  writeBytes(dir + "/cut.c3d", good.substr(0, 400000));
  msg = inputErrorOf([&] { readC3d(dir + "/cut.c3d"); });
  // (400000 - 11264) / 2336 = 166.4 frames present of 291.
  EXPECT_THAT(msg, HasSubstr("cut.c3d: data: truncated C3D data: expected 291 frames x 2336 bytes from byte 11264"));
  EXPECT_THAT(msg, HasSubstr("the file has 400000 bytes (166 complete frames)"));

  writeBytes(dir + "/params_cut.c3d", good.substr(0, 2000));
  EXPECT_THAT(inputErrorOf([&] { readC3d(dir + "/params_cut.c3d"); }), HasSubstr("truncated parameter section"));

  writeBytes(dir + "/tiny.c3d", "hello");
  EXPECT_THAT(inputErrorOf([&] { readC3d(dir + "/tiny.c3d"); }), HasSubstr("expected a C3D header of 512 bytes"));
}

// Hostile files found by fuzzing (fuzz/, docs/fuzzing.md) and made by
// fixtures/fuzz/make_c3d_reproducers.py from the seed fuzz/corpus/c3d/gait-intel-float.c3d. Each
// held a float where the reader wants an integer, beyond any integer: converting it was undefined
// behaviour (UBSan: "1e+10 is outside the range of representable values of type 'int'").
TEST(C3dFuzz, FloatParametersBeyondAnyIntegerAreOneLineErrors) {
  const std::map<std::string, std::string> expected = {
      {"point-data-start-1e10.c3d", "point-data-start-1e10.c3d: POINT:DATA_START: expected a whole number in 0..65535, got 1e+10"},
      {"analog-used-3e9.c3d", "analog-used-3e9.c3d: ANALOG:USED: expected a whole number in 0..65535, got 3e+09"},
      {"force-platform-used-1e10.c3d", "force-platform-used-1e10.c3d: FORCE_PLATFORM:USED: expected a whole number in -32768..65535, got 1e+10"},
      {"force-platform-type-1e10.c3d", "force-platform-type-1e10.c3d: FORCE_PLATFORM:TYPE: expected a whole number in -32768..65535, got 1e+10"},
      {"force-platform-channel-1e10.c3d", "force-platform-channel-1e10.c3d: FORCE_PLATFORM:CHANNEL: plate 1: expected analog channel numbers 1..36, got 1e+10"},
      {"residual-3e9.c3d", "residual-3e9.c3d: data/frame 218/point 1: expected a residual word of -1 (missing) or 0..2147483647, got 3e+09"},
      {"residual-nan.c3d", "residual-nan.c3d: data/frame 218/point 1: expected a residual word of -1 (missing) or 0..2147483647, got nan"}};
  for (const auto& [file, message] : expected) {
    SCOPED_TRACE(file);
    const std::string msg = inputErrorOf([&] { readC3d(test::fixturePath("fixtures/fuzz/c3d/" + file)); });
    EXPECT_THAT(msg, HasSubstr(message));
  }
  // The seed they were made from reads.
  EXPECT_EQ(readC3d(test::sourcePath("fuzz/corpus/c3d/gait-intel-float.c3d")).plates.size(), 3u);
}

// Absurd frame counts are refused before anything is allocated (issue 21 part 4), in a child
// process limited to 256 MB more than the test uses: a reader that allocated what the file claims
// would fail there with "out of memory" rather than take the machine's memory.
TEST(C3dFuzz, AbsurdFrameCountsAreRefusedBeforeAllocating) {
  const std::map<std::string, std::string> expected = {
      // TRIAL fields claiming 2^31 frames.
      {"frames-2e31.c3d", "POINT:FRAMES: expected at most 100000000 frames, got 2147483648"},
      // POINT:FRAMES = 1e8 with 3 frames of data.
      // (a frame of the seed is 56 points x 4 + 360 analog values, floats: 2336 bytes)
      {"point-frames-1e8.c3d", "data: truncated C3D data: expected 100000000 frames x 2336 bytes"},
      // POINT:FRAMES = 1e8 of nothing (no points, no analog): 1.2 GB of times and frame numbers.
      {"no-data-frames-1e8.c3d", "POINT:FRAMES: expected at most 16384 frames in a file of 16384 bytes without point or analog data, got 100000000"}};
  for (const auto& [file, message] : expected) {
    SCOPED_TRACE(file);
    const std::string path = test::fixturePath("fixtures/fuzz/c3d/" + file);
    const test::LimitedRun run = test::runWithMemoryLimit([&] { return readC3d(path).path; });
    EXPECT_EQ(run.outcome, "input error");
    EXPECT_THAT(run.message, HasSubstr(message));
  }
}

}  // namespace
}  // namespace kneesim::io
