#include "io/storage.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "io_test_util.hpp"
#include "support/test_data.hpp"

namespace kneesim::io {
namespace {

using ::testing::HasSubstr;
using test_util::inputErrorOf;
using test_util::withLineEnds;
using test_util::writeBytes;

TEST(Storage, ReadsOldSimmMotionHeaderOfOpenSimsIkAnswer) {
  KNEESIM_REQUIRE_DATA("opensim-ik-tests/std_subject01_walk1_ik.mot");
  const Storage s = readStorage(test::dataPath("opensim-ik-tests/std_subject01_walk1_ik.mot"));
  EXPECT_EQ(s.name, "first trial");
  EXPECT_TRUE(s.in_degrees);  // SIMM motion files are in degrees
  ASSERT_EQ(s.labels.size(), 24u);
  ASSERT_EQ(s.getNumRows(), 73);
  EXPECT_EQ(s.labels[0], "time");
  EXPECT_EQ(s.findColumn("knee_angle_r"), 10);
  EXPECT_EQ(s.findColumn("nope"), -1);
  // First data line: "0.4  5.21211788  -1.90606861 ... -55.15907196 (knee_angle_r) ...".
  EXPECT_DOUBLE_EQ(s.data(0, 0), 0.4);
  EXPECT_DOUBLE_EQ(s.data(0, 1), 5.21211788);
  EXPECT_DOUBLE_EQ(s.getColumn("knee_angle_r")[0], -55.15907196);
  // Last line: "1.6  6.35307847 ...".
  EXPECT_DOUBLE_EQ(s.data(72, 0), 1.6);
  EXPECT_DOUBLE_EQ(s.data(72, 1), 6.35307847);
  bool has_range = false;
  for (const auto& [k, v] : s.header) has_range = has_range || (k == "range" && v == "0.400000 1.600000");
  EXPECT_TRUE(has_range);
  EXPECT_THROW(s.getColumn("nope"), std::out_of_range);
}

TEST(Storage, ReadsModernHeaderWithPaddedColumns) {
  KNEESIM_REQUIRE_DATA("opensim-ik-tests/std_markers_coords_ik.sto");
  const Storage s = readStorage(test::dataPath("opensim-ik-tests/std_markers_coords_ik.sto"));
  EXPECT_EQ(s.name, "UNKNOWN");
  EXPECT_FALSE(s.in_degrees);
  ASSERT_EQ(s.labels.size(), 165u);
  ASSERT_EQ(s.getNumRows(), 10);
  EXPECT_EQ(s.labels[1], "R.ASIS_tx");
  EXPECT_EQ(s.labels.back(), "ground_torque_z");
  EXPECT_DOUBLE_EQ(s.data(0, 1), 0.61724762);  // "      0.61724762"
  EXPECT_DOUBLE_EQ(s.data(9, 0), 0.15);
}

const char* kModern =
    "walk ik\n"
    "version=1\n"
    "nRows=3\n"
    "nColumns=3\n"
    "inDegrees=yes\n"
    "DataType=double\n"
    "endheader\n"
    "time\tknee_angle_r\tpelvis_tx\n"
    "0.0 10.5 0.25\n"
    "0.01\t-1.25e+01\tNaN\n"
    "0.02\t  7   \t-nan(ind)\n";

TEST(Storage, AcceptsTabsSpacesCrlfAndCrAndNaNSpellings) {
  const std::string dir = test::scratchDir("sto_eol");
  for (const std::string eol : {"\n", "\r\n", "\r"}) {
    writeBytes(dir + "/a.sto", withLineEnds(kModern, eol));
    const Storage s = readStorage(dir + "/a.sto");
    EXPECT_EQ(s.name, "walk ik");
    EXPECT_TRUE(s.in_degrees);
    ASSERT_EQ(s.getNumRows(), 3);
    EXPECT_DOUBLE_EQ(s.data(1, 1), -12.5);
    EXPECT_DOUBLE_EQ(s.data(2, 1), 7.0);
    EXPECT_TRUE(std::isnan(s.data(1, 2)));
    EXPECT_TRUE(std::isnan(s.data(2, 2)));
    ASSERT_EQ(s.header.size(), 1u);
    EXPECT_EQ(s.header[0], (std::pair<std::string, std::string>{"DataType", "double"}));
  }
}

TEST(Storage, WriteThenReadKeepsValuesHeaderAndSmallNumbers) {
  const std::string dir = test::scratchDir("sto_write");
  Storage s;
  s.name = "errors";
  s.in_degrees = true;
  s.labels = {"time", "a", "b"};
  s.header = {{"DataType", "double"}, {"nRows", "999"}};  // nRows is regenerated, not copied
  s.data.resize(3, 3);
  s.data << 0.0, 123.456789012, 1.234567891e-7,  //
      0.0083333333, -0.5, std::nan(""),          //
      1e6, 0.0, -2.5e-12;
  writeStorage(dir + "/e.sto", s);
  const Storage r = readStorage(dir + "/e.sto");
  EXPECT_EQ(r.name, "errors");
  EXPECT_TRUE(r.in_degrees);
  EXPECT_EQ(r.labels, s.labels);
  ASSERT_EQ(r.header.size(), 1u);
  EXPECT_EQ(r.header[0].first, "DataType");
  ASSERT_EQ(r.getNumRows(), 3);
  EXPECT_NEAR(r.data(0, 1), 123.456789012, 5e-9);  // %.8f
  EXPECT_NEAR(r.data(1, 0), 0.0083333333, 5e-9);
  EXPECT_NEAR(r.data(0, 2), 1.234567891e-7, 1e-15);  // small values keep 9 significant digits
  EXPECT_NEAR(r.data(2, 2), -2.5e-12, 1e-20);
  EXPECT_TRUE(std::isnan(r.data(1, 2)));
  EXPECT_DOUBLE_EQ(r.data(2, 0), 1e6);
  const std::string text = test_util::readBytes(dir + "/e.sto");
  // The header as OpenSim's Storage::print writes it (e.g. OpenSim 4's IK output, "Coordinates"),
  // the two lines on units included; reading it back does not keep them as header pairs.
  EXPECT_THAT(text, HasSubstr("errors\nversion=1\nnRows=3\nnColumns=3\ninDegrees=yes\nDataType=double\n\n"
                              "Units are S.I. units (second, meters, Newtons, ...)\n"
                              "If the header above contains a line with 'inDegrees', this indicates whether rotational "
                              "values are in degrees (yes) or radians (no).\n\nendheader\ntime\ta\tb\n"));
  EXPECT_THAT(text, HasSubstr("0.00000000\t123.45678901\t1.23456789e-07\n"));
}

TEST(Storage, MalformedFilesAreErrorsWithLineNumbers) {
  const std::string dir = test::scratchDir("sto_bad");
  auto errorFor = [&](const std::string& text) {
    writeBytes(dir + "/bad.sto", text);
    return inputErrorOf([&] { readStorage(dir + "/bad.sto"); });
  };
  std::string t = kModern;
  EXPECT_THAT(errorFor(t.substr(0, t.find("endheader"))), HasSubstr("expected a header ending in 'endheader'"));
  EXPECT_THAT(errorFor(t.substr(0, t.rfind("0.02"))), HasSubstr("expected 3 data rows (nRows), got 2 (truncated file?)"));
  t = kModern;
  t.replace(t.find("0.0 10.5 0.25"), 13, "0.0 10.5");
  EXPECT_THAT(errorFor(t), HasSubstr("bad.sto:9: expected 3 values (one per column label), got 2"));
  t = kModern;
  t.replace(t.find("0.25"), 4, "abc");
  EXPECT_THAT(errorFor(t), HasSubstr("bad.sto:9: pelvis_tx: expected a number, got 'abc'"));
  t = kModern;
  t.replace(t.find("nColumns=3"), 10, "nColumns=4");
  EXPECT_THAT(errorFor(t), HasSubstr("bad.sto:8: expected 4 column labels (nColumns), got 3"));
  t = kModern;
  t.replace(t.find("inDegrees=yes"), 13, "inDegrees=maybe");
  EXPECT_THAT(errorFor(t), HasSubstr("bad.sto:5: inDegrees: expected yes or no, got 'maybe'"));
  EXPECT_THAT(inputErrorOf([&] { readStorage(dir + "/missing.sto"); }), HasSubstr("missing.sto: cannot open"));
}

}  // namespace
}  // namespace kneesim::io
