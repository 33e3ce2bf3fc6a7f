#include "model/function.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace kneesim::model {
namespace {

double fd1(const Function& f, double x, double h = 1e-6) { return (f.calcValue(x + h) - f.calcValue(x - h)) / (2 * h); }
double fd2(const Function& f, double x, double h = 1e-6) {
  return (f.calcDerivative1(x + h) - f.calcDerivative1(x - h)) / (2 * h);
}

TEST(Function, ConstantLinearPolynomial) {
  auto c = makeConstant(2.5);
  EXPECT_EQ(c->calcValue(-3.0), 2.5);
  EXPECT_EQ(c->calcDerivative1(1.0), 0.0);
  EXPECT_EQ(c->getTypeName(), "Constant");

  auto l = makeLinear(-1.5, 0.25);
  EXPECT_DOUBLE_EQ(l->calcValue(2.0), -2.75);
  EXPECT_EQ(l->calcDerivative1(7.0), -1.5);
  EXPECT_EQ(l->calcDerivative2(7.0), 0.0);

  // 2x^3 - x + 4 (coefficients highest order first, as OpenSim).
  auto p = makePolynomial({2.0, 0.0, -1.0, 4.0});
  EXPECT_DOUBLE_EQ(p->calcValue(1.5), 2 * 3.375 - 1.5 + 4);
  EXPECT_DOUBLE_EQ(p->calcDerivative1(1.5), 6 * 2.25 - 1);
  EXPECT_DOUBLE_EQ(p->calcDerivative2(1.5), 12 * 1.5);
  EXPECT_EQ(makePolynomial({})->calcValue(3.0), 0.0);
}

TEST(Function, SimmSplineTwoPointsIsTheLine) {
  auto f = makeSimmSpline({1.0, 3.0}, {2.0, 6.0});  // y = 2x
  for (double x : {-1.0, 1.0, 1.7, 3.0, 10.0}) {
    EXPECT_NEAR(f->calcValue(x), 2 * x, 1e-14) << x;
    EXPECT_NEAR(f->calcDerivative1(x), 2.0, 1e-14) << x;
    EXPECT_EQ(f->calcDerivative2(x), 0.0) << x;
  }
}

TEST(Function, SimmSplineThreePointsIsTheParabolaThroughThem) {
  // Hand-derived: the parabola through (0,0), (1,1), (3,0) is y = -x^2/2 + 3x/2, y' = -x + 3/2, y'' = -1.
  auto f = makeSimmSpline({0.0, 1.0, 3.0}, {0.0, 1.0, 0.0});
  for (double x : {0.25, 1.0, 2.0, 2.9}) {
    EXPECT_NEAR(f->calcValue(x), -0.5 * x * x + 1.5 * x, 1e-14) << x;
    EXPECT_NEAR(f->calcDerivative1(x), -x + 1.5, 1e-14) << x;
    EXPECT_NEAR(f->calcDerivative2(x), -1.0, 1e-14) << x;
  }
  // Outside the knots SIMM extrapolates linearly with the end slopes (1.5 at 0, -1.5 at 3).
  EXPECT_NEAR(f->calcValue(4.0), -1.5, 1e-14);
  EXPECT_NEAR(f->calcValue(-2.0), -3.0, 1e-14);
  EXPECT_NEAR(f->calcDerivative1(4.0), -1.5, 1e-14);
  EXPECT_EQ(f->calcDerivative2(4.0), 0.0);
  EXPECT_EQ(f->calcDerivative2(-2.0), 0.0);
}

TEST(Function, SimmSplineReproducesACubicOnUnevenKnots) {
  // The end conditions match third divided differences, so cubic data give the cubic itself.
  auto cubic = [](double x) { return x * x * x - 2 * x * x + 0.5 * x + 1; };
  auto d1 = [](double x) { return 3 * x * x - 4 * x + 0.5; };
  auto d2 = [](double x) { return 6 * x - 4; };
  const std::vector<double> xs = {0.0, 0.5, 1.5, 2.0, 3.5};
  std::vector<double> ys;
  for (double x : xs) ys.push_back(cubic(x));
  auto f = makeSimmSpline(xs, ys);
  for (double x : {0.1, 0.5, 0.9, 1.7, 2.0, 2.6, 3.4}) {
    EXPECT_NEAR(f->calcValue(x), cubic(x), 1e-12) << x;
    EXPECT_NEAR(f->calcDerivative1(x), d1(x), 1e-11) << x;
    EXPECT_NEAR(f->calcDerivative2(x), d2(x), 1e-10) << x;
  }
  // Beyond the last knot: value and slope at 3.5 continued linearly.
  EXPECT_NEAR(f->calcValue(4.0), cubic(3.5) + 0.5 * d1(3.5), 1e-11);
}

TEST(Function, SimmSplinePassesThroughItsKnotsAndDerivativesMatchFiniteDifferences) {
  // gait2354's knee_r translation1 spline (subject01_simbody.osim), uneven knots.
  const std::vector<double> x = {-2.0944, -1.74533, -1.39626, -1.0472, -0.698132, -0.349066,
                                 -0.174533, 0.197344, 0.337395, 0.490178, 1.52146, 2.0944};
  const std::vector<double> y = {-0.0032, 0.00179, 0.00411, 0.0041, 0.00212, -0.001,
                                 -0.0031, -0.005227, -0.005435, -0.005574, -0.005435, -0.00525};
  auto f = makeSimmSpline(x, y);
  for (size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(f->calcValue(x[i]), y[i], 1e-15) << i;
  for (double q = -2.05; q < 2.05; q += 0.0137) {
    EXPECT_NEAR(f->calcDerivative1(q), fd1(*f, q), 1e-7) << q;
    EXPECT_NEAR(f->calcDerivative2(q), fd2(*f, q), 1e-6) << q;
  }
  // Continuity of value and slope at an interior knot.
  EXPECT_NEAR(f->calcValue(0.337395 - 1e-12), f->calcValue(0.337395 + 1e-12), 1e-13);
  EXPECT_NEAR(f->calcDerivative1(0.337395 - 1e-10), f->calcDerivative1(0.337395 + 1e-10), 1e-9);
  // Within 2e-13 of an end knot OpenSim returns the knot's value.
  EXPECT_EQ(f->calcValue(2.0944 - 1e-13), -0.00525);
}

TEST(Function, NaturalCubicSplineIsEvaluatedAsOpenSimDoes) {
  // OpenSim renames NaturalCubicSpline to SimmSpline on load: same numbers, other name.
  const std::vector<double> x = {0.0, 0.17453293, 0.34906585, 0.52359878, 0.6981317};
  const std::vector<double> y = {0.0496029, 0.16886844, 0.23535302, 0.26977369, 0.28992734};
  auto n = makeNaturalCubicSpline(x, y);
  auto s = makeSimmSpline(x, y);
  EXPECT_EQ(n->getTypeName(), "NaturalCubicSpline");
  for (double q = -0.1; q < 0.8; q += 0.05) {
    EXPECT_EQ(n->calcValue(q), s->calcValue(q));
    EXPECT_EQ(n->calcDerivative1(q), s->calcDerivative1(q));
  }
}

TEST(Function, PiecewiseLinear) {
  auto f = makePiecewiseLinear({0.0, 1.0, 3.0}, {0.0, 2.0, 1.0});
  EXPECT_DOUBLE_EQ(f->calcValue(0.5), 1.0);
  EXPECT_DOUBLE_EQ(f->calcValue(2.0), 1.5);
  EXPECT_DOUBLE_EQ(f->calcDerivative1(0.5), 2.0);
  EXPECT_DOUBLE_EQ(f->calcDerivative1(2.0), -0.5);
  EXPECT_EQ(f->calcDerivative2(2.0), 0.0);
  EXPECT_DOUBLE_EQ(f->calcValue(-1.0), -2.0);  // first segment's slope
  EXPECT_DOUBLE_EQ(f->calcValue(5.0), 0.0);    // last segment's slope
  EXPECT_DOUBLE_EQ(f->calcValue(1.0), 2.0);
  EXPECT_DOUBLE_EQ(f->calcValue(0.0), 0.0);  // the end knots give their values
  EXPECT_DOUBLE_EQ(f->calcValue(3.0), 1.0);
}

TEST(Function, MultiplierScalesValueAndDerivatives) {
  auto g = makeSimmSpline({0.0, 1.0, 2.0}, {0.0, 0.1, 0.4});  // 0.1 x^2
  auto f = makeMultiplier(g, 1.14724);
  EXPECT_NEAR(f->calcValue(1.5), 1.14724 * 0.225, 1e-15);
  EXPECT_NEAR(f->calcDerivative1(1.5), 1.14724 * 0.3, 1e-14);
  EXPECT_NEAR(f->calcDerivative2(1.5), 1.14724 * 0.2, 1e-14);
  EXPECT_EQ(f->getArgumentSize(), 1);
  EXPECT_THROW(makeMultiplier(nullptr, 2.0), std::invalid_argument);
}

TEST(Function, KnotChecks) {
  EXPECT_EQ(checkKnots({0, 1}, {0, 1}), "");
  EXPECT_NE(checkKnots({0, 1, 2}, {0, 1}).find("expected as many y values"), std::string::npos);
  EXPECT_NE(checkKnots({0}, {0}).find("at least 2"), std::string::npos);
  EXPECT_NE(checkKnots({0, 0.5, 0.5}, {0, 1, 2}).find("strictly increasing"), std::string::npos);
  EXPECT_NE(checkKnots({0, NAN}, {0, 1}).find("finite"), std::string::npos);
  EXPECT_THROW(makeSimmSpline({0, -1}, {0, 1}), std::invalid_argument);
  EXPECT_THROW(makePiecewiseLinear({0}, {0}), std::invalid_argument);
}

TEST(Function, LinearForm) {
  double s = 0, i = 0;
  EXPECT_TRUE(findLinearForm(*makeLinear(2, 3), s, i));
  EXPECT_EQ(s, 2);
  EXPECT_EQ(i, 3);
  EXPECT_TRUE(findLinearForm(*makeMultiplier(makeLinear(1, 0.5), -2), s, i));
  EXPECT_EQ(s, -2);
  EXPECT_EQ(i, -1);
  EXPECT_TRUE(findLinearForm(*makeConstant(0.2), s, i));
  EXPECT_EQ(s, 0);
  EXPECT_EQ(i, 0.2);
  EXPECT_TRUE(findLinearForm(*makePolynomial({0, 0, 4, 1}), s, i));
  EXPECT_EQ(s, 4);
  EXPECT_EQ(i, 1);
  EXPECT_FALSE(findLinearForm(*makePolynomial({1, 0, 0}), s, i));
  EXPECT_FALSE(findLinearForm(*makeSimmSpline({0, 1}, {0, 1}), s, i));
}

}  // namespace
}  // namespace kneesim::model
