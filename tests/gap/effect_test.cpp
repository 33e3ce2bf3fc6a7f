#include "gap/effect.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "plugin/registry.hpp"
#include "support/input_error.hpp"

namespace kneesim::gap {
namespace {

using kneesim::test::inputErrorOf;
using ::testing::HasSubstr;

// A 1.2 s trial at 120 Hz with every channel the catalogue reads, smooth and away from zero.
struct Channels {
  std::vector<double> time;
  identify::ChannelMap ch;
};

Channels makeChannels() {
  Channels c;
  const int n = 144;
  for (int i = 0; i < n; ++i) {
    const double t = i / 120.0;
    const double s = 1e-6 * (300 + 700 * std::exp(-std::pow((t - 0.35) / 0.15, 2)) +
                             400 * std::exp(-std::pow((t - 0.8) / 0.1, 2)));
    const double ds = 1e-6 * (700 * std::exp(-std::pow((t - 0.35) / 0.15, 2)) * (-2 * (t - 0.35) / (0.15 * 0.15)) +
                              400 * std::exp(-std::pow((t - 0.8) / 0.1, 2)) * (-2 * (t - 0.8) / (0.1 * 0.1)));
    const double th = 0.1 + 0.9 * std::pow(std::sin(M_PI * t / 1.2), 2);
    c.time.push_back(t);
    c.ch["S"].push_back(s);
    c.ch["S_medial"].push_back(s * (0.55 + 0.1 * std::sin(5 * t)));
    c.ch["S_lateral"].push_back(s * (0.45 - 0.1 * std::sin(5 * t)));
    c.ch["dS_dt"].push_back(ds);
    c.ch["knee_flexion"].push_back(th);
    c.ch["dS_dflexion"].push_back(-4e-4 * (1 + 0.5 * std::cos(3 * t)));
    c.ch["dS_dap"].push_back(0.02 * (1 + 0.3 * std::sin(2 * t)));
    for (int mm : {2, 3, 5, 6}) c.ch["S@" + std::to_string(mm) + "mm"].push_back(s + 0.25 * (mm - 4) * 1e-3 * std::sqrt(s));
    c.ch["knee_flexion_rate"].push_back(0.9 * M_PI / 1.2 * std::sin(2 * M_PI * t / 1.2));  // d theta / dt
    c.ch["GRF:vertical"].push_back(600 * std::pow(std::sin(M_PI * t / 1.2), 2));
    c.ch["GRF:vertical_left"].push_back(600 * std::pow(std::cos(M_PI * t / 1.2), 2));
    c.ch["GRF:x"].push_back(-120 * std::sin(2 * M_PI * t / 1.2));
    c.ch["GRF:y"].push_back(30 * std::sin(M_PI * t / 1.2));
    c.ch["trial_time"].push_back(t);
    c.ch["EMG:cocontraction"].push_back(0.2 + 0.1 * std::cos(4 * t));
    c.ch["knee_axial_force"].push_back(650 * std::pow(std::sin(M_PI * t / 1.2), 2) + 40);
    c.ch["knee_flexion_moment"].push_back(30 * std::sin(2 * M_PI * t / 1.2));
    c.ch["knee_adduction_moment"].push_back(-15 * std::pow(std::sin(M_PI * t / 1.2), 2));
  }
  return c;
}

class Effects : public ::testing::Test {
 protected:
  void SetUp() override {
    registry.loadPlugin("hertz");
    registry.loadPlugin("gap_effects");
  }
  plugin::Registry registry;
};

TEST_F(Effects, TheCatalogueIsRegistered) {
  EXPECT_EQ(registry.getEffectNames(),
            (std::vector<std::string>{"adhesion_jkr", "ap_translation", "creep", "emg_cocontraction", "exponent",
                                      "flexion_gain", "flexion_offset", "grf_left", "grf_load", "grf_shear",
                                      "hysteresis", "knee_load", "load_flexion", "ml_compartments", "radius_flexion",
                                      "rate", "threshold", "time_delay", "trial_drift"}));
  EXPECT_THAT(registry.findOrigin("time_delay"), HasSubstr("libkneesim_gap_effects.so"));
  EXPECT_THAT(inputErrorOf([&] { Effect::fromRegistry(registry, "delay", {"g.xml", 3, "effects"}); }),
              HasSubstr("g.xml:3: effects: no effect named 'delay' (loaded: adhesion_jkr, "));
}

// Every effect at its defaults gives the baseline's force back exactly, and its Jacobian (exact for
// force maps, central differences for rewrites) agrees with central differences elsewhere.
TEST_F(Effects, EveryEffectIsNestedAndItsDerivativesAreRight) {
  const Channels c = makeChannels();
  const identify::ContactLaw hertz = identify::ContactLaw::fromRegistry(registry, "hertz");
  const identify::LawInputs base_in(hertz, c.ch, c.time, "synthetic");
  Eigen::VectorXd base_params = hertz.getDefaultValues();
  base_params[0] = 2e9;
  Eigen::VectorXd f0;
  hertz.calcForce(base_params, base_in, f0);
  for (const auto& name : registry.getEffectNames()) {
    SCOPED_TRACE(name);
    const Effect e = Effect::fromRegistry(registry, name);
    const identify::ContactLaw law = makeExtendedLaw(hertz, {e});
    EXPECT_EQ(law.getName(), "hertz+" + name);
    ASSERT_EQ(law.getNumParameters(), 3 + e.getNumParameters());
    EXPECT_EQ(law.getParameter(3).name, name + "." + e.getParameters()[0].name);
    const identify::LawInputs in(law, c.ch, c.time, "synthetic");
    Eigen::VectorXd p = law.getDefaultValues();
    p.head(3) = base_params;
    Eigen::VectorXd f;
    Eigen::MatrixXd j;
    law.calcForce(p, in, f, &j);
    for (int i = 0; i < f.size(); ++i) ASSERT_EQ(f[i], f0[i]) << "frame " << i;
    // Away from the defaults: move every effect parameter by a fraction of its scale (inside bounds).
    for (int k = 0; k < e.getNumParameters(); ++k) {
      const auto& q = e.getParameters()[k];
      p[3 + k] = std::clamp(q.default_value + 0.7 * q.typical_scale, q.lower, q.upper);
    }
    const Eigen::VectorXd err = identify::calcDerivativeError(law, p, in);
    for (int k = 0; k < err.size(); ++k) EXPECT_LT(err[k], 2e-6) << law.getParameter(k).name;
  }
}

double hertzOf(double s, double k, double r) { return 2.0 / (3.0 * r) * k * std::pow(s / M_PI, 1.5); }

// Closed forms of a few effects, written out independently of the plugin.
TEST_F(Effects, ClosedForms) {
  const Channels c = makeChannels();
  const identify::ContactLaw hertz = identify::ContactLaw::fromRegistry(registry, "hertz");
  const double e_mod = 2e9, nu = 0.45, r = 0.037, k = e_mod / (1 - nu * nu);
  auto eval = [&](const std::string& effect, double value) {
    const identify::ContactLaw law = makeExtendedLaw(hertz, {Effect::fromRegistry(registry, effect)});
    const identify::LawInputs in(law, c.ch, c.time, "t");
    Eigen::VectorXd p = law.getDefaultValues();
    p[0] = e_mod;
    p[3] = value;
    Eigen::VectorXd f;
    law.calcForce(p, in, f);
    return f;
  };
  const auto& s = c.ch.at("S");
  const Eigen::VectorXd fe = eval("exponent", 0.4), fj = eval("adhesion_jkr", 3e4), fo = eval("flexion_offset", 0.1),
                        fg = eval("grf_load", 0.5), ft = eval("threshold", 0.001), fd = eval("time_delay", 0.05),
                        fk = eval("knee_load", 0.4);
  for (size_t i = 0; i < s.size(); ++i) {
    const double fh = hertzOf(s[i], k, r);
    EXPECT_NEAR(fe[i], fh * std::pow(s[i] / 2.5e-3, 0.4), 1e-9 * fh);
    EXPECT_NEAR(fj[i], fh - 3e4 * std::pow(s[i] / M_PI, 0.75), 1e-9 * fh);
    EXPECT_NEAR(fo[i], hertzOf(s[i] + c.ch.at("dS_dflexion")[i] * 0.1, k, r), 1e-9 * fh);
    EXPECT_NEAR(fg[i], fh + 0.5 * c.ch.at("GRF:vertical")[i], 1e-9 * fh);
    EXPECT_NEAR(fk[i], fh + 0.4 * c.ch.at("knee_flexion_moment")[i], 1e-9 * fh);  // its first parameter, flexion
    // S(h) is linear in sqrt(S)-scaled steps between the channels: S(5 mm) = S@5mm exactly (a knot).
    EXPECT_NEAR(ft[i], hertzOf(c.ch.at("S@5mm")[i], k, r), 1e-9 * fh);
    // The delayed force is the baseline 50 ms earlier (6 frames at 120 Hz: a sample, so exact).
    if (i >= 6) EXPECT_NEAR(fd[i], hertzOf(s[i - 6], k, r), 1e-9 * fh);
    else EXPECT_NEAR(fd[i], hertzOf(s[0], k, r), 1e-9 * fh);  // held at the first sample
  }
  // Between samples the delay interpolates with cubic Hermite: 3.3 ms is within 1 % of the
  // analytic force of the smooth area curve.
  const Eigen::VectorXd fd2 = eval("time_delay", 0.0033);
  for (size_t i = 2; i < s.size(); ++i) {
    const double t = c.time[i] - 0.0033;
    const double st = 1e-6 * (300 + 700 * std::exp(-std::pow((t - 0.35) / 0.15, 2)) +
                              400 * std::exp(-std::pow((t - 0.8) / 0.1, 2)));
    EXPECT_NEAR(fd2[i], hertzOf(st, k, r), 1e-2 * hertzOf(st, k, r));
  }
}

// The additive terms of motion_load_effects.c, written out by hand: direction (tanh of the flexion rate
// over omega0 = 0.3 rad/s), GRF through a lever theta, the other foot's GRF, the horizontal components,
// and a drift over the recording's time.
TEST_F(Effects, MotionAndLoadEffectsClosedForms) {
  const Channels c = makeChannels();
  const identify::ContactLaw hertz = identify::ContactLaw::fromRegistry(registry, "hertz");
  auto eval = [&](const std::string& effect, const std::vector<double>& values) {
    const identify::ContactLaw law = makeExtendedLaw(hertz, {Effect::fromRegistry(registry, effect)});
    const identify::LawInputs in(law, c.ch, c.time, "t");
    Eigen::VectorXd p = law.getDefaultValues();
    p[0] = 2e9;
    for (size_t k = 0; k < values.size(); ++k) p[3 + k] = values[k];
    Eigen::VectorXd f;
    law.calcForce(p, in, f);
    return f;
  };
  const Eigen::VectorXd f0 = eval("hysteresis", {0.0}), fh = eval("hysteresis", {150.0}),
                        fw = eval("hysteresis", {150.0, 1.0}), fl = eval("load_flexion", {0.8}),
                        fg = eval("grf_left", {-0.4}), fs = eval("grf_shear", {1.5, -2.0}),
                        fd = eval("trial_drift", {12.0});
  for (size_t i = 0; i < c.time.size(); ++i) {
    const double v = c.ch.at("knee_flexion_rate")[i];
    EXPECT_NEAR(fh[i] - f0[i], 150.0 * std::tanh(v / 0.3), 1e-9);
    EXPECT_NEAR(fw[i] - f0[i], 150.0 * std::tanh(v / 1.0), 1e-9);
    EXPECT_NEAR(fl[i] - f0[i], 0.8 * c.ch.at("GRF:vertical")[i] * c.ch.at("knee_flexion")[i], 1e-9);
    EXPECT_NEAR(fg[i] - f0[i], -0.4 * c.ch.at("GRF:vertical_left")[i], 1e-9);
    EXPECT_NEAR(fs[i] - f0[i], 1.5 * c.ch.at("GRF:x")[i] - 2.0 * c.ch.at("GRF:y")[i], 1e-9);
    EXPECT_NEAR(fd[i] - f0[i], 12.0 * c.time[i], 1e-9);
  }
  // Flexing (t < 0.6 s here) adds h, extending removes it: at the fastest flexion (t = 0.3 s, 2.36 rad/s)
  // tanh(7.85) = 1 to 7 digits.
  EXPECT_NEAR(fh[36] - f0[36], 150.0, 1e-4);
  EXPECT_NEAR(fh[108] - f0[108], -150.0, 1e-4);
}

TEST_F(Effects, EffectsComposeAndMissingChannelsAreNamed) {
  Channels c = makeChannels();
  const identify::ContactLaw hertz = identify::ContactLaw::fromRegistry(registry, "hertz");
  // A rewrite feeding a map that reads the rewritten channel: derivatives still right.
  const identify::ContactLaw law = makeExtendedLaw(
      hertz, {Effect::fromRegistry(registry, "flexion_offset"), Effect::fromRegistry(registry, "exponent"),
              Effect::fromRegistry(registry, "time_delay")});
  EXPECT_EQ(law.getName(), "hertz+flexion_offset+exponent+time_delay");
  const identify::LawInputs in(law, c.ch, c.time, "t");
  Eigen::VectorXd p = law.getDefaultValues();
  p[0] = 2e9;
  p[3] = 0.05;
  p[4] = 0.3;
  p[6] = 0.02;
  const Eigen::VectorXd err = identify::calcDerivativeError(law, p, in);
  for (int k = 0; k < err.size(); ++k) EXPECT_LT(err[k], 2e-6) << law.getParameter(k).name;
  // The same law extended again (an extended law as baseline).
  const identify::ContactLaw twice = makeExtendedLaw(law, {Effect::fromRegistry(registry, "grf_load")});
  const identify::LawInputs in2(twice, c.ch, c.time, "t");
  Eigen::VectorXd p2 = twice.getDefaultValues();
  p2.head(p.size()) = p;
  Eigen::VectorXd f1, f2;
  law.calcForce(p, in, f1);
  twice.calcForce(p2, in2, f2);
  EXPECT_EQ(f1, f2);
  // Missing inputs: the effect lists them, and the law's inputs name them for trials.
  c.ch.erase("dS_dflexion");
  EXPECT_EQ(Effect::fromRegistry(registry, "flexion_offset").findMissingInputs(c.ch),
            std::vector<std::string>{"dS_dflexion"});
  EXPECT_TRUE(Effect::fromRegistry(registry, "time_delay").findMissingInputs(c.ch).empty());
  EXPECT_THAT(inputErrorOf([&] { identify::LawInputs bad(law, c.ch, c.time, "walk"); }),
              HasSubstr("needs input channel 'dS_dflexion', which trial 'walk' does not have"));
}

// Tables the registry refuses.
int noMap(const double*, const kneesim_inputs*, const double*, int, const double*, double*, double*, double*, char*,
          int) {
  return 0;
}
const kneesim_param kBadDefault[] = {{"g", "1", 0, 1, 2, 1, 0, "default outside its bounds"}};
const char* const kIn[] = {"S"};
const char* const kRw[] = {"dS_dt"};

TEST(EffectRegistry, InvalidTablesAreRefused) {
  plugin::Registry r;
  const kneesim_effect no_stage{sizeof(kneesim_effect), "none", "", 0, nullptr, 0, nullptr, 0, nullptr, nullptr,
                                nullptr, nullptr, nullptr};
  EXPECT_THROW(r.adoptEffect(&no_stage), InternalError);
  const kneesim_effect bad_default{sizeof(kneesim_effect), "bad", "", 1, kBadDefault, 1, kIn, 0, nullptr, nullptr,
                                   noMap, nullptr, nullptr};
  try {
    r.adoptEffect(&bad_default);
    FAIL();
  } catch (const InternalError& e) {
    EXPECT_THAT(e.what(), HasSubstr("effect 'bad': parameter 'g': expected lower <= default <= upper"));
  }
  auto rewrite = [](const double*, const kneesim_inputs*, double*, char*, int) { return 0; };
  const kneesim_effect unlisted{sizeof(kneesim_effect), "rw", "", 0, nullptr, 1, kIn, 1, kRw, +rewrite, nullptr,
                                nullptr, nullptr};
  try {
    r.adoptEffect(&unlisted);
    FAIL();
  } catch (const InternalError& e) {
    EXPECT_THAT(e.what(), HasSubstr("rewritten channel 'dS_dt' must also be listed in inputs"));
  }
  const kneesim_effect good{sizeof(kneesim_effect), "good", "", 0, nullptr, 1, kIn, 0, nullptr, nullptr, noMap,
                            nullptr, nullptr};
  r.adoptEffect(&good);
  EXPECT_THROW(r.adoptEffect(&good), InternalError);  // the name is taken
  EXPECT_EQ(r.getEffectNames(), std::vector<std::string>{"good"});
  EXPECT_EQ(r.findOrigin("good"), "built-in");
}

}  // namespace
}  // namespace kneesim::gap
