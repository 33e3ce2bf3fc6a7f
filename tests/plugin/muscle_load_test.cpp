// The muscle_load gap effect (plugins/muscle_load): nested (gain 0 gives the law back), its closed
// form F = F_base + gain (F_muscles - F_base) against the Hertz law written out here, its Jacobian
// against central differences, and a trial without the channel named.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "gap/effect.hpp"
#include "identify/contact_law.hpp"
#include "plugin/registry.hpp"

namespace kneesim {
namespace {

TEST(MuscleLoad, ClosedFormNestedAndDerivatives) {
  plugin::Registry registry;
  registry.loadPlugin("hertz");
  registry.loadPlugin("muscle_load");
  EXPECT_EQ(registry.getEffectNames(), std::vector<std::string>{"muscle_load"});
  const identify::ContactLaw hertz = identify::ContactLaw::fromRegistry(registry, "hertz");
  const gap::Effect e = gap::Effect::fromRegistry(registry, "muscle_load");
  const identify::ContactLaw law = gap::makeExtendedLaw(hertz, {e});
  std::vector<double> time;
  identify::ChannelMap ch;
  for (int i = 0; i < 120; ++i) {
    const double t = i / 120.0;
    time.push_back(t);
    ch["S"].push_back(1e-6 * (600 + 900 * std::pow(std::sin(M_PI * t), 2)));
    ch["knee_muscle_total"].push_back(300 + 1800 * std::pow(std::sin(2 * M_PI * t), 2));
  }
  const identify::LawInputs in(law, ch, time, "synthetic");
  Eigen::VectorXd p = law.getDefaultValues();
  const double e_mod = 2e9, nu = 0.45, r = 0.037, k = e_mod / (1 - nu * nu);
  p[0] = e_mod;
  Eigen::VectorXd f;
  law.calcForce(p, in, f);
  for (int i = 0; i < f.size(); ++i) {
    const double fh = 2.0 / (3.0 * r) * k * std::pow(ch["S"][size_t(i)] / M_PI, 1.5);
    EXPECT_NEAR(f[i], fh, 1e-9 * fh);  // gain 0: the law itself
  }
  p[3] = 0.6;
  law.calcForce(p, in, f);
  for (int i = 0; i < f.size(); ++i) {
    const double fh = 2.0 / (3.0 * r) * k * std::pow(ch["S"][size_t(i)] / M_PI, 1.5);
    EXPECT_NEAR(f[i], fh + 0.6 * (ch["knee_muscle_total"][size_t(i)] - fh), 1e-9 * fh);
  }
  const Eigen::VectorXd err = identify::calcDerivativeError(law, p, in);
  for (int j = 0; j < err.size(); ++j) EXPECT_LT(err[j], 2e-6) << law.getParameter(j).name;
  ch.erase("knee_muscle_total");
  std::string what;
  try {
    const identify::LawInputs missing(law, ch, time, "no_muscles");
  } catch (const std::exception& ex) {
    what = ex.what();
  }
  EXPECT_THAT(what, ::testing::HasSubstr("knee_muscle_total"));
}

}  // namespace
}  // namespace kneesim
