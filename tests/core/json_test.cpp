#include "core/json.hpp"

#include <gtest/gtest.h>

#include <limits>

namespace kneesim {
namespace {

// The reports are read back by Python's json module and by jq: a NaN written as the bare token NaN
// would make the whole file invalid JSON, so every undefined figure must come out as null.
TEST(Json, FiniteNumbersStayNumbers) {
  EXPECT_EQ(jsonNumber(1.25).dump(), "1.25");
  EXPECT_EQ(jsonNumber(-0.0).dump(), "-0.0");
  EXPECT_EQ(jsonNumber(std::numeric_limits<double>::max()).get<double>(), std::numeric_limits<double>::max());
}

TEST(Json, NanAndInfinitiesBecomeNull) {
  EXPECT_EQ(jsonNumber(std::numeric_limits<double>::quiet_NaN()).dump(), "null");
  EXPECT_EQ(jsonNumber(std::numeric_limits<double>::infinity()).dump(), "null");
  EXPECT_EQ(jsonNumber(-std::numeric_limits<double>::infinity()).dump(), "null");
  const nlohmann::json report = {{"r2", jsonNumber(std::numeric_limits<double>::quiet_NaN())}, {"n", 3}};
  EXPECT_EQ(nlohmann::json::parse(report.dump()), report);
}

}  // namespace
}  // namespace kneesim
