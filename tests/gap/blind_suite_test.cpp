// The blind synthetic suite of the gap diagnosis (issue 5, part 4): synthetic trials built from
// JW's REAL gait and stair-ascent inputs -- the paper workflow's contact areas (IK kinematics, the
// femur seated by the model; tests/gap/fixtures), flexion, area derivatives, force plates and EMG --
// with one hidden effect each (or none, or a force component outside the catalogue), noise at the
// real between-cycle level (100 N: ngait_og3's two cycles scatter by 105 N), diagnosed blind over
// 20 seeds per case.

#include <gtest/gtest.h>

#include <cstdio>

#include "gap/jw_sources.hpp"
#include "gap/synth.hpp"
#include "plugin/registry.hpp"

namespace kneesim::gap {
namespace {

// The settings of `kneesim synth share/gap/jw_gap.xml --blind-suite` (the README's matrix): the
// setup's baseline identification (E free, nu assumed 0.45, JW's 66.7 kg).
BlindSuiteOptions suiteOptions(int seeds) {
  identify::FitOptions fit;
  fit.free_parameters = {"E", "nu"};
  fit.assumed_values = {{"nu", 0.45}};
  fit.body_mass = 66.7;
  return getStandardBlindSuiteOptions(fit, seeds);
}

TEST(BlindSuite, NamesTheHiddenEffectPrefersTheBaselineAndRecoversTheSize) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  plugin::Registry reg;
  reg.loadPlugin("hertz");
  reg.loadPlugin("gap_effects");
  const identify::ContactLaw hertz = identify::ContactLaw::fromRegistry(reg, "hertz");
  std::vector<Effect> catalogue;
  for (const auto& n : reg.getEffectNames()) catalogue.push_back(Effect::fromRegistry(reg, n));
  const auto sources = test::jwGaitAndStair();
  BlindSuiteOptions base_options = suiteOptions(0);
  const auto base_values = fitSyntheticBaseline(hertz, sources, base_options.diagnosis.fit);
  // The baseline of the synthetic forces: Hertz fitted to the real forces of both trials (every
  // frame). The paper workflow finds K = 2.50 MPa on ngait_og3's stance alone (bootstrap 1.84-3.11
  // MPa); over whole trials, swing and stairs included, the fit may differ but not by much, since S
  // barely changes (2000-2740 mm^2) while the force spans 100-1600 N.
  const double K = base_values.at("E") / (1 - 0.45 * 0.45);
  std::printf("[ info     ] synthetic baseline: K = %.4g Pa (Hertz on the real forces of ngait_og3 and stairupf1)\n", K);
  EXPECT_GT(K, 1.5e6);
  EXPECT_LT(K, 3.5e6);
  const int seeds = std::getenv("KNEESIM_BLIND_SEEDS") ? std::atoi(std::getenv("KNEESIM_BLIND_SEEDS")) : 20;
  BlindSuiteOptions options = suiteOptions(seeds);
  options.synth.base_values = base_values;
  const BlindSuiteResult res = runBlindSuite(hertz, catalogue, sources, options);
  // One thread gives the same outcomes as two (the first two cases, two seeds: same case indices,
  // hence the same noise).
  if (seeds >= 2) {
    BlindSuiteOptions one = options;
    one.seeds = 2;
    one.cases = {getDefaultBlindCases()[0], getDefaultBlindCases()[1]};
    one.threads = 1;
    const BlindSuiteResult a = runBlindSuite(hertz, catalogue, sources, one);
    ASSERT_EQ(a.outcomes.size(), 4u);
    for (const auto& o : a.outcomes) {
      const BlindOutcome* m = res.getOutcomes(o.case_name)[o.seed - 1];
      EXPECT_EQ(o.answer, m->answer);
      EXPECT_EQ(o.estimate, m->estimate);
      EXPECT_EQ(o.rmse_final, m->rmse_final);
    }
  }
  // Each outcome says how it came about (kneesim synth --details): a line per selection step, the
  // selected effect starred, then the verdict.
  for (const auto& o : res.outcomes) {
    ASSERT_GE(o.trace.size(), 2u) << o.case_name << " seed " << o.seed;
    EXPECT_EQ(o.trace.front().rfind("step 1: screened ", 0), 0u) << o.trace.front();
    EXPECT_EQ(o.trace.back().rfind("verdict: " + o.answer, 0), 0u) << o.trace.back();
    EXPECT_NE(o.trace.back().find("] (remaining structure: mean-gap p "), std::string::npos) << o.trace.back();
    if (o.answer != "baseline" && o.answer != "none of the candidates" && o.answer != "undecided") {
      EXPECT_NE(o.trace.front().find(" *" + o.answer + "["), std::string::npos) << o.trace.front();
    }
  }
  std::printf("%s\n[ info     ] %zu blind diagnoses in %.1f s\n", res.formatMarkdown().c_str(), res.outcomes.size(),
              res.seconds);
  for (const auto& o : res.outcomes)
    if (!o.correct)
    {
      std::string conf;
      for (const auto& c : o.confusable_with_answer) conf += (conf.empty() ? "" : ", ") + c;
      std::printf("[ miss     ] %s seed %llu: named %s (injected change %.0f N RMS)%s%s\n", o.case_name.c_str(), o.seed,
                  o.answer.c_str(), o.injected_rms, conf.empty() ? "" : "; reported confusable with ", conf.c_str());
    }
  // What the suite demands, per case, on JW's real inputs at the real noise (README "Blind
  // synthetic suite" has the matrix): at least 18 of 20 seeds name the right answer first: the
  // effect; the baseline for nothing; the baseline, the effect itself or "undecided", never another
  // effect nor "none of the candidates", for an absorbed effect (isRightAnswer); "none" (or "partly
  // explained") for the outside bump. Since issue 17's verdicts (the noise floor must be consistent with
  // the withheld error for "baseline") absorbed effects come out "undecided" in 1-5 of 20 seeds
  // (ap_translation 5, the most), where they were "baseline"; nothing injected: 18 baseline, 1
  // undecided, 1 none (2026-11-24).
  // Absorbed today: ml_compartments, flexion_offset, flexion_gain, ap_translation, and -- since the
  // Hertz modulus may go below 1 MPa -- creep and adhesion_jkr: on these areas (2000-2740 mm^2, a
  // smooth function of the flexion) both change the force nearly in proportion to the Hertz term,
  // so a smaller modulus takes up all but ~20 N of them (the old 1 MPa floor made 136-214 N of them
  // look visible). Two visible effects act on the force only through the contact area and make
  // force changes the baseline leaves nearly collinear with those of other area effects: exponent
  // and threshold. The matrix's "best possible" column (OracleBound, force differences up to 6 Hz)
  // says how much of a miss is the data's and how much the method's. Exponent: 100 % against
  // radius_flexion once adhesion is held to its physical size (psi <= 7e4 N/m^1.5: w <= 0.1 J/m^2
  // on K <= 2 GPa). Its old bound, 1e7, let an adhesion of psi ~ 2.4e5 (w ~ 1.1 J/m^2, 11 times the
  // dry maximum) mimic the exponent: best possible 78 %, 13 / 20 named first.
  // Threshold: 100 % against flexion_offset, so its misses were the method's. It leaves ~40 N
  // after the baseline's refit under 100 N of noise, where a withheld-error reduction's z is only
  // about half the effect's size over the noise. Choosing among the significant candidates by
  // prewhitened withheld errors lifted it from 11 to 16 of 20, the whitened-comparable rule to 17,
  // and the cross-fitted score test (CandidateFit::score_t, z about the whole size) to 19 (on three
  // other sets of 20 seeds 16, 16, 16 -> 19, 19, 16), with flexion_gain, whose 23 N it also sees
  // better, 19 (and 18, 15, 19 -> 16, 17, 17, never below 15 before or after).
  const int demand = 18;
  // Every visible single-effect case has its best-possible rate against its closest rival.
  for (const auto& bc : getDefaultBlindCases()) {
    if (bc.effects.size() != 1 || res.expected.at(bc.name) == "baseline") continue;
    SCOPED_TRACE(bc.name);
    ASSERT_TRUE(res.oracle.count(bc.name));
    const OracleBound& ob = res.oracle.at(bc.name);
    EXPECT_NE(ob.rival, bc.name);
    EXPECT_GT(ob.distance, 0);
  }
  // The data's limits (today: exponent 100 % against radius_flexion, D = 5.7; threshold 100 %
  // against flexion_offset, D = 6.5). Adhesion, a negative control, mimics nothing at its
  // physical size.
  if (res.oracle.count("exponent")) {
    EXPECT_NE(res.oracle.at("exponent").rival, "adhesion_jkr");
    EXPECT_GT(res.oracle.at("exponent").accuracy, 0.99);
  }
  if (res.oracle.count("threshold")) {
    EXPECT_GT(res.oracle.at("threshold").accuracy, 0.99);
  }
  for (const auto& row : res.rows) {
    const auto outs = res.getOutcomes(row);
    int ok = 0, est = 0, cov = 0, cov_jack = 0;
    for (const auto* o : outs) {
      ok += o->correct;
      if (o->has_estimate) ++est, cov += o->covered, cov_jack += o->covered_jackknife;
    }
    SCOPED_TRACE(row);
    EXPECT_GE(ok, demand * outs.size() / 20.0);
    // The injected size lies in its 95 % intervals about as often as it should, where the effect is
    // visible (an absorbed effect's size is not identifiable: its expected answer is the baseline).
    // Observed: asymptotic 18-20 of 20 (all cases); jackknife over the 5 folds 13/19 (threshold) to
    // 20/20 -- a Student t on 5 fold estimates under-covers a bounded, nonlinear parameter.
    if (est >= 5 && res.expected.at(row) != "baseline") {
      EXPECT_GE(cov, 0.85 * est);
      EXPECT_GE(cov_jack, 0.65 * est);
    }
  }
}

}  // namespace
}  // namespace kneesim::gap
