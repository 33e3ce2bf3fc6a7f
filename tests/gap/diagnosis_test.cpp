#include "gap/diagnosis.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "gap/catalogue_fixture.hpp"
#include "gap/jw_sources.hpp"
#include "gap/synth.hpp"
#include "io/knee_forces.hpp"
#include "io/storage.hpp"
#include "plugin/registry.hpp"
#include "support/input_error.hpp"

namespace kneesim::gap {
namespace {

using kneesim::test::inputErrorOf;
using ::testing::HasSubstr;

class Diagnosis : public test::CatalogueFixture {
 protected:
  DiagnosisOptions options() const {
    DiagnosisOptions o = hertzOptions();
    o.bootstrap = 300;
    return o;
  }
  std::vector<GapTrial> synthetic(const std::vector<InjectedEffect>& effects, unsigned long long seed) const {
    SynthOptions so;
    so.base_values = {{"E", 2.5e6 * (1 - 0.45 * 0.45)}};  // JW's K on ngait_og3's stance (paper workflow)
    so.effects = effects;
    so.seed = seed;
    return makeSyntheticTrials(hertz(), catalogue, test::jwGaitAndStair(), so);
  }
};

// A 140 ms lag of the load cells (on JW's real areas the predicted force changes slowly: a 30 ms lag
// changes it by 15 N, far below the noise, and 140 ms by 68 N): the diagnosis names it, finds the
// lag in the cross-correlation,
// recovers its size within its intervals, and the gap shrinks on withheld cycles and activities.
TEST_F(Diagnosis, TimeDelayIsNamedLocatedAndRemoved) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  // One seed; how often the delay is named first over 20 seeds is the blind suite's (18 of 20).
  const auto trials = synthetic({{"time_delay", {{"delay", 0.14}}}}, 1);
  DiagnosisOptions o = options();
  o.max_lag = 0.2;
  const GapReport rep = diagnose(hertz(), catalogue, trials, o);
  ASSERT_EQ(rep.targets.size(), 1u);
  const TargetDiagnosis& d = rep.targets[0];
  std::printf("[ info     ] %s\n", d.verdict_text.c_str());
  EXPECT_FALSE(rep.interim_inputs);
  // Named: explained, or partly explained when a structure test fires at its level. On this seed the
  // offset-or-wander test of 2026-11-28 gives p = 0.0085 against its 0.01 (46.9 N RMS beyond the noise of
  // the quarter cycles): "partly explained by time_delay"; over the blind suite's 20 seeds time_delay is
  // named in all.
  EXPECT_THAT(d.verdict, ::testing::AnyOf("time_delay", "partly explained by time_delay"));
  ASSERT_EQ(d.selected, std::vector<std::string>{"time_delay"});
  // The screening ranks it among the effects fitted fully (rate, nearly collinear with it on these
  // inputs, may rank higher; the full fits tell them apart).
  const auto& first = d.screening[0];
  const auto rank = std::find_if(first.begin(), first.end(), [](const Screening& s) { return s.effect == "time_delay"; });
  ASSERT_NE(rank, first.end());
  EXPECT_LT(rank - first.begin(), 3);
  // measured(t) = F(t - 140 ms): the prediction shifted by about the lag matches best. The
  // model-free cross-correlation peak is broad on these slow forces and the noise moves it (117 ms
  // on this seed, 3 frames early); the fitted delay's intervals below are the sharper test.
  EXPECT_NEAR(d.best_lag, 0.14, 0.03);
  // The gap is -delay * dF/dt to first order: it anti-correlates with the rate of the prediction.
  const auto it = std::find_if(d.correlations.begin(), d.correlations.end(),
                               [](const SignalCorrelation& c) { return c.signal == "rate of the predicted force"; });
  ASSERT_NE(it, d.correlations.end());
  std::printf("[ info     ] gap vs rate of the predicted force: r = %.2f [%.2f, %.2f]\n", it->r, it->lower, it->upper);
  EXPECT_LT(it->upper, -0.3);
  const auto cit = std::find_if(d.candidates.begin(), d.candidates.end(),
                                [](const CandidateFit& c) { return c.effect == "time_delay" && c.accepted; });
  ASSERT_NE(cit, d.candidates.end());
  const CandidateFit& cf = *cit;
  ASSERT_EQ(cf.parameters.size(), 1u);
  EXPECT_LT(cf.parameters[0].ci.lower, 0.14);
  EXPECT_GT(cf.parameters[0].ci.upper, 0.14);
  EXPECT_LT(cf.parameters[0].ci_jackknife.lower, 0.14);
  EXPECT_GT(cf.parameters[0].ci_jackknife.upper, 0.14);
  EXPECT_EQ(cf.parameters[0].sign_consistency, 1.0);
  EXPECT_LT(cf.d_bic, -10);
  // Shrinkage: leave one cycle out and leave one activity out (gait <-> stair), intervals above 0.
  ASSERT_FALSE(d.shrinkage.empty());
  EXPECT_EQ(d.shrinkage[0].scope, "overall");
  EXPECT_GT(d.shrinkage[0].ci.lower, 0.1);
  int loao = 0, loao_phases = 0;
  for (const auto& r : d.shrinkage)
    if (r.scheme == "leave one activity out") {
      if (r.scope == "gait" || r.scope == "stair") {
        ++loao;
        EXPECT_GT(r.reduction, 0.1) << r.scope;
      } else {
        ++loao_phases;  // "gait: mid-stance", ...
      }
    }
  EXPECT_EQ(loao, 2);
  EXPECT_EQ(loao_phases, 10);
  // The final model's withheld error is near the noise (100 N smooth + 5 N white).
  EXPECT_LT(d.shrinkage[0].rmse_final, 115);
  EXPECT_GT(d.shrinkage[0].rmse_base, 130);
}

// The comparisons beside the baseline: a channel taken as the force (the measured force plus 50 N:
// its withheld RMSE is 50 N in every row, nothing being fitted) and an effect added whether or not
// selected (its withheld error on withheld cycles is its first-step candidate's, and on the withheld
// activity it shrinks the gap as the injected delay does).
TEST_F(Diagnosis, ComparisonsGiveTheAlternativesWithheldErrors) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  auto trials = synthetic({{"time_delay", {{"delay", 0.14}}}}, 1);
  for (GapTrial& g : trials) {
    std::vector<double>& v = g.trial.channels["offset_force_total"];
    for (double f : g.trial.measured_force) v.push_back(f + 50);
  }
  DiagnosisOptions o = options();
  o.where = false;
  o.max_effects = 1;
  o.alternative_baselines = {"offset_force_total", "missing_total"};
  o.compared_effects = {"time_delay", "rate"};
  const GapReport rep = diagnose(hertz(), catalogue, trials, o);
  const TargetDiagnosis& d = rep.targets[0];
  ASSERT_EQ(d.comparisons.size(), 4u);
  const Comparison &alt = d.comparisons[0], &missing = d.comparisons[1], &delay = d.comparisons[2];
  EXPECT_EQ(alt.kind, "alternative baseline");
  // Leave one cycle out overall and per activity, then each activity left out.
  ASSERT_EQ(alt.rows.size(), 5u);
  for (const ShrinkageRow& r : alt.rows) EXPECT_NEAR(r.rmse_final, 50.0, 1e-9) << r.scheme << " " << r.scope;
  EXPECT_NEAR(alt.rows[0].rmse_base, d.baseline_rmse_heldout, 1e-9);
  EXPECT_EQ(alt.rows[3].scheme, "leave one activity out");
  EXPECT_TRUE(missing.rows.empty());
  EXPECT_THAT(missing.note, HasSubstr("no channel 'missing_total'"));
  EXPECT_EQ(delay.kind, "baseline + effect");
  ASSERT_EQ(delay.rows.size(), 5u);
  const auto cand = std::find_if(d.candidates.begin(), d.candidates.end(),
                                 [](const CandidateFit& c) { return c.effect == "time_delay" && c.step == 1; });
  ASSERT_NE(cand, d.candidates.end());
  EXPECT_NEAR(delay.rows[0].rmse_final, cand->rmse_heldout, 1e-6 * cand->rmse_heldout);
  for (size_t k = 3; k < 5; ++k) EXPECT_GT(delay.rows[k].reduction, 0.1) << delay.rows[k].scope;
  // The same comparisons on the medial target read the channel's compartment version.
  o.targets = {"medial"};
  o.compared_effects.clear();
  o.alternative_baselines = {"offset_force_total"};
  const GapReport med = diagnose(hertz(), catalogue, trials, o);
  ASSERT_EQ(med.targets[0].comparisons.size(), 1u);
  EXPECT_EQ(med.targets[0].comparisons[0].channel, "offset_force_medial");
  EXPECT_TRUE(med.targets[0].comparisons[0].rows.empty());
  o.compared_effects = {"no_such_effect"};
  EXPECT_THAT(inputErrorOf([&] { diagnose(hertz(), catalogue, trials, o); }),
              HasSubstr("compared_effects: expected an effect of the catalogue, got 'no_such_effect'"));
}

