#include "identify/identifiability.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace kneesim::identify {
namespace {

TEST(Identifiability, FullRankMatrixHasNoNullDirection) {
  // Columns orthogonal with norms 3 and 4 over 2 rows: singular values (4, 3) / sqrt(2).
  Eigen::MatrixXd s(2, 2);
  s << 3, 0, 0, 4;
  const IdentifiabilityReport r = analyzeSensitivity(s, {"a", "b"}, {1, 2});
  EXPECT_TRUE(r.isIdentifiable());
  ASSERT_EQ(r.singular_values.size(), 2u);
  EXPECT_NEAR(r.singular_values[0], 4 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(r.singular_values[1], 3 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(r.condition_number, 4.0 / 3.0, 1e-12);
  EXPECT_NEAR(r.column_rms[0], 3 / std::sqrt(2.0), 1e-12);
  EXPECT_TRUE(r.weak_directions.empty());
}

TEST(Identifiability, ProportionalColumnsGiveTheHandDerivedNullDirection) {
  // Column b = 2 * column a: the forces do not change along (2, -1) / sqrt(5).
  Eigen::MatrixXd s(4, 3);
  s << 1, 2, 0.3, 2, 4, -1, 3, 6, 0.5, 4, 8, 2;
  const IdentifiabilityReport r = analyzeSensitivity(s, {"a", "b", "c"}, {0, 0, 0});
  ASSERT_EQ(r.null_directions.size(), 1u);
  const auto& d = r.null_directions[0];
  EXPECT_LT(d.relative, 1e-14);
  EXPECT_NEAR(d.components[0], 2 / std::sqrt(5.0), 1e-12);
  EXPECT_NEAR(d.components[1], -1 / std::sqrt(5.0), 1e-12);
  EXPECT_NEAR(d.components[2], 0.0, 1e-12);
  EXPECT_EQ(r.describe(d), "0.894 a - 0.447 b");
  const std::vector<double> lev = r.calcNullSpaceLeverage();
  EXPECT_NEAR(lev[0], 2 / std::sqrt(5.0), 1e-12);
  EXPECT_NEAR(lev[2], 0.0, 1e-12);
  EXPECT_TRUE(std::isinf(r.condition_number) || r.condition_number > 1e14);
}

TEST(Identifiability, NearlyProportionalColumnsAreWeak) {
  Eigen::MatrixXd s(3, 2);
  s << 1, 1, 1, 1.0001, 1, 1;
  const IdentifiabilityReport r = analyzeSensitivity(s, {"a", "b"}, {1, 1}, 1e-6, 1e-3);
  EXPECT_TRUE(r.isIdentifiable());
  ASSERT_EQ(r.weak_directions.size(), 1u);
  EXPECT_GT(r.weak_directions[0].relative, 1e-6);
  EXPECT_LT(r.weak_directions[0].relative, 1e-3);
}

TEST(Identifiability, FewerRowsThanColumnsAndZeroColumns) {
  Eigen::MatrixXd s(1, 2);
  s << 1, 1;
  IdentifiabilityReport r = analyzeSensitivity(s, {"a", "b"}, {1, 1});
  EXPECT_EQ(r.null_directions.size(), 1u);
  EXPECT_EQ(r.singular_values.size(), 2u);
  Eigen::MatrixXd z = Eigen::MatrixXd::Zero(5, 1);
  r = analyzeSensitivity(z, {"a"}, {1});
  EXPECT_EQ(r.null_directions.size(), 1u);
  EXPECT_TRUE(std::isinf(r.condition_number));
}

}  // namespace
}  // namespace kneesim::identify
