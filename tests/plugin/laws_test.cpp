// The contact laws shipped in plugins/: forces against hand-computed values and independent
// derivations, exact Jacobians, errors on bad input.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "identify/contact_law.hpp"
#include "plugin/registry.hpp"

namespace kneesim::identify {
namespace {

using ::testing::HasSubstr;

struct Laws : ::testing::Test {
  plugin::Registry registry;
  void SetUp() override {
    registry.loadPlugin("hertz");
    registry.loadPlugin("elastic_foundation");
  }
  ContactLaw law(const std::string& name) { return ContactLaw(registry.getContactLaw(name), registry.findOrigin(name)); }
};

TEST_F(Laws, HertzMatchesEquation2ByHand) {
  const ContactLaw hertz = law("hertz");
  ASSERT_EQ(hertz.getNumParameters(), 3);
  EXPECT_EQ(hertz.getParameter(2).name, "R");
  EXPECT_TRUE(hertz.getParameter(2).fixed_by_default);
  EXPECT_DOUBLE_EQ(hertz.getParameter(2).default_value, 0.037);  // paper section 3.1
  EXPECT_DOUBLE_EQ(hertz.getParameter(1).default_value, 0.45);
  EXPECT_EQ(hertz.getInputNames(), std::vector<std::string>{"S"});

  const std::vector<double> time{0, 1, 2, 3};
  const ChannelMap ch{{"S", {0.0, 1e-4, 5e-4, 1.1e-3}}};
  const LawInputs in(hertz, ch, time, "t");
  Eigen::VectorXd f;
  // The paper's result E = 4.67 GPa, nu = 0.25, R = 37 mm; references from
  // F = 2/(3R) E/(1-nu^2) (S/pi)^1.5 evaluated independently (Python, double precision).
  const Eigen::Vector3d p(4.67e9, 0.25, 0.037);
  hertz.calcForce(p, in, f);
  EXPECT_EQ(f[0], 0.0);
  EXPECT_NEAR(f[1], 16118.618336567504, 1e-9 * 16118.6);
  EXPECT_NEAR(f[2], 180211.63151969764, 1e-9 * 180211.6);
  EXPECT_NEAR(f[3], 588053.5007747058, 1e-9 * 588053.5);
  const Eigen::VectorXd d = hertz.calcDerived(p);
  EXPECT_EQ(hertz.getDerivedNames(), (std::vector<std::string>{"K", "K_over_R"}));
  EXPECT_NEAR(d[0], 4981333333.333333, 1e-3);
  EXPECT_NEAR(d[1], 134630630630.63063, 1e-1);
}

TEST_F(Laws, HertzDependsOnEAndNuOnlyThroughK) {
  const ContactLaw hertz = law("hertz");
  const std::vector<double> time{0, 1};
  const ChannelMap ch{{"S", {2e-4, 7e-4}}};
  const LawInputs in(hertz, ch, time, "t");
  Eigen::VectorXd f1, f2;
  // Same K = 2e9: (E, nu) = (1.5e9, 0.5) and (2e9, 0).
  hertz.calcForce(Eigen::Vector3d(1.5e9, 0.5, 0.04), in, f1);
  hertz.calcForce(Eigen::Vector3d(2e9, 0.0, 0.04), in, f2);
  EXPECT_NEAR((f1 - f2).cwiseAbs().maxCoeff(), 0.0, 1e-9 * f2.maxCoeff());
}

TEST_F(Laws, HertzPerCompartmentSumsTwoContacts) {
  const ContactLaw total = law("hertz"), ml = law("hertz_ml");
  const std::vector<double> time{0, 1};
  const ChannelMap ch{{"S", {4e-4, 8e-4}}, {"S_medial", {2e-4, 4e-4}}, {"S_lateral", {2e-4, 4e-4}}};
  Eigen::VectorXd ft, fm;
  const Eigen::Vector3d p(1e9, 0.45, 0.037);
  total.calcForce(p, LawInputs(total, ch, time, "t"), ft);
  ml.calcForce(p, LawInputs(ml, ch, time, "t"), fm);
  // Two equal halves: 2 (S/2)^1.5 = S^1.5 / sqrt(2).
  EXPECT_NEAR(fm[0] / ft[0], 1 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(fm[1] / ft[1], 1 / std::sqrt(2.0), 1e-12);
}

TEST_F(Laws, JacobiansAreExact) {
  const std::vector<double> time{0, 1, 2, 3, 4};
  const ChannelMap ch{{"S", {0.0, 1e-5, 2e-4, 6e-4, 1.2e-3}},
                      {"S_medial", {0.0, 4e-6, 1e-4, 3.5e-4, 7e-4}},
                      {"S_lateral", {0.0, 6e-6, 1e-4, 2.5e-4, 5e-4}}};
  for (const std::string name : {"hertz", "hertz_ml"}) {
    const ContactLaw l = law(name);
    const Eigen::VectorXd err = calcDerivativeError(l, Eigen::Vector3d(8e8, 0.42, 0.035), LawInputs(l, ch, time, "t"));
    for (int j = 0; j < err.size(); ++j) EXPECT_LT(err[j], 1e-6) << name << " parameter " << j;
  }
  const ContactLaw ef = law("elastic_foundation");
  Eigen::VectorXd p(4);
  p << 8e8, 0.42, 0.035, 0.007;
  const Eigen::VectorXd err = calcDerivativeError(ef, p, LawInputs(ef, ch, time, "t"));
  for (int j = 0; j < err.size(); ++j) EXPECT_LT(err[j], 1e-6) << "elastic_foundation parameter " << j;
}

TEST_F(Laws, ElasticFoundationMatchesTheSpringBedIntegratedNumerically) {
  const ContactLaw ef = law("elastic_foundation");
  ASSERT_EQ(ef.getNumParameters(), 4);
  const double e = 9e8, nu = 0.4, r = 0.03, h = 0.006, delta = 2e-4;
  // Independent route: integrate p(r) = K_ef u(r) / h over the contact circle of a sphere pressed
  // in by delta, u(r) = delta - r^2/(2R), with Simpson's rule.
  const double k_ef = (1 - nu) * e / ((1 + nu) * (1 - 2 * nu));
  const double a = std::sqrt(2 * r * delta);
  const int m = 2000;
  double integral = 0;
  for (int i = 0; i <= m; ++i) {
    const double x = a * i / m;
    const double g = k_ef / h * (delta - x * x / (2 * r)) * 2 * M_PI * x;
    integral += g * (i == 0 || i == m ? 1 : (i % 2 ? 4 : 2));
  }
  integral *= a / m / 3;
  const std::vector<double> time{0};
  const ChannelMap ch{{"S", {M_PI * a * a}}};
  Eigen::VectorXd f, p(4);
  p << e, nu, r, h;
  ef.calcForce(p, LawInputs(ef, ch, time, "t"), f);
  EXPECT_NEAR(f[0], integral, 1e-9 * integral);
  // Derived: K_ef = (1-nu) E / ((1+nu)(1-2nu)) = 0.6 * 9e8 / (1.4 * 0.2) by hand = 1.9285714e9.
  EXPECT_NEAR(ef.calcDerived(p)[0], 0.6 * 9e8 / 0.28, 1e-3);
  EXPECT_NEAR(ef.calcDerived(p)[1], 0.6 * 9e8 / 0.28 / 0.006, 1);
}

TEST_F(Laws, NegativeAreaAndMissingChannelAreClearErrors) {
  const ContactLaw hertz = law("hertz");
  const std::vector<double> time{0, 1};
  const ChannelMap ch{{"S", {1e-4, -1e-5}}};
  const LawInputs in(hertz, ch, time, "walk1", {"setup.xml", 4, "Trial[walk1]"});
  Eigen::VectorXd f;
  try {
    hertz.calcForce(Eigen::Vector3d(1e9, 0.45, 0.037), in, f);
    FAIL() << "negative area accepted";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "setup.xml:4: Trial[walk1]: contact law 'hertz' failed on trial 'walk1': expected a contact area S >= "
                 "0 m^2, got -1e-05 at frame 1");
  }
  const ContactLaw ml = law("hertz_ml");
  try {
    LawInputs bad(ml, ch, time, "walk1", {"setup.xml", 4, "Trial[walk1]"});
    FAIL() << "missing channel accepted";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "setup.xml:4: Trial[walk1]: contact law 'hertz_ml' needs input channel 'S_medial', which trial "
                 "'walk1' does not have (channels: time, S)");
  }
}

}  // namespace
}  // namespace kneesim::identify