// Nothing injected: the baseline is preferred, the phases' gaps lie within the repeatability band,
// and the best monotone map of S (isotonic regression) fits at least as well as Hertz in sample,
// since Hertz is one monotone map of S.
TEST_F(Diagnosis, BaselineIsPreferredAndTheIsotonicFloorHolds) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  const auto trials = synthetic({}, 3);
  const GapReport rep = diagnose(hertz(), catalogue, trials, options());
  const TargetDiagnosis& d = rep.targets[0];
  EXPECT_EQ(d.verdict, "baseline");
  EXPECT_TRUE(d.selected.empty());
  EXPECT_LE(d.reference.isotonic_in_sample_rmse, d.baseline.overall.rmse);
  EXPECT_GT(d.reference.isotonic_in_sample_rmse, 50);  // the noise is not fitted away
  EXPECT_GT(d.reference.mean_curve_frames, 0);
  int within = 0, counted = 0;
  for (const auto& p : d.phases) {
    if (p.verdict == "gap" || p.verdict == "within noise") ++counted, within += p.verdict == "within noise";
  }
  EXPECT_EQ(counted, 10);  // five gait and five stair phases
  EXPECT_GE(within, 9);
  ASSERT_EQ(d.bands.size(), 2u);
  EXPECT_EQ(d.bands[0].phase.size(), 50u);
  // Every frame of every synthetic trial got a held-out prediction.
  for (const auto& s : d.series)
    for (double p : s.baseline) ASSERT_TRUE(std::isfinite(p)) << s.trial;
}

