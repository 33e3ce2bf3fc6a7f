#include "identify/fit.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "plugin/registry.hpp"
#include "synthetic.hpp"
#include "support/input_error.hpp"

namespace kneesim::identify {
namespace {

using ::testing::Contains;
using ::testing::HasSubstr;
using test::gaitArea;
using test::hertzForce;
using test::makeTrial;

constexpr double kTrueK = 2.0e7;  // Pa: about 2 kN at 1000 mm^2 with R = 37 mm, like the eKnee's stance peaks
constexpr double kR = 0.037;

struct Fit : ::testing::Test {
  plugin::Registry registry;
  void SetUp() override {
    registry.loadPlugin("hertz");
    registry.loadPlugin("elastic_foundation");
  }
  ContactLaw law(const std::string& name) { return ContactLaw(registry.getContactLaw(name), registry.findOrigin(name)); }
  static FitOptions quick() {
    FitOptions o;
    o.confidence.bootstrap_samples = 0;
    o.confidence.profile = false;
    return o;
  }
};

auto hertzK(double k, double r = kR) {
  return [k, r](double s) { return hertzForce(s, k, r); };
}

using kneesim::test::inputErrorOf;

TEST_F(Fit, HertzRecoversKAndFlagsEAndNu) {
  const ContactLaw hertz = law("hertz");
  const FitReport r = fit(hertz, {makeTrial("walk", hertzK(kTrueK))}, quick());
  EXPECT_TRUE(r.solver.success) << r.solver.status;
  EXPECT_GT(r.solver.iterations, 0);
  // (E, nu) flagged before solving; nu fixed at the law's default 0.45.
  ASSERT_EQ(r.fixed_by_identifiability.size(), 1u);
  EXPECT_EQ(r.fixed_by_identifiability[0].name, "nu");
  EXPECT_EQ(r.fixed_by_identifiability[0].value, 0.45);
  EXPECT_EQ(r.fixed_by_identifiability[0].value_source, "law default");
  EXPECT_FALSE(r.identifiability_start.isIdentifiable());
  EXPECT_LT(r.identifiability_start.null_directions[0].relative, 1e-10);
  EXPECT_TRUE(r.identifiability_final.isIdentifiable());
  EXPECT_EQ(r.getParameter("nu").status, ParameterStatus::FixedUnidentifiable);
  EXPECT_EQ(r.getParameter("E").status, ParameterStatus::Identified);
  EXPECT_EQ(r.getParameter("R").status, ParameterStatus::FixedBySetup);
  // K to 1e-6 relative; E only as E at the assumed nu.
  EXPECT_NEAR(r.getDerived("K").value, kTrueK, 1e-6 * kTrueK);
  EXPECT_TRUE(r.getDerived("K").identified);
  EXPECT_NEAR(r.getParameter("E").value, kTrueK * (1 - 0.45 * 0.45), 1e-6 * kTrueK);
  EXPECT_NEAR(r.getDerived("K_over_R").value, kTrueK / kR, 1e-6 * kTrueK / kR);
  EXPECT_LT(r.overall.rmse, 1e-6 * r.overall.peak_measured);
  EXPECT_NEAR(r.overall.r2, 1.0, 1e-12);
  ASSERT_GE(r.notes.size(), 3u);
  EXPECT_THAT(r.notes[0], HasSubstr("'nu' is not identifiable from force data"));
  EXPECT_THAT(r.notes[0], HasSubstr("held at 0.45 (law default)"));
  EXPECT_THAT(r.notes[1], HasSubstr("identified: K = "));
  EXPECT_THAT(r.notes[2], HasSubstr("E = "));
  EXPECT_THAT(r.notes[2], HasSubstr("only at the assumed nu = 0.45"));
}

TEST_F(Fit, NullDirectionIsTheHandDerivedCombinationOfEAndNu) {
  // Scaled columns at (E, nu): dF/dE * E = F and dF/dnu * nu = F * 2 nu^2 / (1 - nu^2). Their
  // null vector is (c, -1) / sqrt(1 + c^2) with c = 2 nu^2 / (1 - nu^2); at nu = 0.45,
  // c = 0.405 / 0.7975 = 0.50784, giving (0.4528, -0.8916), reported with the larger component positive.
  const ContactLaw hertz = law("hertz");
  const FitReport r = fit(hertz, {makeTrial("walk", hertzK(kTrueK))}, quick());
  const auto& id = r.identifiability_start;
  ASSERT_EQ(id.parameters, (std::vector<std::string>{"E", "nu"}));
  ASSERT_EQ(id.null_directions.size(), 1u);
  const double c = 2 * 0.45 * 0.45 / (1 - 0.45 * 0.45);
  EXPECT_NEAR(id.null_directions[0].components[0], -c / std::sqrt(1 + c * c), 1e-9);
  EXPECT_NEAR(id.null_directions[0].components[1], 1 / std::sqrt(1 + c * c), 1e-9);
  EXPECT_EQ(r.fixed_by_identifiability[0].direction, "-0.453 E + 0.892 nu");
  EXPECT_GT(id.condition_number, 1e10);
}

TEST_F(Fit, KDoesNotDependOnTheAssumedNu) {
  const ContactLaw hertz = law("hertz");
  const std::vector<Trial> trials{makeTrial("walk", hertzK(kTrueK))};
  FitOptions o = quick();
  o.assumed_values["nu"] = 0.3;
  const FitReport a = fit(hertz, trials, o);
  o.assumed_values["nu"] = 0.49;
  const FitReport b = fit(hertz, trials, o);
  EXPECT_EQ(a.fixed_by_identifiability[0].value_source, "assumed value");
  EXPECT_NEAR(a.getDerived("K").value, b.getDerived("K").value, 1e-7 * kTrueK);
  EXPECT_NEAR(a.getParameter("E").value, kTrueK * (1 - 0.09), 1e-6 * kTrueK);
  EXPECT_NEAR(b.getParameter("E").value, kTrueK * (1 - 0.49 * 0.49), 1e-6 * kTrueK);
}

TEST_F(Fit, FreeingRTooLeavesOnlyKOverRIdentified) {
  const ContactLaw hertz = law("hertz");
  FitOptions o = quick();
  o.free_parameters = {"E", "nu", "R"};
  const FitReport r = fit(hertz, {makeTrial("walk", hertzK(kTrueK))}, o);
  // Rank one: two null directions. R goes first (the law fixes it by default: a geometric
  // constant), then nu (holding E at its default instead would leave no fit).
  EXPECT_EQ(r.identifiability_start.null_directions.size(), 2u);
  ASSERT_EQ(r.fixed_by_identifiability.size(), 2u);
  EXPECT_EQ(r.fixed_by_identifiability[0].name, "R");
  EXPECT_EQ(r.fixed_by_identifiability[1].name, "nu");
  EXPECT_FALSE(r.getDerived("K").identified);  // K changes along E/R
  EXPECT_TRUE(r.getDerived("K_over_R").identified);
  EXPECT_NEAR(r.getDerived("K_over_R").value, kTrueK / kR, 1e-6 * kTrueK / kR);
}

TEST_F(Fit, RefusingToFixUnidentifiableParametersIsAnError) {
  const ContactLaw hertz = law("hertz");
  FitOptions o = quick();
  o.fix_unidentifiable = false;
  o.where = {"identify.xml", 9, "IdentifyTool/free_parameters"};
  const std::string msg = inputErrorOf([&] { fit(hertz, {makeTrial("walk", hertzK(kTrueK))}, o); });
  EXPECT_THAT(msg, HasSubstr("identify.xml:9: IdentifyTool/free_parameters: contact law 'hertz': parameters not "
                             "identifiable from these data: the forces do not change along -0.453 E + 0.892 nu"));
}

TEST_F(Fit, ElasticFoundationRecoversKefOverH) {
  const ContactLaw ef = law("elastic_foundation");
  const double kef_over_h = 3.0e9;  // Pa/m
  const auto force = [&](double s) { return kef_over_h * s * s / (4 * M_PI * kR); };
  const FitReport r = fit(ef, {makeTrial("walk", force)}, quick());
  EXPECT_TRUE(r.solver.success) << r.solver.status;
  ASSERT_EQ(r.fixed_by_identifiability.size(), 1u);
  EXPECT_EQ(r.fixed_by_identifiability[0].name, "nu");
  EXPECT_NEAR(r.getDerived("K_ef_over_h").value, kef_over_h, 1e-6 * kef_over_h);
  EXPECT_TRUE(r.getDerived("K_ef_over_h").identified);
  // E at the assumed nu = 0.45 and h = 8 mm: K_ef = 0.55 E / (1.45 * 0.1).
  EXPECT_NEAR(r.getParameter("E").value, kef_over_h * 0.008 * 0.145 / 0.55, 1e-6 * kef_over_h * 0.008);
}

TEST_F(Fit, BoundsAreRespected) {
  const ContactLaw hertz = law("hertz");
  FitOptions o = quick();
  o.free_parameters = {"E"};
  const double e_true = kTrueK * (1 - 0.45 * 0.45);
  o.bounds["E"] = {1e6, 0.8 * e_true};
  const FitReport r = fit(hertz, {makeTrial("walk", hertzK(kTrueK))}, o);
  EXPECT_LE(r.getParameter("E").value, 0.8 * e_true);
  EXPECT_NEAR(r.getParameter("E").value, 0.8 * e_true, 1e-6 * e_true);
  EXPECT_TRUE(r.getParameter("E").at_bound);
  EXPECT_THAT(r.notes, Contains(HasSubstr("'E' = 1.276e+07 lies on its bound [1e+06, 1.276e+07]")));
  EXPECT_THAT(r.notes, Contains(HasSubstr("start value of 'E' moved from the law default 1e+09 into the bounds")));
  // A start value outside the bounds is an input error.
  o.parameter_values["E"] = e_true;
  EXPECT_THAT(inputErrorOf([&] { fit(hertz, {makeTrial("walk", hertzK(kTrueK))}, o); }),
              HasSubstr("parameter 'E': expected a start value in [1e+06, "));
}

TEST_F(Fit, MissingChannelNamesTheLawAndTheChannel) {
  const ContactLaw ml = law("hertz_ml");
  Trial t = makeTrial("walk", hertzK(kTrueK));
  t.channels.erase("S_lateral");
  t.source = {"identify.xml", 21, "IdentifyTool/trials/Trial[walk]"};
  EXPECT_EQ(inputErrorOf([&] { fit(ml, {t}, quick()); }),
            "identify.xml:21: IdentifyTool/trials/Trial[walk]: contact law 'hertz_ml' needs input channel 'S_lateral', "
            "which trial 'walk' does not have (channels: time, S, S_medial)");
}

TEST_F(Fit, WindowsThatSelectNoFramesAreAnError) {
  const ContactLaw hertz = law("hertz");
  Trial t = makeTrial("walk", hertzK(kTrueK));
  t.windows = {{2.0, 3.0}};
  FitOptions o = quick();
  o.where = {"identify.xml", 5, "IdentifyTool"};
  EXPECT_EQ(inputErrorOf([&] { fit(hertz, {t}, o); }),
            "identify.xml:5: IdentifyTool: trial 'walk': time windows [2, 3]: expected at least one frame inside, got "
            "none (trial has t = 0 .. 1.19167 s)");
}

TEST_F(Fit, WindowsAndZeroWeightsLeaveFramesOut) {
  const ContactLaw hertz = law("hertz");
  Trial t = makeTrial("walk", hertzK(kTrueK));
  // Garbage outside the stance window and a zero-weight spike inside it must not bias K.
  for (size_t i = 0; i < t.time.size(); ++i)
    if (t.time[i] > 0.705) t.measured_force[i] = 1e5;
  t.windows = {{0.0, 0.705}};
  t.weight.assign(t.time.size(), 1.0);
  t.weight[40] = 0.0;
  t.measured_force[40] += 5000;
  const FitReport r = fit(hertz, {t}, quick());
  EXPECT_NEAR(r.getDerived("K").value, kTrueK, 1e-6 * kTrueK);
  EXPECT_EQ(r.overall.n_frames, 85);  // frames 0..84 have t <= 0.705 s
  EXPECT_NEAR(r.overall.max_abs_error, 5000, 1e-3);  // metrics are unweighted: the spike shows
  EXPECT_EQ(r.overall.time_of_max_error, t.time[40]);
}

TEST_F(Fit, LimitedMemoryHessianConvergesToo) {
  const ContactLaw hertz = law("hertz");
  FitOptions o = quick();
  o.gauss_newton = false;
  const FitReport r = fit(hertz, {makeTrial("walk", hertzK(kTrueK))}, o);
  EXPECT_TRUE(r.solver.success) << r.solver.status;
  EXPECT_NEAR(r.getDerived("K").value, kTrueK, 1e-6 * kTrueK);
}

TEST_F(Fit, WithNoiseTheIntervalsCoverTheTruth) {
  const ContactLaw hertz = law("hertz");
  const double sigma = 60.0;  // N, about 3 % of the 2 kN peak
  FitOptions o;
  o.body_mass = 66.7;
  o.confidence.bootstrap_samples = 200;
  const FitReport r = fit(hertz, {makeTrial("walk", hertzK(kTrueK), sigma, 7)}, o);
  const DerivedResult& k = r.getDerived("K");
  std::cout << "[ info     ] K = " << k.value << " Pa (true " << kTrueK << "); 95 % CI asymptotic [" << k.ci_asymptotic.lower
            << ", " << k.ci_asymptotic.upper << "], profile [" << k.ci_profile.lower << ", " << k.ci_profile.upper
            << "], block bootstrap [" << k.ci_bootstrap.lower << ", " << k.ci_bootstrap.upper << "] (block "
            << r.bootstrap.block_length << "); RMSE " << r.overall.rmse << " N = " << r.overall.rmse_bw << " BW\n";
  for (const Interval& ci : {k.ci_asymptotic, k.ci_profile, k.ci_bootstrap}) {
    ASSERT_TRUE(ci.isValid());
    EXPECT_LT(ci.lower, kTrueK);
    EXPECT_GT(ci.upper, kTrueK);
    // Not vacuous: the standard error of K is sigma / sqrt(sum (dF/dK)^2), about 0.5 % of K here.
    EXPECT_LT(ci.upper - ci.lower, 0.05 * kTrueK);
    EXPECT_GT(ci.upper - ci.lower, 0.002 * kTrueK);
  }
  // E's intervals map to K's through the fixed nu.
  const ParameterResult& e = r.getParameter("E");
  EXPECT_NEAR(e.ci_profile.lower, k.ci_profile.lower * (1 - 0.45 * 0.45), 1e-6 * kTrueK);
  EXPECT_NEAR(r.overall.rmse, sigma, 0.2 * sigma);
  EXPECT_NEAR(r.overall.rmse_bw, r.overall.rmse / (66.7 * 9.80665), 1e-12);
  EXPECT_EQ(r.bootstrap.samples, 200);
  EXPECT_EQ(r.bootstrap.failures, 0);
  EXPECT_GE(r.bootstrap.block_length, 5);  // ceil(144^(1/3)) = 6 for white residuals
}

TEST_F(Fit, IntervalsCoverAtRoughlyTheirLevel) {
  // 40 independent noise realisations: a 95 % interval should miss about twice.
  const ContactLaw hertz = law("hertz");
  FitOptions o;
  o.confidence.bootstrap_samples = 0;
  int covered_asym = 0, covered_prof = 0;
  const int runs = 40;
  for (int s = 0; s < runs; ++s) {
    const FitReport r = fit(hertz, {makeTrial("walk", hertzK(kTrueK), 60.0, 100 + s)}, o);
    const DerivedResult& k = r.getDerived("K");
    covered_asym += k.ci_asymptotic.lower < kTrueK && kTrueK < k.ci_asymptotic.upper;
    covered_prof += k.ci_profile.lower < kTrueK && kTrueK < k.ci_profile.upper;
  }
  std::cout << "[ info     ] 95 % intervals of K covering the truth in " << runs << " runs: asymptotic " << covered_asym
            << ", profile " << covered_prof << "\n";
  EXPECT_GE(covered_asym, 34);
  EXPECT_GE(covered_prof, 34);
  EXPECT_LE(covered_prof, 40);
}

TEST_F(Fit, BootstrapIsReproducibleWithItsSeed) {
  const ContactLaw hertz = law("hertz");
  FitOptions o;
  o.confidence.bootstrap_samples = 50;
  o.confidence.profile = false;
  const std::vector<Trial> trials{makeTrial("walk", hertzK(kTrueK), 60.0, 3)};
  const FitReport a = fit(hertz, trials, o), b = fit(hertz, trials, o);
  EXPECT_EQ(a.getDerived("K").ci_bootstrap.lower, b.getDerived("K").ci_bootstrap.lower);
  EXPECT_EQ(a.getDerived("K").ci_bootstrap.upper, b.getDerived("K").ci_bootstrap.upper);
  o.confidence.seed = 99;
  const FitReport c = fit(hertz, trials, o);
  EXPECT_NE(a.getDerived("K").ci_bootstrap.lower, c.getDerived("K").ci_bootstrap.lower);
}

// Blocks of frames are drawn circularly (Politis & Romano 1992) so every frame is resampled
// equally often. Drawing block starts only where a whole block fits under-samples the first and
// last frames of a window: with a force that is low at both ends of the window (a stance phase)
// and a nearly constant area, the bootstrap then over-estimates K and its interval can miss the
// estimate altogether (it did on JW's stance: [2.53, 3.14] MPa around K = 2.50 MPa). Here the area
// is constant, so K is proportional to the mean force and a frame-uniform resampling is centred
// on it.
TEST_F(Fit, BlockBootstrapResamplesEveryFrameEqually) {
  const ContactLaw hertz = law("hertz");
  Trial t = makeTrial("stance", hertzK(kTrueK));
  for (size_t i = 0; i < t.time.size(); ++i) {
    t.channels["S"][i] = 1000e-6;
    const double x = std::sin(M_PI * double(i) / double(t.time.size() - 1));
    t.measured_force[i] = 200 + 1500 * x * x;
  }
  FitOptions o;
  o.confidence.profile = false;
  o.confidence.bootstrap_samples = 400;
  o.confidence.block_length = 72;  // half the window, as the JW stance's serial correlation asks for
  const FitReport r = fit(hertz, {t}, o);
  const double k = r.getDerived("K").value;
  const Interval& ci = r.getDerived("K").ci_bootstrap;
  std::printf("[ bootstrap] K = %.4g, circular block bootstrap 95%% [%.4g, %.4g]\n", k, ci.lower, ci.upper);
  EXPECT_LT(ci.lower, k);
  EXPECT_GT(ci.upper, k);
  // Centred: neither side more than twice the other.
  EXPECT_LT(ci.upper - k, 2 * (k - ci.lower));
  EXPECT_LT(k - ci.lower, 2 * (ci.upper - k));
}

TEST_F(Fit, BootstrapOverTrials) {
  const ContactLaw hertz = law("hertz");
  FitOptions o;
  o.confidence.bootstrap_samples = 100;
  o.confidence.bootstrap_mode = "trials";
  std::vector<Trial> trials;
  for (int i = 0; i < 5; ++i) trials.push_back(makeTrial("walk" + std::to_string(i), hertzK(kTrueK), 60.0, 20 + i, 0.01 * i));
  const FitReport r = fit(hertz, trials, o);
  const Interval& ci = r.getDerived("K").ci_bootstrap;
  EXPECT_LT(ci.lower, kTrueK);
  EXPECT_GT(ci.upper, kTrueK);
  EXPECT_EQ(r.bootstrap.block_length, 0);
  EXPECT_EQ(r.per_trial.size(), 5u);
  o.confidence.bootstrap_mode = "frame";
  EXPECT_THAT(inputErrorOf([&] { fit(hertz, trials, o); }),
              HasSubstr("bootstrap mode: expected 'frames' or 'trials', got 'frame'"));
}

TEST_F(Fit, PredictHeldOutTrialAndPhases) {
  const ContactLaw hertz = law("hertz");
  FitOptions o = quick();
  o.body_mass = 66.7;
  o.phases = {{"first half", 0.0, 0.5, true}, {"push-off", 0.35, 0.6, false}};
  const FitReport r = fit(hertz, {makeTrial("train", hertzK(kTrueK))}, o);
  ASSERT_EQ(r.per_phase.size(), 2u);
  // Fractions of the 0 .. 143/120 s trial: t <= 0.5 * 1.19167 s -> frames 0..71; 0.35 .. 0.6 s -> 42..72.
  EXPECT_EQ(r.per_phase[0].second.n_frames, 72);
  EXPECT_EQ(r.per_phase[1].second.n_frames, 31);
  // A held-out trial with a 30 % stiffer knee: the prediction under-predicts by 30 % / 1.3 of the force.
  const Trial test = makeTrial("test", hertzK(1.3 * kTrueK), 0.0, 1, 0.02);
  const PredictionReport p = predict(hertz, r.getValues(), test, o);
  EXPECT_EQ(p.metrics.n_frames, 144);
  double bias = 0;
  for (size_t i = 0; i < p.measured.size(); ++i) bias += (p.predicted[i] - p.measured[i]);
  bias /= p.measured.size();
  EXPECT_NEAR(p.metrics.bias, bias, 1e-9);
  EXPECT_LT(p.metrics.bias, 0);
  for (size_t i = 0; i < p.measured.size(); ++i) EXPECT_NEAR(p.predicted[i], p.measured[i] / 1.3, 1e-6 * p.measured[i]);
  EXPECT_EQ(p.phases.size(), 2u);
}

}  // namespace
}  // namespace kneesim::identify

