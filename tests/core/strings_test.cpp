#include "core/strings.hpp"

#include <gtest/gtest.h>

#include <set>

#include <cmath>
#include <limits>

namespace kneesim {
namespace {

TEST(Strings, SplitLinesAcceptsLfCrlfAndLoneCr) {
  const auto lines = splitLines("a\nb\r\nc\rd");
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0], "a");
  EXPECT_EQ(lines[1], "b");
  EXPECT_EQ(lines[2], "c");
  EXPECT_EQ(lines[3], "d");
}

TEST(Strings, SplitOnKeepsEmptyFields) {
  const auto f = splitOn("1,,3,", ',');
  ASSERT_EQ(f.size(), 4u);
  EXPECT_EQ(f[1], "");
  EXPECT_EQ(f[3], "");
}

TEST(Strings, ParseDoubleRejectsTrailingGarbage) {
  double v = 0;
  EXPECT_TRUE(tryParseDouble(" 1.5e3 ", v));
  EXPECT_DOUBLE_EQ(v, 1500.0);
  EXPECT_FALSE(tryParseDouble("1.5mm", v));
  EXPECT_TRUE(tryParseDouble("NaN", v));
  EXPECT_TRUE(std::isnan(v));
  try {
    parseDouble("abc", {"f.xml", 3, "Model/mass"});
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "f.xml:3: Model/mass: expected a number, got 'abc'");
  }
}

TEST(Strings, FormatSignificantDigits) {
  EXPECT_EQ(formatSignificant(0.25, 6), "0.25");
  EXPECT_EQ(formatSignificant(1.0 / 3.0, 3), "0.333");
  EXPECT_EQ(formatSignificant(2.0 / 3.0, 4), "0.6667");
  EXPECT_EQ(formatSignificant(1.5e6, 3), "1.5e+06");
  EXPECT_EQ(formatSignificant(-0.000123456, 2), "-0.00012");
  EXPECT_EQ(formatSignificant(123456.0, 6), "123456");
  EXPECT_EQ(formatSignificant(1234567.0, 6), "1.23457e+06");
  EXPECT_EQ(formatSignificant(std::numeric_limits<double>::infinity(), 6), "inf");
}

TEST(Strings, ParseBool) {
  EXPECT_TRUE(parseBool(" TRUE ", {}));
  EXPECT_FALSE(parseBool("false", {}));
  EXPECT_THROW(parseBool("yes", {}), InputError);
}

TEST(Strings, JoinSeparatesElementsInOrder) {
  EXPECT_EQ(join(std::vector<std::string>{"a", "b", "c"}, ", "), "a, b, c");
  EXPECT_EQ(join(std::set<std::string>{"z", "a"}, "; "), "a; z");
  EXPECT_EQ(join(std::vector<std::string_view>{"x"}, " + "), "x");
  EXPECT_EQ(join(std::vector<std::string>{}, ", "), "");
  EXPECT_EQ(join(std::vector<std::string>{"", "b"}, ","), ",b");  // an empty first element keeps its place
}

}  // namespace
}  // namespace kneesim
