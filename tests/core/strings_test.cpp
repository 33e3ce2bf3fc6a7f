#include "core/strings.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <set>

#include "support/input_error.hpp"
#include "support/test_data.hpp"

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

TEST(Strings, FormatRoundTripIsTheShortestExactText) {
  EXPECT_EQ(formatRoundTrip(0.004), "0.004");  // %.17g would write 0.0040000000000000001
  EXPECT_EQ(formatRoundTrip(66.7), "66.7");
  EXPECT_EQ(formatRoundTrip(1e-5), "1e-05");
  EXPECT_EQ(formatRoundTrip(-90), "-90");
  EXPECT_EQ(formatRoundTrip(0.1 + 0.2), "0.30000000000000004");
  EXPECT_EQ(formatRoundTrip(1.0 / 3.0), "0.3333333333333333");
  EXPECT_EQ(formatRoundTrip(6.02214076e23), "6.02214076e+23");
  EXPECT_EQ(formatRoundTrip(std::numeric_limits<double>::quiet_NaN()), "nan");
  for (double v : {1.0 / 7.0, 6.02214076e23, -2.5e-300, 123456789.125})
    EXPECT_EQ(std::strtod(formatRoundTrip(v).c_str(), nullptr), v) << formatRoundTrip(v);
}

TEST(Strings, ShellQuoteIsOneWord) {
  EXPECT_EQ(shellQuote("a b"), "'a b'");
  EXPECT_EQ(shellQuote("it's $HOME"), "'it'\\''s $HOME'");
  EXPECT_EQ(shellQuote(""), "''");
}

TEST(Strings, ParseBool) {
  EXPECT_TRUE(parseBool(" TRUE ", {}));
  EXPECT_FALSE(parseBool("false", {}));
  EXPECT_THROW(parseBool("yes", {}), InputError);
}

TEST(Strings, ReadFileTextNamesAFolderAsOne) {
  const std::string dir = test::scratchDir("strings_folder");
  EXPECT_EQ(test::inputErrorOf([&] { readFileText(dir); }), dir + ": expected a file, got a folder");
  EXPECT_EQ(test::inputErrorOf([&] { readFileText(dir + "/none.txt"); }),
            dir + "/none.txt: cannot open file: No such file or directory");
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
