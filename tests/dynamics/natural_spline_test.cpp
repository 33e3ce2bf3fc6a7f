// Interpolating natural splines against a hand-solved natural cubic spline and against the
// properties that define the natural spline of each degree (interpolation, continuity of the
// first 2m-2 derivatives, derivatives m..2m-2 zero at the ends), which make it unique.
#include "dynamics/natural_spline.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

namespace kneesim::dynamics {
namespace {

// Natural cubic spline through (0,0) (1,1) (2,0) (3,1): with unit steps the second derivatives
// M1, M2 solve 4 M1 + M2 = 6 (y0 - 2 y1 + y2) = -12 and M1 + 4 M2 = 6 (y1 - 2 y2 + y3) = 12, so
// M1 = -4, M2 = 4; on [0,1] s(x) = x + M1 (x^3 - x) / 6, s(0.5) = 0.75, s'(0) = 1 + 4/6.
TEST(NaturalSpline, CubicMatchesHandSolution) {
  const NaturalSplineFitter fitter({0, 1, 2, 3}, 3);
  const NaturalSpline s = fitter.fit({0, 1, 0, 1});
  EXPECT_NEAR(s.calcValue(0.5), 0.75, 1e-13);
  EXPECT_NEAR(s.calcDerivative(0.0, 1), 1.0 + 4.0 / 6.0, 1e-13);
  EXPECT_NEAR(s.calcDerivative(1.0, 2), -4.0, 1e-12);
  EXPECT_NEAR(s.calcDerivative(2.0, 2), 4.0, 1e-12);
  EXPECT_NEAR(s.calcDerivative(0.0, 2), 0.0, 1e-12);
  EXPECT_NEAR(s.calcDerivative(3.0, 2), 0.0, 1e-12);
  // On [2,3] by symmetry s(x) = 1 - s(3 - x) + ... : check the value at 2.5 directly:
  // s = y2 (3-x) + y3 (x-2) + M2 ((3-x)^3 - (3-x)) / 6 = 0.5 + 4 (0.125 - 0.5) / 6 = 0.25.
  EXPECT_NEAR(s.calcValue(2.5), 0.25, 1e-13);
  // Outside the data a natural cubic spline is a straight line.
  EXPECT_NEAR(s.calcDerivative(-1.0, 2), 0.0, 1e-13);
  EXPECT_NEAR(s.calcValue(-1.0), -(1.0 + 4.0 / 6.0), 1e-12);
}

class NaturalSplineDegree : public ::testing::TestWithParam<int> {};

TEST_P(NaturalSplineDegree, HasTheDefiningProperties) {
  const int degree = GetParam(), m = (degree + 1) / 2;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> step(0.5, 1.5), val(-1, 1);
  std::vector<double> x{0.0}, y;
  for (int i = 1; i < 14; ++i) x.push_back(x.back() + 0.1 * step(rng));
  for (size_t i = 0; i < x.size(); ++i) y.push_back(val(rng));
  const NaturalSpline s = NaturalSplineFitter(x, degree).fit(y);
  EXPECT_EQ(s.getDegree(), degree);
  double below[8], above[8];
  for (size_t i = 0; i < x.size(); ++i) {
    EXPECT_NEAR(s.calcValue(x[i]), y[i], 1e-10) << i;
    if (i == 0 || i + 1 == x.size()) continue;
    s.calcDerivatives(x[i] - 1e-9, degree, below);
    s.calcDerivatives(x[i], degree, above);
    for (int o = 1; o <= 2 * m - 2; ++o)
      EXPECT_NEAR(below[o], above[o], 1e-5 * (1 + std::abs(above[o])) * std::pow(10.0, o)) << "knot " << i << " order " << o;
  }
  for (double end : {x.front(), x.back()}) {
    s.calcDerivatives(end, degree, above);
    for (int o = m; o <= 2 * m - 2; ++o) EXPECT_NEAR(above[o], 0.0, 1e-7 * std::pow(10.0, 2 * o)) << "end " << end << " order " << o;
  }
}

TEST_P(NaturalSplineDegree, ReproducesPolynomialsBelowItsHalfOrder) {
  const int degree = GetParam(), m = (degree + 1) / 2;
  std::vector<double> x, y;
  for (int i = 0; i < 12; ++i) x.push_back(0.3 * i + 0.01 * i * i);
  auto p = [&](double t) { return m >= 3 ? 2 - t + 0.5 * t * t : (m == 2 ? 2 - t : 2.0); };
  for (double t : x) y.push_back(p(t));
  const NaturalSpline s = NaturalSplineFitter(x, degree).fit(y);
  for (double t = -0.5; t < 4.0; t += 0.137) EXPECT_NEAR(s.calcValue(t), p(t), 1e-10) << t;
  if (m >= 3) EXPECT_NEAR(s.calcDerivative(1.234, 2), 1.0, 1e-9);
}

INSTANTIATE_TEST_SUITE_P(Degrees, NaturalSplineDegree, ::testing::Values(1, 3, 5, 7));

TEST(NaturalSpline, QuinticDifferentiatesASmoothSignal) {
  std::vector<double> t, y;
  for (int i = 0; i <= 120; ++i) {
    t.push_back(i / 60.0);
    y.push_back(std::sin(3 * t.back()));
  }
  const NaturalSpline s = NaturalSplineFitter(t, 5).fit(y);
  double d[3];
  s.calcDerivatives(1.01, 2, d);
  EXPECT_NEAR(d[1], 3 * std::cos(3 * 1.01), 1e-7);
  EXPECT_NEAR(d[2], -9 * std::sin(3 * 1.01), 1e-5);
}

TEST(NaturalSpline, RejectsBadAbscissae) {
  EXPECT_THROW(NaturalSplineFitter({0, 1, 1, 2, 3, 4}, 5), std::invalid_argument);
  EXPECT_THROW(NaturalSplineFitter({0, 1, 2}, 3), std::invalid_argument);
  EXPECT_THROW(NaturalSplineFitter({0, 1, 2, 3}, 4), std::invalid_argument);
  EXPECT_THROW(NaturalSplineFitter({0, 1, std::nan(""), 3}, 3), std::invalid_argument);
}

}  // namespace
}  // namespace kneesim::dynamics