// A mean gap of each recording's own (a slow wander of the load cells' zero, a recording-level offset)
// with one recording per activity, as in share/gap/jw_gap.xml: the mean-gap test must be able to find
// it. Six synthetic recordings (three each of JW's gait and stair trials), each its own activity, offsets
// of +-150 N that the law cannot take. The sign-flip test it replaced could not: flipping every cycle of
// an activity leaves its statistic unchanged, so its p was at least 2^6 / 2^cycles (1/64 with 12). Without
// the offsets the same recordings give an F near one.
TEST_F(Diagnosis, MeanGapTestFindsAnOffsetPerRecordingWithOneRecordingPerActivity) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  DiagnosisOptions o = options();
  o.cv_folds = 0;
  o.max_effects = 0;
  o.agnostic_check = false;
  o.where = false;
  o.shrinkage = false;
  auto run = [&](double offset) {
    std::vector<GapTrial> trials = synthetic({}, 5);
    std::vector<GapTrial> kept;
    for (auto& g : trials) {  // three replicates each of JW's gait and stair recordings
      g.activity = g.activity + " " + std::to_string(kept.size());
      for (double& f : g.trial.measured_force) f += (kept.size() % 2 ? -offset : offset);
      kept.push_back(g);
    }
    return diagnose(hertz(), catalogue, kept, o).targets[0].structure;
  };
  const StructureTest with = run(150), without = run(0);
  std::printf("[ info     ] mean gap %.0f N +- %.0f N over %d cycles: F = %.2f, p = %.2g (%s); without the offsets "
              "F = %.2f, p = %.2g\n", with.systematic_gap, with.mean_uncertainty, with.cycles, with.statistic,
              with.p_value, with.note.c_str(), without.statistic, without.p_value);
  EXPECT_GE(with.cycles, 6);
  EXPECT_LT(with.p_value, 1e-3);
  EXPECT_THAT(with.evidence, ::testing::Contains(std::string("mean gap over the cycle")));
  EXPECT_GT(without.p_value, o.structure_alpha / 4);
  EXPECT_LT(without.statistic, 2.5);
}

