#include "io/motion_compare.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "io_test_util.hpp"

namespace kneesim::io {
namespace {

using ::testing::HasSubstr;
using test_util::inputErrorOf;

Storage motion(std::vector<std::string> labels, std::vector<std::vector<double>> rows, bool degrees = true) {
  Storage s;
  s.name = "m";
  s.labels = std::move(labels);
  s.in_degrees = degrees;
  s.data.resize(Eigen::Index(rows.size()), Eigen::Index(s.labels.size()));
  for (size_t r = 0; r < rows.size(); ++r)
    for (size_t c = 0; c < rows[r].size(); ++c) s.data(Eigen::Index(r), Eigen::Index(c)) = rows[r][c];
  return s;
}

TEST(MotionCompare, MatchesRowsByTimeAndComputesRmsAndMaxPerColumn) {
  // b has an extra leading row and a row (t = 0.3) a does not have; columns in another order.
  const Storage a = motion({"time", "x", "y", "only_a"}, {{0.1, 1, 10, 0}, {0.2, 2, 20, 0}, {0.4, 4, 40, 0}});
  const Storage b = motion({"time", "y", "x", "only_b"},
                           {{0.0, 0, 0, 0}, {0.1, 13, 1, 0}, {0.2, 16, 2, 0}, {0.3, 0, 3, 0}, {0.4 + 1e-9, 40, 5, 0}});
  const MotionComparison c = compareMotions(a, b, "b.mot");
  EXPECT_EQ(c.rows_matched, 3);
  EXPECT_EQ(c.rows_first, 3);
  EXPECT_EQ(c.rows_second, 5);
  ASSERT_EQ(c.columns.size(), 2u);
  EXPECT_EQ(c.columns[0].label, "x");
  EXPECT_NEAR(c.columns[0].rms, std::sqrt(1.0 / 3.0), 1e-15);  // differences 0, 0, -1
  EXPECT_EQ(c.columns[0].max, 1.0);
  EXPECT_EQ(c.columns[1].label, "y");
  EXPECT_NEAR(c.columns[1].rms, std::sqrt((9.0 + 16.0) / 3.0), 1e-15);  // -3, 4, 0
  EXPECT_EQ(c.columns[1].max, 4.0);
  EXPECT_EQ(c.findWorst()->label, "y");
  EXPECT_EQ(c.only_in_first, std::vector<std::string>{"only_a"});
  EXPECT_EQ(c.only_in_second, std::vector<std::string>{"only_b"});
}

// Times that do not line up (a TRC's 3 decimals against OpenSim's output): the second motion is
// interpolated linearly at the first one's times; rows beyond its span are left out and counted.
TEST(MotionCompare, InterpolatesTheSecondMotionBetweenItsRows) {
  const Storage a = motion({"time", "x"}, {{0.05, 0.5}, {0.15, 2.0}, {0.2, 4.0}, {0.3, 9.0}});
  const Storage b = motion({"time", "x"}, {{0.0, 0.0}, {0.1, 1.0}, {0.2, 4.0}});
  const MotionComparison c = compareMotions(a, b, "b.mot");
  EXPECT_EQ(c.rows_matched, 1);       // 0.2
  EXPECT_EQ(c.rows_interpolated, 2);  // 0.05 -> 0.5, 0.15 -> 2.5
  EXPECT_EQ(c.rows_outside, 1);       // 0.3
  EXPECT_EQ(c.getRowsCompared(), 3);
  ASSERT_EQ(c.columns.size(), 1u);
  EXPECT_NEAR(c.columns[0].rms, std::sqrt(0.25 / 3.0), 1e-15);  // differences 0, -0.5, 0
  EXPECT_NEAR(c.columns[0].max, 0.5, 1e-15);
}

TEST(MotionCompare, RefusesMixedAngleUnitsAndDisjointTimes) {
  const Storage a = motion({"time", "x"}, {{0.1, 1}});
  EXPECT_THAT(inputErrorOf([&] { compareMotions(a, motion({"time", "x"}, {{0.1, 1}}, false), "rad.mot"); }),
              HasSubstr("rad.mot: inDegrees: expected angles in degrees like the first motion, got radians"));
  EXPECT_THAT(inputErrorOf([&] { compareMotions(a, motion({"time", "x"}, {{0.5, 1}}), "late.mot"); }),
              HasSubstr("late.mot: expected rows at or around the times of the first motion, got none"));
  EXPECT_THAT(inputErrorOf([&] { compareMotions(a, motion({"t", "x"}, {{0.1, 1}}), "notime.mot"); }),
              HasSubstr("notime.mot: expected a time column"));
}

}  // namespace
}  // namespace kneesim::io
