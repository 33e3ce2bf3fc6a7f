#include "io/csv.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "io_test_util.hpp"
#include "support/test_data.hpp"

namespace kneesim::io {
namespace {

using ::testing::HasSubstr;
using test_util::inputErrorOf;
using test_util::withLineEnds;
using test_util::writeBytes;

// Trailing commas on every line, one empty cell, a quoted name holding a comma and a quote.
const char* kCsv =
    "time,\"force, N\",\"say \"\"hi\"\"\",z,\n"
    "0.0,1.5,-2,3e2,\n"
    "0.1,,4,5,\n"
    "\n"
    "0.2,\"7\",8,9\n";

TEST(Csv, ReadsAnyLineEndTrailingCommasEmptyCellsAndQuotes) {
  const std::string dir = test::scratchDir("csv_eol");
  for (const std::string eol : {"\n", "\r\n", "\r"}) {
    writeBytes(dir + "/a.csv", withLineEnds(kCsv, eol));
    const CsvTable t = readCsv(dir + "/a.csv");
    EXPECT_EQ(t.labels, (std::vector<std::string>{"time", "force, N", "say \"hi\"", "z"}));
    ASSERT_EQ(t.data.rows(), 3);
    ASSERT_EQ(t.data.cols(), 4);
    EXPECT_DOUBLE_EQ(t.data(0, 1), 1.5);
    EXPECT_DOUBLE_EQ(t.data(0, 3), 300.0);
    EXPECT_TRUE(std::isnan(t.data(1, 1)));
    EXPECT_DOUBLE_EQ(t.data(2, 1), 7.0);
    EXPECT_DOUBLE_EQ(t.data(2, 3), 9.0);
    EXPECT_EQ(t.findColumn("z"), 3);
    EXPECT_EQ(t.findColumnIgnoreCase("TIME"), 0);
    EXPECT_EQ(t.findColumn("Z"), -1);
  }
}

TEST(Csv, RowShapeAndNumberErrorsNameTheLine) {
  const std::string dir = test::scratchDir("csv_bad");
  writeBytes(dir + "/a.csv", "a,b\r1,2\r3,4,5\r");
  EXPECT_THAT(inputErrorOf([&] { readCsv(dir + "/a.csv"); }), HasSubstr("a.csv:3: expected 2 cells (one per header column), got 3"));
  writeBytes(dir + "/b.csv", "a,b\n1,2\n3\n");
  EXPECT_THAT(inputErrorOf([&] { readCsv(dir + "/b.csv"); }), HasSubstr("b.csv:3: expected 2 cells"));
  writeBytes(dir + "/c.csv", "a,b\n1,x2\n");
  EXPECT_THAT(inputErrorOf([&] { readCsv(dir + "/c.csv"); }), HasSubstr("c.csv:2: b: expected a number, got 'x2'"));
  writeBytes(dir + "/d.csv", "a,,b\n1,2,3\n");
  EXPECT_THAT(inputErrorOf([&] { readCsv(dir + "/d.csv"); }), HasSubstr("d.csv:1: expected a name for column 2"));
  writeBytes(dir + "/e.csv", "\n\n");
  EXPECT_THAT(inputErrorOf([&] { readCsv(dir + "/e.csv"); }), HasSubstr("expected a header row"));
  writeBytes(dir + "/f.csv", "a,a\n1,2\n");
  EXPECT_THAT(inputErrorOf([&] { readCsv(dir + "/f.csv"); }), HasSubstr("f.csv:1: expected unique column names"));
  writeBytes(dir + "/g.csv", "\"a,b\n1\n");
  EXPECT_THAT(inputErrorOf([&] { readCsv(dir + "/g.csv"); }), HasSubstr("g.csv:1: expected a closing double quote"));
}

TEST(Csv, WriteThenReadRoundTrips) {
  const std::string dir = test::scratchDir("csv_write");
  CsvTable t;
  t.labels = {"time", "F, N", "q\"x"};
  t.data.resize(2, 3);
  t.data << 0.008333333333333, 1234.5678, std::nan(""),  //
      1.0, -1e-9, 42;
  writeCsv(dir + "/o.csv", t);
  const CsvTable r = readCsv(dir + "/o.csv");
  EXPECT_EQ(r.labels, t.labels);
  EXPECT_NEAR(r.data(0, 0), 0.008333333333333, 1e-14);
  EXPECT_NEAR(r.data(1, 1), -1e-9, 1e-20);
  EXPECT_TRUE(std::isnan(r.data(0, 2)));
  EXPECT_EQ(test_util::readBytes(dir + "/o.csv").substr(0, 22), "time,\"F, N\",\"q\"\"x\"\n0.0");
}

}  // namespace
}  // namespace kneesim::io