// JW's real contact areas (the paper workflow's, the femur seated by the model: a function of the
// flexion alone) cannot follow a force that varies from 100 to 1600 N. With only four cycles no test of
// what remains has the power to say so -- the mean gap (385 N) is within its own uncertainty (367 N), too
// few cycles beyond one per activity for the F-type test, the model-agnostic check removes a third of the withheld error with a
// score t of 3.1 where 3 degrees of freedom need 5.4 -- so the verdict is "undecided", with the cycles
// that would tell, never "baseline". The gap follows the external load (the vertical ground reaction
// force of the instrumented leg and the knee's net axial force that carries it), and the external-load
// term, driven by it, takes most of the gap.
TEST_F(Diagnosis, RealAreasLeaveAGapThatFollowsTheExternalLoad) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  const std::vector<GapTrial> trials = test::jwGaitAndStair();
  DiagnosisOptions o = options();
  o.cv_folds = 0;
  o.max_effects = 0;  // the baseline alone: where is the gap, and is it noise?
  const GapReport base_only = diagnose(hertz(), catalogue, trials, o);
  const TargetDiagnosis& b = base_only.targets[0];
  std::printf("[ real     ] baseline withheld RMSE %.1f N; systematic gap %.1f N against a band of %.1f N; top "
              "correlation %s r = %.2f\n", b.baseline_rmse_heldout, b.structure.systematic_gap,
              b.structure.repeatability_band, b.correlations[0].signal.c_str(), b.correlations[0].r);
  EXPECT_EQ(b.verdict_class, "undecided");
  EXPECT_EQ(b.verdict, "undecided");
  // 4 cycles of 2 activities, some bins of the edge cycles empty: fewer than two cycles beyond one per
  // activity for the mean-gap test.
  EXPECT_TRUE(std::isnan(b.structure.p_value));
  EXPECT_TRUE(b.structure.exceeds_band);
  EXPECT_LT(b.structure.systematic_gap, 2 * b.structure.mean_uncertainty);
  EXPECT_GT(b.structure.agnostic.reduction, 0.2);
  EXPECT_FALSE(b.structure.agnostic.significant);
  EXPECT_GT(b.structure.agnostic.cycles_needed, 6);
  EXPECT_THAT(b.verdict_text, HasSubstr("cycles would make it significant"));
  EXPECT_GT(b.baseline_rmse_heldout, 400);
  // The external load in either form: the ground reaction or the knee's net axial force from
  // inverse dynamics (the channel that carries the ground reaction to the knee; 0.91 on 2026-11-24).
  EXPECT_THAT(b.correlations[0].signal, testing::AnyOf("GRF:vertical", "knee_axial_force"));
  for (const auto& c : b.correlations)
    if (c.signal == "GRF:vertical" || c.signal == "knee_axial_force") {
      std::printf("[ real     ] correlation of the gap with %s: r = %.3f\n", c.signal.c_str(), c.r);
      EXPECT_GT(c.r, 0.8) << c.signal;
    }
  o.max_effects = 2;
  const GapReport rep = diagnose(hertz(), catalogue, trials, o);
  const TargetDiagnosis& d = rep.targets[0];
  std::printf("[ real     ] %s: withheld RMSE %.1f -> %.1f N\n", d.verdict.c_str(), d.shrinkage[0].rmse_base,
              d.shrinkage[0].rmse_final);
  ASSERT_FALSE(d.selected.empty());
  EXPECT_EQ(d.selected[0], "grf_load");
  EXPECT_LT(d.shrinkage[0].rmse_final, 0.5 * d.shrinkage[0].rmse_base);
}

// A smaller exponent (dm < 0) asks adhesion for a negative pull-off, which its bound (psi >= 0)
// forbids: its fit stays at the baseline. However alike the directions of their force changes,
// adhesion reproduces none of it and is not a rival; radius_flexion, which can follow, is. (Before
// rivals had to remove 5 % of the withheld error themselves, this seed reported exponent ~
// adhesion_jkr.)
TEST_F(Diagnosis, ARivalHeldAtTheBaselineByItsBoundIsNotConfusable) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  const auto trials = synthetic({{"exponent", {{"dm", -0.6}}}}, 1);
  DiagnosisOptions o = options();
  o.where = false;
  o.max_effects = 1;
  const GapReport rep = diagnose(hertz(), catalogue, trials, o);
  const TargetDiagnosis& d = rep.targets[0];
  ASSERT_EQ(d.selected, std::vector<std::string>{"exponent"});
  std::vector<std::string> rivals;
  for (const auto& cp : d.confusable) {
    if (cp.a == "exponent") rivals.push_back(cp.b);
    if (cp.b == "exponent") rivals.push_back(cp.a);
  }
  EXPECT_THAT(rivals, testing::Contains("radius_flexion"));
  EXPECT_THAT(rivals, testing::Not(testing::Contains("adhesion_jkr")));
}