namespace kneesim::identify {
namespace {

// F = a S + b: linear in both parameters, so with white noise the profile-likelihood and the
// Gauss-Newton (Wald) intervals must agree closely and cover the truth.
int affineForce(const double* p, const kneesim_inputs* in, double* f, double* df, char*, int) {
  const double* s = nullptr;
  for (int c = 0; c < in->n_channels; ++c)
    if (std::string(in->names[c]) == "S") s = in->values[c];
  for (int i = 0; i < in->n_frames; ++i) {
    f[i] = p[0] * s[i] + p[1];
    if (df) {
      df[i] = s[i];
      df[in->n_frames + i] = 1.0;
    }
  }
  return 0;
}
const kneesim_param kAffineParams[] = {{"a", "Pa", 0, 1e9, 1e6, 1e6, 0, "slope"},
                                       {"b", "N", -1e4, 1e4, 0, 100, 0, "offset"}};
const char* const kAffineInputs[] = {"S"};
const kneesim_contact_law kAffine = {sizeof(kneesim_contact_law), "affine", "a S + b", 2, kAffineParams, 1,
                                     kAffineInputs, affineForce, 0, nullptr, nullptr, nullptr};

TEST(FitTwoParameters, ProfileAndWaldIntervalsAgreeForALinearLaw) {
  const ContactLaw law(kAffine);
  const double a = 2.5e6, b = -150;
  Trial t = test::makeTrial("walk", [&](double s) { return a * s + b; }, 40.0, 11);
  FitOptions o;
  o.confidence.bootstrap_samples = 100;
  const FitReport r = fit(law, {t}, o);
  ASSERT_TRUE(r.solver.success);
  EXPECT_TRUE(r.fixed_by_identifiability.empty());
  EXPECT_TRUE(r.identifiability_start.isIdentifiable());
  for (const char* name : {"a", "b"}) {
    const ParameterResult& p = r.getParameter(name);
    const double truth = std::string(name) == "a" ? a : b;
    const double wald = p.ci_asymptotic.upper - p.ci_asymptotic.lower;
    const double prof = p.ci_profile.upper - p.ci_profile.lower;
    std::cout << "[ info     ] " << name << " = " << p.value << " (true " << truth << "): Wald [" << p.ci_asymptotic.lower
              << ", " << p.ci_asymptotic.upper << "], profile [" << p.ci_profile.lower << ", " << p.ci_profile.upper
              << "], bootstrap [" << p.ci_bootstrap.lower << ", " << p.ci_bootstrap.upper << "]\n";
    EXPECT_NEAR(prof / wald, 1.0, 0.05) << name;
    EXPECT_NEAR(0.5 * (p.ci_profile.lower + p.ci_profile.upper), p.value, 0.02 * wald) << name;
    EXPECT_LT(p.ci_profile.lower, truth);
    EXPECT_GT(p.ci_profile.upper, truth);
    // The bootstrap resamples frames, so one interval misses the truth in about 5% of noise
    // realisations (this seed's narrowly does for a); what must hold for any seed: it contains the
    // estimate and, the noise being white, it is about as wide as Wald's (0.85 of it on average
    // over 30 seeds).
    EXPECT_LT(p.ci_bootstrap.lower, p.value) << name;
    EXPECT_GT(p.ci_bootstrap.upper, p.value) << name;
    const double boot = p.ci_bootstrap.upper - p.ci_bootstrap.lower;
    EXPECT_GT(boot / wald, 0.5) << name;
    EXPECT_LT(boot / wald, 1.5) << name;
  }
}


// F = a S + b y with y ~ 1e10 S: the columns of J differ by ~1e10, so J^T W J has pivots 1e20 apart.
// Scaled by the parameters' magnitudes it is well conditioned: the Wald interval must exist and
// match the profile interval (the law is linear).
int disparateForce(const double* p, const kneesim_inputs* in, double* f, double* df, char*, int) {
  const double* s = nullptr;
  for (int c = 0; c < in->n_channels; ++c)
    if (std::string(in->names[c]) == "S") s = in->values[c];
  for (int i = 0; i < in->n_frames; ++i) {
    const double y = 1e10 * std::sin(40.0 * i / in->n_frames) * s[i];
    f[i] = p[0] * s[i] + p[1] * y;
    if (df) {
      df[i] = s[i];
      df[in->n_frames + i] = y;
    }
  }
  return 0;
}
const kneesim_param kDisparateParams[] = {{"a", "Pa", 0, 1e9, 1e6, 1e6, 0, "slope"},
                                          {"b", "m", -1e-5, 1e-5, 0, 1e-8, 0, "tiny gain"}};
const kneesim_contact_law kDisparate = {sizeof(kneesim_contact_law), "disparate", "a S + b y", 2, kDisparateParams, 1,
                                        kAffineInputs, disparateForce, 0, nullptr, nullptr, nullptr};

TEST(FitTwoParameters, WaldIntervalsOfParametersOfVeryDifferentMagnitudes) {
  const ContactLaw law(kDisparate);
  const double a = 2.5e6, b = 3e-8;
  Trial t = test::makeTrial("walk", [&](double s) { return a * s; }, 40.0, 12);
  for (size_t i = 0; i < t.time.size(); ++i)
    t.measured_force[i] += b * 1e10 * std::sin(40.0 * i / t.time.size()) * t.channels["S"][i];
  FitOptions o;
  o.confidence.bootstrap_samples = 0;
  const FitReport r = fit(law, {t}, o);
  ASSERT_TRUE(r.solver.success);
  for (const char* name : {"a", "b"}) {
    const ParameterResult& p = r.getParameter(name);
    ASSERT_TRUE(p.ci_asymptotic.isValid()) << name;
    const double wald = p.ci_asymptotic.upper - p.ci_asymptotic.lower;
    const double prof = p.ci_profile.upper - p.ci_profile.lower;
    EXPECT_NEAR(prof / wald, 1.0, 0.05) << name;
  }
}

}  // namespace
}  // namespace kneesim::identify
