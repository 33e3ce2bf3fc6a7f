#include "gap/boosting.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace kneesim::gap {
namespace {

// Rows in 10 groups of 60; features: x0, x1 uniform on [-1, 1], x2 pure noise.
struct Data {
  std::vector<std::vector<double>> x{3};
  std::vector<int> groups;
  std::vector<int> even, odd;  // groups 0, 2, 4... and 1, 3, 5...
};

Data makeData(unsigned seed) {
  Data d;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 600; ++i) {
    for (auto& c : d.x) c.push_back(u(rng));
    d.groups.push_back(i / 60);
    ((i / 60) % 2 ? d.odd : d.even).push_back(i);
  }
  return d;
}

double heldOutRmse(const BoostedTrees& m, const BinnedFeatures& b, const std::vector<double>& truth,
                   const std::vector<int>& rows) {
  double s = 0;
  for (int i : rows) s += std::pow(m.predict(b, i) - truth[i], 2);
  return std::sqrt(s / rows.size());
}

TEST(Binning, QuantileBinsAndAMissingBin) {
  std::vector<double> c;
  for (int i = 0; i < 100; ++i) c.push_back(i);
  c[7] = std::nan("");
  const BinnedFeatures b({c}, 4);
  // 99 finite values (7 is missing) in 4 bins, upper edges at the sorted values 24, 49 and 74 of 99
  // (25, 50, 75): 0..25 -> 1, 26..50 -> 2, 51..75 -> 3, 76..99 -> 4.
  EXPECT_EQ(b.getNumBins(0), 5);
  EXPECT_EQ(b.getBin(0, 7), 0);
  EXPECT_EQ(b.getBin(0, 0), 1);
  EXPECT_EQ(b.getBin(0, 25), 1);
  EXPECT_EQ(b.getBin(0, 26), 2);
  EXPECT_EQ(b.getBin(0, 75), 3);
  EXPECT_EQ(b.getBin(0, 99), 4);
  EXPECT_TRUE(std::isnan(b.getBinValue(0, 0)));
  EXPECT_NEAR(b.getBinValue(0, 4), 88, 0.5);  // the median of 76..99 (upper middle of 24 values)
}

// A step in x0 (the sign of a rate) under small noise: learned on the even groups, predicted on the
// odd ones within a tenth of the step; x0 carries nearly all the gain.
TEST(Boosting, LearnsAStepAndNamesItsFeature) {
  Data d = makeData(1);
  std::mt19937_64 rng(2);
  std::normal_distribution<double> e(0, 5);
  std::vector<double> y, truth;
  for (int i = 0; i < 600; ++i) {
    truth.push_back(d.x[0][i] > 0.2 ? 100 : -100);
    y.push_back(truth.back() + e(rng));
  }
  const BinnedFeatures b(d.x, 16);
  BoostingOptions o;
  const BoostedTrees m = BoostedTrees::fit(b, y, d.groups, d.even, o);
  EXPECT_EQ(m.getNumTrees(), 50);
  // 50 rounds at a learning rate of 0.1 recover 1 - 0.9^50 = 99.5 % of a step a tree can represent;
  // the step at 0.2 falls inside a bin of width ~0.125, so a few rows near it are misplaced.
  EXPECT_LT(heldOutRmse(m, b, truth, d.odd), 25);
  const auto& g = m.getGains();
  EXPECT_GT(g[0] / (g[0] + g[1] + g[2]), 0.95);
}

// A product x0 x1 (a load through a lever) needs two splits on different features: depth 2 learns
// it, stumps (additive) cannot -- a product of two zero-mean uniforms has no additive part.
TEST(Boosting, DepthTwoLearnsAProductStumpsCannot) {
  Data d = makeData(3);
  std::vector<double> y;
  for (int i = 0; i < 600; ++i) y.push_back(100 * d.x[0][i] * d.x[1][i]);
  const BinnedFeatures b(d.x, 16);
  BoostingOptions o;
  o.rounds = 150;
  const double sd = 100.0 / 3;  // SD of 100 x0 x1: 100 E[x^2] = 100 / 3
  const double rmse2 = heldOutRmse(BoostedTrees::fit(b, y, d.groups, d.even, o), b, y, d.odd);
  o.depth = 1;
  const double rmse1 = heldOutRmse(BoostedTrees::fit(b, y, d.groups, d.even, o), b, y, d.odd);
  EXPECT_LT(rmse2, 0.5 * sd);
  EXPECT_GT(rmse1, 0.9 * sd);
}

// Every leaf must hold rows of two groups: an offset per group carried by a feature that names the
// group cannot be fitted one group at a time (it is noise from cycle to cycle, not structure).
TEST(Boosting, LeavesSpanTwoGroups) {
  std::vector<std::vector<double>> x(1);
  std::vector<double> y;
  std::vector<int> groups, rows;
  for (int i = 0; i < 90; ++i) {
    groups.push_back(i / 30);
    x[0].push_back(i / 30);
    y.push_back(i / 30 == 1 ? 50.0 : 0.0);
    rows.push_back(i);
  }
  const BinnedFeatures b(x, 8);
  BoostingOptions o;
  o.min_leaf = 5;
  const BoostedTrees two = BoostedTrees::fit(b, y, groups, rows, o);
  // No split can separate group 1 from both others with two groups on each side: the mean, 16.7 N.
  for (int i : {0, 45, 80}) EXPECT_NEAR(two.predict(b, i), (1 - std::pow(0.9, 50)) * 50.0 / 3, 1e-9);
  o.min_groups = 1;
  const BoostedTrees one = BoostedTrees::fit(b, y, groups, rows, o);
  EXPECT_NEAR(one.predict(b, 45), 50.0, 1.0);
}

// Missing values sit in bin 0 and can be split off; partial dependence follows an additive slope.
TEST(Boosting, MissingValuesAndPartialDependence) {
  Data d = makeData(5);
  std::vector<double> y;
  for (int i = 0; i < 600; ++i) {
    if (i % 7 == 0) d.x[1][i] = std::nan("");
    y.push_back(30 * d.x[0][i] + (std::isnan(d.x[1][i]) ? 40 : 0));
  }
  const BinnedFeatures b(d.x, 16);
  BoostingOptions o;
  o.rounds = 200;
  const BoostedTrees m = BoostedTrees::fit(b, y, d.groups, d.even, o);
  EXPECT_LT(heldOutRmse(m, b, y, d.odd), 6);
  // Partial dependence on x0: the mean prediction with x0 set to each bin, against 30 x (slope 30).
  std::vector<double> px, py;
  for (int bin = 1; bin < b.getNumBins(0); ++bin) {
    double s = 0;
    for (int i : d.odd) s += m.predictWith(b, i, 0, bin);
    px.push_back(b.getBinValue(0, bin));
    py.push_back(s / d.odd.size());
  }
  const double slope = (py.back() - py.front()) / (px.back() - px.front());
  EXPECT_NEAR(slope, 30, 4);
}

}  // namespace
}  // namespace kneesim::gap