// A small threshold change (-0.4 mm) on seed 1: ap_translation removes a steady 8 % of the withheld
// error (significant) but whitens to -62 %; threshold removes as much (8 %) but varies more from
// cycle to cycle, so its withheld reduction is not significant; it whitens to +14 %.
//  - At the standard level its cross-fitted score is (t = 3.94 against 3.29, Bonferroni over the 14
//    screened effects): threshold is significant and the best prewhitened of the significant ones.
//  - At alpha = 0.01 neither of its tests is (3.94 against 4.22); it still enters, as the best
//    prewhitened candidate not significantly worse in raw error than the gate (flexion_gain, whose
//    score is significant) and significantly better than it in prewhitened error.
// (Before either rule, the step selected ap_translation.)
TEST_F(Diagnosis, ACandidateEntersByItsScoreOrAsTheBestWhitenedComparableToTheGate) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  const auto trials = synthetic({{"threshold", {{"dh", -0.0004}}}}, 1);
  // The figures below are those of the catalogue before issue 17's five effects: issue 5's 13 and
  // knee_load (the Bonferroni levels count the effects screened).
  const std::vector<Effect> all = catalogue;
  catalogue.clear();
  for (const auto& e : all)
    if (e.getName() != "hysteresis" && e.getName() != "load_flexion" && e.getName() != "grf_left" &&
        e.getName() != "grf_shear" && e.getName() != "trial_drift")
      catalogue.push_back(e);
  ASSERT_EQ(catalogue.size(), 14u);
  DiagnosisOptions o = options();
  o.where = false;
  o.shrinkage = false;
  o.screen_top = 4;
  o.max_effects = 1;
  auto find = [](const TargetDiagnosis& d, const std::string& effect) {
    for (const auto& c : d.candidates)
      if (c.effect == effect) return c;
    ADD_FAILURE() << effect << " was not fitted";
    return CandidateFit{};
  };
  {
    const GapReport rep = diagnose(hertz(), catalogue, trials, o);
    const TargetDiagnosis& d = rep.targets[0];
    ASSERT_EQ(d.selected, std::vector<std::string>{"threshold"});
    const CandidateFit thr = find(d, "threshold"), ap = find(d, "ap_translation");
    EXPECT_GT(ap.one_sided_lower, 0);
    EXPECT_LT(thr.one_sided_lower, 0);
    EXPECT_NEAR(thr.score_t, 3.94, 0.01);
    EXPECT_NEAR(thr.score_critical, 3.29, 0.01);  // Student t, 11 dof, one-sided 1 - 0.05 / 14
    EXPECT_TRUE(thr.isSignificant());
    EXPECT_GT(thr.whitened_improvement, ap.whitened_improvement);
    EXPECT_THAT(thr.decision, HasSubstr("among the significant ones"));
    EXPECT_THAT(thr.decision, HasSubstr("cross-fitted score t = 3.94 against 3.29"));
    // Its prewhitened reduction's lower bound (reported, not a criterion) lies below the reduction.
    EXPECT_LT(thr.whitened_one_sided_lower, thr.whitened_improvement);
    EXPECT_GT(std::abs(thr.whitened_one_sided_lower - thr.one_sided_lower), 0.01);  // from the prewhitened errors
  }
  {
    DiagnosisOptions strict = o;
    strict.alpha = 0.01;
    const GapReport rep = diagnose(hertz(), catalogue, trials, strict);
    const TargetDiagnosis& d = rep.targets[0];
    ASSERT_EQ(d.selected, std::vector<std::string>{"threshold"});
    const CandidateFit thr = find(d, "threshold"), fg = find(d, "flexion_gain");
    EXPECT_FALSE(thr.isSignificant());
    EXPECT_NEAR(thr.score_critical, 4.22, 0.01);
    EXPECT_TRUE(fg.isSignificant());
    EXPECT_THAT(thr.decision, HasSubstr("significantly lower in prewhitened error than flexion_gain"));
  }
  // Without prewhitening the prewhitened errors are the raw ones, and so are their bounds.
  o.prewhiten_order = 0;
  const GapReport raw = diagnose(hertz(), catalogue, trials, o);
  for (const auto& c : raw.targets[0].candidates) {
    EXPECT_NEAR(c.whitened_improvement, c.relative_improvement, 1e-12) << c.effect;
    EXPECT_NEAR(c.whitened_one_sided_lower, c.one_sided_lower, 1e-12) << c.effect;
  }
}

