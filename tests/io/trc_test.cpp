#include "io/trc.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "io/marker_table.hpp"
#include "io_test_util.hpp"
#include "support/memory_limit.hpp"
#include "support/test_data.hpp"

namespace kneesim::io {
namespace {

using ::testing::HasSubstr;
using test_util::inputErrorOf;
using test_util::withLineEnds;
using test_util::writeBytes;

// A 3-marker, 4-frame TRC in millimetres with gaps: a blank triple (M2 frame 2), NaN (M3
// frame 3), a half-blank triple (M1 frame 4, counts as missing) and a trailing tab.
const char* kGapTrc =
    "PathFileType\t4\t(X/Y/Z)\tgaps.trc\n"
    "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames\n"
    "100\t100\t4\t3\tmm\t100\t10\t4\n"
    "Frame#\tTime\tM1\t\t\tM2\t\t\tM3\t\t\n"
    "\t\tX1\tY1\tZ1\tX2\tY2\tZ2\tX3\tY3\tZ3\n"
    "\n"
    "10\t0.09\t1\t2\t3\t10\t20\t30\t100\t200\t300\n"
    "11\t0.10\t1.5\t2.5\t3.5\t\t\t\t101\t201\t301\t\n"
    "12\t0.11\t2\t3\t4\t11\t21\t31\tNaN\tnan\tNaN\n"
    "13\t0.12\t2.5\t\t4.5\t12\t22\t32\t103\t203\t303\n";

TEST(Trc, ReadsOpenSimSyntheticMarkersInMetres) {
  KNEESIM_REQUIRE_DATA("opensim-ik-tests/subject01_synthetic_marker_data.trc");
  const MarkerTable t = readTrc(test::dataPath("opensim-ik-tests/subject01_synthetic_marker_data.trc"));
  EXPECT_EQ(t.getNumFrames(), 73);
  EXPECT_EQ(t.getNumMarkers(), 31);
  EXPECT_DOUBLE_EQ(t.rate, 60.0);
  EXPECT_EQ(t.original_units, "m");
  EXPECT_EQ(t.labels.front(), "Sternum");
  EXPECT_EQ(t.labels[4], "R.ASIS");
  // Row 1 of the file: "1  0.4  0.67076  1.3961  -0.025106 ..." (units m, no conversion).
  EXPECT_EQ(t.frame_numbers.front(), 1);
  EXPECT_DOUBLE_EQ(t.time.front(), 0.4);
  EXPECT_DOUBLE_EQ(t.getPosition(0, 0).x(), 0.67076);
  EXPECT_DOUBLE_EQ(t.getPosition(0, 0).y(), 1.3961);
  EXPECT_DOUBLE_EQ(t.getPosition(0, 0).z(), -0.025106);
  EXPECT_EQ(t.frame_numbers.back(), 73);
  EXPECT_DOUBLE_EQ(t.time.back(), 1.6);
  for (const auto& [name, gaps] : t.calcGapCounts()) EXPECT_EQ(gaps, 0) << name;
}

TEST(Trc, ConvertsMillimetresOfConstraintTest) {
  KNEESIM_REQUIRE_DATA("opensim-ik-tests/constraintTest.trc");
  const MarkerTable t = readTrc(test::dataPath("opensim-ik-tests/constraintTest.trc"));
  EXPECT_EQ(t.getNumFrames(), 2105);
  EXPECT_EQ(t.getNumMarkers(), 44);
  EXPECT_DOUBLE_EQ(t.rate, 200.0);
  EXPECT_EQ(t.original_units, "mm");
  EXPECT_EQ(t.labels.front(), "R.Shoulder");
  EXPECT_EQ(t.labels.back(), "L_HJC");
  // Row 1: "1  0.00000  90.174  1884.322  -1717.028" mm.
  EXPECT_NEAR(t.getPosition(0, 0).x(), 0.090174, 1e-12);
  EXPECT_NEAR(t.getPosition(0, 0).y(), 1.884322, 1e-12);
  EXPECT_NEAR(t.getPosition(0, 0).z(), -1.717028, 1e-12);
  // Line 2000 of the file = frame 1994: "1994  9.96500  175.200  1905.529  -1743.552".
  EXPECT_EQ(t.frame_numbers[1993], 1994);
  EXPECT_DOUBLE_EQ(t.time[1993], 9.965);
  EXPECT_NEAR(t.getPosition(1993, 0).x(), 0.175200, 1e-12);
  EXPECT_NEAR(t.getPosition(1993, 0).z(), -1.743552, 1e-12);
}

TEST(Trc, GapsBecomeNaNAndAreCountedWithAnyLineEnd) {
  const std::string dir = test::scratchDir("trc_gaps");
  for (const std::string eol : {"\n", "\r\n", "\r"}) {
    writeBytes(dir + "/gaps.trc", withLineEnds(kGapTrc, eol));
    const MarkerTable t = readTrc(dir + "/gaps.trc");
    ASSERT_EQ(t.getNumFrames(), 4);
    ASSERT_EQ(t.getNumMarkers(), 3);
    EXPECT_EQ(t.labels, (std::vector<std::string>{"M1", "M2", "M3"}));
    EXPECT_EQ(t.frame_numbers.front(), 10);
    EXPECT_NEAR(t.getPosition(1, 0).x(), 0.0015, 1e-15);
    EXPECT_NEAR(t.getPosition(3, 2).z(), 0.303, 1e-15);
    EXPECT_TRUE(t.isMissing(1, 1));
    EXPECT_TRUE(std::isnan(t.getPosition(1, 1).x()));
    EXPECT_TRUE(t.isMissing(2, 2));
    EXPECT_TRUE(t.isMissing(3, 0));  // one blank coordinate makes the whole marker missing
    EXPECT_FALSE(t.isMissing(0, 0));
    const auto gaps = t.calcGapCounts();
    EXPECT_EQ(gaps[0], (std::pair<std::string, int>{"M1", 1}));
    EXPECT_EQ(gaps[1], (std::pair<std::string, int>{"M2", 1}));
    EXPECT_EQ(gaps[2], (std::pair<std::string, int>{"M3", 1}));
  }
}

TEST(Trc, AcceptsUnitSpellingsAndRejectsUnknownUnitsOnLine3) {
  const std::string dir = test::scratchDir("trc_units");
  auto withUnits = [&](const std::string& u) {
    std::string s = kGapTrc;
    s.replace(s.find("\tmm\t"), 4, "\t" + u + "\t");
    writeBytes(dir + "/u.trc", s);
    return dir + "/u.trc";
  };
  EXPECT_NEAR(readTrc(withUnits("Millimeters")).getPosition(0, 1).x(), 0.010, 1e-15);
  EXPECT_NEAR(readTrc(withUnits("CM")).getPosition(0, 1).x(), 0.10, 1e-15);
  EXPECT_NEAR(readTrc(withUnits("metres")).getPosition(0, 1).x(), 10.0, 1e-15);
  const std::string path = withUnits("inches");
  const std::string msg = inputErrorOf([&] { readTrc(path); });
  EXPECT_THAT(msg, HasSubstr(path + ":3:"));
  EXPECT_THAT(msg, HasSubstr("'inches'"));
}

TEST(Trc, TruncatedFileIsAnErrorNamingTheLine) {
  const std::string dir = test::scratchDir("trc_trunc");
  std::string s = kGapTrc;
  s = s.substr(0, s.find("12\t0.11"));  // rows 10 and 11 only; header promises 4
  writeBytes(dir + "/t.trc", s);
  const std::string msg = inputErrorOf([&] { readTrc(dir + "/t.trc"); });
  EXPECT_THAT(msg, HasSubstr("t.trc:9:"));
  EXPECT_THAT(msg, HasSubstr("truncated"));
  EXPECT_THAT(msg, HasSubstr("NumFrames=4"));
  EXPECT_THAT(msg, HasSubstr("got 2"));
}

TEST(Trc, ShortRowAndNonNumberAreErrorsWithLineNumbers) {
  const std::string dir = test::scratchDir("trc_rows");
  std::string s = kGapTrc;
  const std::string row12 = "12\t0.11\t2\t3\t4\t11\t21\t31\tNaN\tnan\tNaN";
  s.replace(s.find(row12), row12.size(), "12\t0.11\t2\t3\t4\t11\t21");
  writeBytes(dir + "/short.trc", s);
  std::string msg = inputErrorOf([&] { readTrc(dir + "/short.trc"); });
  EXPECT_THAT(msg, HasSubstr("short.trc:9:"));
  EXPECT_THAT(msg, HasSubstr("expected 11 cells"));
  EXPECT_THAT(msg, HasSubstr("got 7"));

  s = kGapTrc;
  s.replace(s.find("101\t201"), 3, "1o1");
  writeBytes(dir + "/word.trc", s);
  msg = inputErrorOf([&] { readTrc(dir + "/word.trc"); });
  EXPECT_THAT(msg, HasSubstr("word.trc:8: M3/X: expected a number, got '1o1'"));
}

TEST(Trc, HeaderProblemsAreErrors) {
  const std::string dir = test::scratchDir("trc_header");
  writeBytes(dir + "/a.trc", "hello\n");
  EXPECT_THAT(inputErrorOf([&] { readTrc(dir + "/a.trc"); }), HasSubstr("a.trc:1:"));
  std::string s = kGapTrc;
  s.replace(s.find("\t3\tmm"), 2, "\t4");  // NumMarkers 4, but 3 names
  writeBytes(dir + "/b.trc", s);
  EXPECT_THAT(inputErrorOf([&] { readTrc(dir + "/b.trc"); }), HasSubstr("b.trc:4: expected 4 marker names"));
  EXPECT_THAT(inputErrorOf([&] { readTrc(dir + "/missing.trc"); }), HasSubstr("missing.trc"));
}

TEST(Trc, WriteThenReadRoundTripsPositionsGapsAndFrames) {
  const std::string dir = test::scratchDir("trc_write");
  writeBytes(dir + "/in.trc", kGapTrc);
  const MarkerTable in = readTrc(dir + "/in.trc");
  for (const std::string units : {"mm", "m", "cm"}) {
    writeTrc(dir + "/out.trc", in, units);
    const MarkerTable out = readTrc(dir + "/out.trc");
    EXPECT_EQ(out.original_units, units);
    ASSERT_EQ(out.getNumFrames(), in.getNumFrames());
    EXPECT_EQ(out.labels, in.labels);
    EXPECT_EQ(out.frame_numbers, in.frame_numbers);
    EXPECT_DOUBLE_EQ(out.rate, 100.0);
    for (int f = 0; f < in.getNumFrames(); ++f) {
      EXPECT_NEAR(out.time[f], in.time[f], 1e-12);
      for (int m = 0; m < in.getNumMarkers(); ++m) {
        EXPECT_EQ(out.isMissing(f, m), in.isMissing(f, m));
        if (!in.isMissing(f, m)) {
          EXPECT_NEAR((out.getPosition(f, m) - in.getPosition(f, m)).norm(), 0.0, 1e-12);
        }
      }
    }
  }
  EXPECT_THROW(writeTrc(dir + "/bad.trc", in, "furlongs"), InputError);
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.trc"));
}

TEST(Trc, DamagedTextOnlyEverThrowsInputError) {
  const std::string dir = test::scratchDir("trc_fuzz");
  const std::string alphabet = "0123456789.-+eEnaNIf\t\t\n\r ,#X";
  std::mt19937 rng(7);
  int ok = 0, rejected = 0;
  for (int iter = 0; iter < 2000; ++iter) {
    std::string s = kGapTrc;
    for (int h = 0, n = 1 + int(rng() % 4); h < n; ++h) s[rng() % s.size()] = alphabet[rng() % alphabet.size()];
    if (rng() % 4 == 0) s.resize(rng() % s.size());
    writeBytes(dir + "/f.trc", s);
    try {
      const MarkerTable t = readTrc(dir + "/f.trc");
      EXPECT_EQ(t.positions.size(), size_t(t.getNumFrames()) * size_t(t.getNumMarkers()));
      ++ok;
    } catch (const InputError&) {
      ++rejected;
    } catch (const std::exception& e) {
      FAIL() << "iteration " << iter << ": expected InputError, got " << e.what();
    }
  }
  EXPECT_GT(ok, 50);
  EXPECT_GT(rejected, 50);
}

// Found by fuzzing (fuzz/, docs/fuzzing.md): a whole frame number no int holds was converted to
// one (undefined behaviour, UBSan: "1e+10 is outside the range of representable values of type
// 'int'"). The reproducers are fixtures/fuzz/trc/.
TEST(TrcFuzz, FrameNumbersNoIntegerHoldsAreOneLineErrors) {
  for (const std::string file : {"frame-1e10.trc", "frame-inf.trc"}) {
    const std::string path = test::fixturePath("fixtures/fuzz/trc/" + file);
    EXPECT_EQ(inputErrorOf([&] { readTrc(path); }),
              path + ":7: Frame#: expected a frame number, got '" + (file == "frame-inf.trc" ? "inf" : "1e10") + "'");
  }
}

// A header claiming a million markers (and 10^8 frames) over one name is refused before anything
// is allocated for them (issue 21 part 4), checked in a child process limited to 256 MB more than
// the test uses.
TEST(TrcFuzz, AHeaderClaimingAMillionMarkersIsRefusedBeforeAllocating) {
  const std::string path = test::fixturePath("fixtures/fuzz/trc/markers-1e6.trc");
  const test::LimitedRun run = test::runWithMemoryLimit([&] { return readTrc(path).source_file; });
  EXPECT_EQ(run.outcome, "input error");
  EXPECT_EQ(run.message, path + ":4: expected 1000000 marker names (NumMarkers), got 1");
}

TEST(MarkerTable, ReadMarkerFileDispatchesOnExtensionAndFindsMarkers) {
  const std::string dir = test::scratchDir("trc_dispatch");
  writeBytes(dir + "/UPPER.TRC", kGapTrc);
  const MarkerTable t = readMarkerFile(dir + "/UPPER.TRC");
  EXPECT_EQ(t.findMarker("M2"), 1);
  EXPECT_EQ(t.findMarker("M4"), -1);
  EXPECT_THAT(inputErrorOf([&] { readMarkerFile(dir + "/x.csv"); }), HasSubstr("expected a .trc or .c3d file"));

  MarkerTable p;
  p.labels = {"JW:RAsis", "synch_bar:bar1", "LAsis", "A:X", "B:X"};
  EXPECT_EQ(p.findMarker("RAsis"), 0);   // subject prefix stripped
  EXPECT_EQ(p.findMarker("JW:RAsis"), 0);
  EXPECT_EQ(p.findMarker("LAsis"), 2);
  EXPECT_EQ(p.findMarker("X"), -1);      // ambiguous between two subjects
}

}  // namespace
}  // namespace kneesim::io