TEST_F(Diagnosis, CompartmentTargetsReadTheirOwnChannels) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  const auto trials = synthetic({}, 1);
  const identify::Trial m = makeTargetTrial(trials[0], "medial");
  EXPECT_EQ(m.channels.at("S"), trials[0].trial.channels.at("S_medial"));
  EXPECT_EQ(m.channels.at("dS_dt"), trials[0].trial.channels.at("dS_medial_dt"));
  EXPECT_EQ(m.measured_force, trials[0].medial);
  EXPECT_EQ(m.channels.count("S@3mm"), 0u);  // the workflow writes no S_medial@3mm
  EXPECT_EQ(m.channels.at("dS_dflexion"), trials[0].trial.channels.at("dS_medial_dflexion"));
  DiagnosisOptions o = options();
  o.targets = {"lateral"};
  o.where = false;
  o.max_effects = 1;
  const GapReport rep = diagnose(hertz(), catalogue, trials, o);
  ASSERT_EQ(rep.targets.size(), 1u);
  EXPECT_EQ(rep.targets[0].target, "lateral");
  EXPECT_THAT(rep.targets[0].untestable, testing::Contains(HasSubstr("threshold: trial")));
}

// The musculoskeletal force (the muscle_load effect's channel) on a compartment target is that
// compartment's share, not the whole knee's; a file without the split leaves the effect untestable there.
TEST(DiagnosisTargets, WholeKneeChannelsReadAsTheCompartments) {
  GapTrial g;
  g.trial.channels["knee_muscle_total"] = {1200, 1300};
  g.trial.channels["knee_muscle_medial"] = {900, 950};
  g.trial.channels["knee_muscle_lateral"] = {300, 350};
  g.trial.channels["knee_flexion_moment"] = {10, 20};
  EXPECT_EQ(makeTargetTrial(g, "total").channels.at("knee_muscle_total"), (std::vector<double>{1200, 1300}));
  EXPECT_EQ(makeTargetTrial(g, "medial").channels.at("knee_muscle_total"), (std::vector<double>{900, 950}));
  EXPECT_EQ(makeTargetTrial(g, "lateral").channels.at("knee_muscle_total"), (std::vector<double>{300, 350}));
  EXPECT_EQ(makeTargetTrial(g, "lateral").channels.at("knee_flexion_moment"), (std::vector<double>{10, 20}));
  g.trial.channels.erase("knee_muscle_medial");
  EXPECT_EQ(makeTargetTrial(g, "medial").channels.count("knee_muscle_total"), 0u);
}

TEST_F(Diagnosis, BadRequestsAreOneLineErrors) {
  KNEESIM_REQUIRE_DATA("kgc4-jw/markers/jw_stairupf1.c3d");
  auto trials = synthetic({}, 1);
  DiagnosisOptions o = options();
  o.targets = {"patellar"};
  EXPECT_THAT(inputErrorOf([&] { diagnose(hertz(), catalogue, trials, o); }),
              HasSubstr("target: expected total, medial or lateral, got 'patellar'"));
  EXPECT_THROW(diagnose(hertz(), catalogue, {}, options()), InputError);
  o = options();
  o.cv_folds = 1;  // was taken silently as leave one cycle out
  EXPECT_THAT(inputErrorOf([&] { diagnose(hertz(), catalogue, trials, o); }),
              HasSubstr("cv_folds: expected 0 (leave one cycle out) or at least 2 folds, got 1"));
  trials.resize(1);
  trials[0].cycles.resize(1);
  std::fill(trials[0].cycle_index.begin(), trials[0].cycle_index.end(), 0);
  EXPECT_THAT(inputErrorOf([&] { diagnose(hertz(), catalogue, trials, options()); }),
              HasSubstr("expected at least two cycles to hold one out, got 1"));
}

}  // namespace
}  // namespace kneesim::gap
