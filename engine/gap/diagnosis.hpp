#pragma once
// Sim-to-real gap diagnosis: where a contact law misses the measured knee force, which candidate
// effect explains the miss, and how far the gap shrinks on withheld data once it is added.
//
// Units of cross-validation are the cycles of the trials (gap/trial_inputs.hpp). Everything is
// judged on WITHHELD data: the baseline law (and every extension) is fitted with identify::fit()
// on all cycles but one (or all folds but one) and predicts the cycle left out.
//
//  1. Where: held-out gaps (measured - predicted) over time and over the normalised cycle, per
//     compartment target and named phase, next to the between-cycle repeatability band of the
//     measured force (a gap inside it is noise); correlations of the gap with candidate signals
//     and the best time shift; two reference predictors (the training-mean curve of the activity,
//     and the best monotone map from contact area to force: isotonic regression, which bounds
//     what any law driven by the area alone can reach).
//  2. Which: every effect of the catalogue is screened by a score (Lagrange multiplier) test at the
//     current model's optimum (one Gauss-Newton step from the fitted model, residuals' serial
//     correlation discounted); the top ones are fitted fully (Ipopt) and compared by withheld
//     error (reduction of the pooled held-out MSE with a ratio-estimator interval over cycles, and
//     per-cycle log ratios of held-out SSE), dAIC/dBIC and the stability of their parameters across
//     folds (jackknife interval). Forward selection continues while some candidate is significant
//     and large enough (the gate): its withheld MSE reduction's lower bound (Bonferroni over the
//     effects fitted at that step) is above zero, or its cross-fitted score test (the change its fold
//     fits predict for withheld cycles against the withheld residuals there; Bonferroni over the
//     effects screened) is significant; it adds the best prewhitened candidate among the significant
//     ones and those not significantly worse than the gate in raw error but significantly better in
//     prewhitened error, if BIC favours it. Pairs that improve alike with nearly the same
//     force change are reported as confusable, with what data would separate them. Then: does
//     structure remain (StructureTest: the mean gap against its uncertainty, a model-agnostic check by
//     boosted trees on every signal, the noise floor from matched frames of other cycles, cycle-to-
//     cycle heterogeneity; gap/remaining.hpp)? Four verdicts: explained, partly explained, not
//     explained ("none of the candidates"), undecided for lack of data; "baseline" only when the
//     withheld error is consistent with the noise floor.
//  3. Shrinkage: withheld RMSE of the baseline and of the selected model, leaving one cycle out
//     and leaving one activity out, overall and per phase, with bootstrap intervals over cycles.

#include <map>
#include <string>
#include <vector>

#include "gap/effect.hpp"
#include "gap/remaining.hpp"
#include "gap/signals.hpp"
#include "gap/trial_inputs.hpp"
#include "identify/fit.hpp"

namespace kneesim::gap {

/// What to diagnose and how.
struct DiagnosisOptions {
  /// Baseline identification: free parameters, values, assumed values, body mass, solver
  /// settings. Its phases are ignored (the activities' phases are used).
  identify::FitOptions fit;
  /// "total", "medial" and/or "lateral": the measured force each analysis explains. For a
  /// compartment the law reads that compartment's channels (S <- S_medial, dS_dt <- dS_medial_dt,
  /// S@3mm <- S_medial@3mm, knee_muscle_total <- knee_muscle_medial, any <p>_total <- <p>_medial;
  /// channels without a compartment version are dropped).
  std::vector<std::string> targets{"total"};
  int screen_top = 4;      ///< Effects fitted fully at each selection step.
  int max_effects = 3;     ///< Most effects selected.
  int cv_folds = 0;        ///< 0: leave one cycle out; k > 1: k folds of cycles.
  double level = 0.95;     ///< Confidence level of reported intervals.
  double alpha = 0.05;     ///< Family-wise level for accepting an effect at a step (Bonferroni).
  /// Smallest withheld mean-square-error reduction, relative to the current model's, worth an effect.
  double min_relative_improvement = 0.05;
  /// Canonical correlation of two effects' visible force changes (what the current model cannot
  /// absorb) at or above which a rival of a selected effect is fitted and, when the rival itself
  /// removes at least min_relative_improvement of the withheld error and the two withheld errors
  /// cannot be told apart, reported confusable with it.
  double confusable_correlation = 0.8;
  /// Order of the autoregressive filter that prewhitens held-out residuals (-1: chosen by BIC up
  /// to 10; 0: no prewhitening). The filter is fitted to the noise, not the gap: the baseline's
  /// in-sample residuals minus their activity's mean over the normalised cycle. The measured force's
  /// gap is smooth (between-cycle scatter), so raw squared errors weigh the slow differences between
  /// rival effects, which the noise hides, and barely the fast ones, which it does not. Residuals are
  /// compared up to 6 Hz (a measured force does not carry the frame-to-frame jitter the kinematics
  /// put into a model's areas, which whitening would otherwise weigh most). Significance stays on
  /// the raw errors; among the eligible candidates of a step (the significant ones, and those not
  /// significantly worse than the best significant one in raw error but significantly better in
  /// prewhitened error), the larger prewhitened withheld improvement is selected. Reported errors
  /// stay in newtons.
  int prewhiten_order = -1;
  /// Family level of the remaining-structure tests, shared by Bonferroni between five: the F-type
  /// test of the mean gap, the model-agnostic check, the noise floor's excess, the cycles'
  /// heterogeneity and the wander within a recording (gap/remaining.hpp).
  double structure_alpha = 0.05;
  /// The withheld error is consistent with the noise floor when the upper bound of its RMSE over the
  /// floor is below this (gap/remaining.hpp NoiseFloor); "baseline" (and "explained") need it.
  double noise_tolerance = 1.25;
  bool agnostic_check = true;     ///< Run the model-agnostic check (boosted trees on every signal).
  int structure_bins = 10;        ///< Bins per cycle of the remaining-structure test.
  int bootstrap = 1000;           ///< Bootstrap resamples of cycles for shrinkage intervals.
  int bins = 50;                  ///< Bins per cycle of the reported bands.
  bool where = true;              ///< Run the where-analysis (bands, phases, correlations, references).
  bool shrinkage = true;          ///< Run the leave-one-activity-out shrinkage.
  double max_lag = 0.1;           ///< s: range of the time-shift search.
  unsigned long long seed = 20150101;
  /// Channels each taken as the force itself, an alternative baseline with nothing fitted (on a
  /// compartment target its compartment's channel, e.g. knee_muscle_total: the musculoskeletal
  /// estimate): their withheld error beside the baseline law's (TargetDiagnosis::comparisons).
  std::vector<std::string> alternative_baselines;
  /// Effects of the catalogue whose withheld error added to the baseline law is reported whether or
  /// not the selection chooses them (e.g. muscle_load; TargetDiagnosis::comparisons).
  std::vector<std::string> compared_effects;
};

/// Correlation of the held-out gap with a candidate signal.
struct SignalCorrelation {
  std::string signal;
  double r = 0, lower = 0, upper = 0;  ///< Pearson r and its interval (Fisher z, effective n).
  double n_eff = 0;
  int n = 0;
};

/// The gap over the normalised cycle of one activity.
struct BandCurve {
  std::string activity;
  std::vector<double> phase;          ///< Bin centres (0..1).
  std::vector<double> mean_gap;       ///< Mean over cycles of the held-out gap, N.
  std::vector<double> sd_gap;         ///< SD over cycles of the gap, N.
  std::vector<double> mean_measured;  ///< Mean measured force, N.
  std::vector<double> sd_measured;    ///< Between-cycle repeatability band: SD of the measured force, N.
  std::vector<double> mean_predicted; ///< Mean held-out prediction, N.
  std::vector<int> n_cycles;          ///< Cycles with frames in the bin.
};

/// The gap in one named phase.
struct PhaseGap {
  std::string activity, phase;
  int n_frames = 0, n_cycles = 0;
  double rmse = 0, rmse_bw = 0;  ///< Held-out RMSE (N, body weights).
  double bias = 0;               ///< Mean gap (measured - predicted), N.
  double systematic = 0;         ///< RMS over the phase's bins of the mean gap curve, N.
  double band = 0;               ///< RMS over the phase's bins of the repeatability band, N (NaN: one cycle).
  std::string verdict;           ///< "gap", "within noise", or "no repeatability band (one cycle)".
};

/// Held-out errors of the reference predictors and the baseline on the same frames.
struct ReferencePredictors {
  double baseline_rmse = 0;
  double mean_curve_rmse = 0;      ///< Training-mean curve of the activity (NaN if no frames).
  int mean_curve_frames = 0;       ///< Frames it could predict (cycles whose activity has training cycles).
  double baseline_rmse_on_mean_curve_frames = 0;
  double isotonic_rmse = 0;        ///< Best monotone area -> force map fitted on the training cycles.
  double isotonic_in_sample_rmse = 0;  ///< The same fitted on all cycles: a floor for any law of S alone.
};

/// Score test of one effect at a selection step.
struct Screening {
  std::string effect;
  bool testable = true;
  std::string reason;            ///< Why not testable.
  double statistic = 0;          ///< LM, discounted for serial correlation.
  int dof = 0;
  double p_value = 1;
  double z = 0;                  ///< (LM - dof) / sqrt(2 dof): the ranking score.
  double predicted_reduction = 0;  ///< SSE fraction one Gauss-Newton step would remove.
  std::vector<std::pair<std::string, double>> one_step;  ///< One-step estimates of its parameters.
};

/// One parameter of a fitted effect.
struct EffectParameter {
  std::string name, unit;
  double value = 0;
  identify::Interval ci;          ///< Asymptotic interval from the full fit.
  identify::Interval ci_jackknife;  ///< Jackknife over folds (Student t).
  double fold_mean = 0, fold_sd = 0;
  double sign_consistency = 1;    ///< Fraction of folds with the full fit's sign.
  bool at_bound = false;
  bool identified = true;
};

/// A fully fitted candidate (the current model plus one effect).
struct CandidateFit {
  std::string effect;
  std::string law;                ///< Name of the extended law.
  int step = 1;
  bool converged = true;
  double rmse_in_sample = 0;
  double rmse_heldout = 0;
  /// Per-cycle log ratio ln(SSE_current / SSE_candidate) of held-out errors: > 0 is better. Its
  /// mean and Student t interval over cycles (scale-free, so cycles of large and small force count
  /// alike; partial cycles much shorter than a whole one are merged into their neighbour).
  MeanInterval log_ratio;
  double relative_improvement = 0;  ///< Reduction of the pooled held-out mean square error, relative.
  /// relative_improvement with its interval over cycles (ratio estimator, delta method:
  /// relativeReductionInterval), the statistic the step selects on.
  MeanInterval reduction;
  /// Lower bound of relative_improvement at the Bonferroni level of the step (one-sided Student t,
  /// cycles - 1 dof): > 0 is the significance the selection asks of an effect.
  double one_sided_lower = 0;
  /// relative_improvement of the prewhitened held-out residuals (DiagnosisOptions::prewhiten_order):
  /// what chooses among the eligible candidates of a step.
  double whitened_improvement = 0;
  /// whitened_improvement's lower bound, as one_sided_lower is relative_improvement's. Reported, not
  /// a criterion on its own: prewhitened errors weigh the fast part of a force change, which the smooth
  /// noise hides least, and would accept effects the baseline absorbs to well under the noise.
  double whitened_one_sided_lower = 0;
  /// Cross-fitted score test, the second way to significance. Per cycle, the force change the
  /// candidate's fold fit (which did not see the cycle) predicts there, times the current model's
  /// withheld residual there, summed over the cycle's frames: its mean over cycles is zero when the
  /// effect is absent (the change was fitted on other cycles' noise) and |d|^2 when the effect's
  /// change d is there, with a spread of sigma |d|, so its t grows like the effect's size over the
  /// noise, D, where the withheld MSE reduction (2 r.d - |d|^2 per cycle) grows like D / 2.
  /// Student t of that mean over cycles (cycles - 1 dof).
  double score_t = 0;
  /// The t score_t must exceed: Bonferroni over every testable effect the step screened, not only
  /// those it fitted, since the screening ranked them by an in-sample score of the same residuals.
  double score_critical = 0;
  /// Significant by either test: the withheld MSE reduction's lower bound or the cross-fitted score.
  bool isSignificant() const { return one_sided_lower > 0 || score_t > score_critical; }
  double d_aic = 0, d_bic = 0;    ///< Against the current model, effective frames.
  std::vector<EffectParameter> parameters;
  bool accepted = false;
  std::string decision;           ///< Why (not) accepted, in words.
  std::vector<std::string> notes;
};

/// Two effects the data cannot tell apart.
struct ConfusablePair {
  std::string a, b;
  /// Correlation of the force changes each makes (two significant full fits), or, for a rival of a
  /// selected effect, the canonical correlation of what the current model leaves visible of them.
  double signature_r = 0;
  MeanInterval difference;        ///< Per-cycle ln(SSE_b / SSE_a) of held-out errors (> 0: a is better).
  std::string separated_by;       ///< What data would separate them.
};

/// Remaining systematic structure in the gap of the final model. Five tests, each at a fifth of
/// DiagnosisOptions::structure_alpha (Bonferroni):
///  - the mean gap over the cycle: an F-type test (Shen & Faraway 2004) of the fit on all cycles'
///    residuals binned over the cycle, a mean curve per activity against none (the squared mean per bin
///    times the number of cycles, against the cycles' scatter about their activity's mean curve, with
///    Box's effective number of bins): the mean against the mean's own uncertainty, not against the
///    single cycles' spread;
///  - the model-agnostic check (AgnosticCheck): boosted trees on every signal, cross-validated;
///  - the noise floor (NoiseFloor): the withheld error significantly above the scatter of matched
///    frames of other cycles;
///  - cycle-to-cycle heterogeneity (CycleHeterogeneity): the offsets and gains of a cycle's thirds;
///  - an offset or slow wander within a recording (RecordingWander): quarter cycles against their neighbours.
/// Structure remains when the mean gap, the model-agnostic check, the cycles or the wander say so. The noise floor is
/// an estimate (matching imperfect in both directions): a withheld error above it, with no test finding
/// what carries the excess, makes the verdict "undecided" (nothing selected) or "partly explained", never
/// "none of the candidates" on its own. The repeatability band (the measured force's SD across cycles)
/// is reported next to the systematic gap and the mean's uncertainty, no longer as a test.
struct StructureTest {
  double statistic = 0;           ///< The mean-gap test's F.
  double p_value = 0;             ///< The mean-gap test's; NaN with too few cycles beyond one per activity.
  int cycles = 0;
  double systematic_gap = 0;      ///< RMS over bins of the mean withheld gap, N.
  double mean_uncertainty = 0;    ///< RMS over the same bins of the mean gap's standard error (SD / sqrt(cycles)), N.
  double repeatability_band = 0;  ///< RMS over the same bins of the measured force's between-cycle SD, N.
  bool exceeds_band = false;      ///< systematic_gap > repeatability_band (reported, not a test).
  bool significant = false;       ///< The mean gap, the model-agnostic check, the cycles or the wander.
  std::string note;
  std::vector<BandCurve> remaining;  ///< Mean held-out gap over the cycle after the selected effects.
  std::vector<SignalCorrelation> correlations;  ///< Of the remaining held-out gap.
  AgnosticCheck agnostic;
  NoiseFloor noise_floor;
  CycleHeterogeneity cycle_heterogeneity;
  RecordingWander recording_wander;
  /// The tests that found structure, in words ("mean gap over the cycle", "model-agnostic check", ...).
  std::vector<std::string> evidence;
};

/// Withheld error of the baseline and the selected model.
struct ShrinkageRow {
  std::string scheme;             ///< "leave one cycle out" or "leave one activity out".
  std::string scope;              ///< "overall", a phase ("gait: mid-stance") or the activity left out.
  std::string train;              ///< What the fits saw.
  int n_frames = 0, n_cycles = 0;
  double rmse_base = 0, rmse_final = 0;  ///< N.
  double rmse_base_bw = 0, rmse_final_bw = 0;
  double reduction = 0;           ///< 1 - rmse_final / rmse_base.
  identify::Interval ci;          ///< Bootstrap over cycles (NaN with fewer than 2).
};

/// The baseline law's withheld error beside an alternative's (DiagnosisOptions::alternative_baselines
/// and compared_effects), on withheld cycles (overall and per activity) and withheld activities.
struct Comparison {
  std::string name;     ///< The channel or the effect.
  /// "alternative baseline" (the channel taken as the force, nothing fitted) or "baseline + effect"
  /// (the effect added to the baseline law and fitted on the same training data as the law alone).
  std::string kind;
  std::string channel;  ///< Alternative baselines: the channel this target read.
  /// rmse_base: the baseline law's withheld error; rmse_final: the alternative's; reduction and its
  /// bootstrap interval over cycles as in the shrinkage rows.
  std::vector<ShrinkageRow> rows;
  std::string note;     ///< Why there are no rows (a missing channel, an effect that cannot be tested).
};

/// Per trial, the series behind the plots.
struct TrialSeries {
  std::string trial, activity;
  std::vector<double> time, phase, measured, baseline, final_model;  ///< Held-out predictions.
  std::vector<int> cycle;
};

/// The candidate that came closest to being added where the selection stopped: it removes at least
/// min_relative_improvement of the withheld error, but its one-sided lower bound is not above zero.
/// cycles_needed is what data would decide it: the cycles that would lift that bound to zero if the
/// reduction and its spread from cycle to cycle held, n ((mean - lower) / mean)^2 at the same t.
struct UndecidedCandidate {
  std::string effect;  ///< Empty: no candidate came that close.
  int step = 0;
  double reduction = 0, lower = 0;          ///< CandidateFit::relative_improvement, one_sided_lower.
  double whitened = 0, whitened_lower = 0;  ///< The same of the prewhitened errors.
  /// Cycles now, and about how many would make the first of the two tests significant if the
  /// reduction (or score) and its spread over cycles held.
  int cycles = 0, cycles_needed = 0;
};

/// The UndecidedCandidate among @p candidates fitted at @p step (the step where the selection
/// stopped): the one with the highest lower bound among those removing at least @p min_improvement
/// without significance; none if the step added an effect or no candidate qualifies.
UndecidedCandidate findUndecided(const std::vector<CandidateFit>& candidates, int step, double min_improvement);

/// The diagnosis of one target (total, medial or lateral force).
struct TargetDiagnosis {
  std::string target;
  identify::FitReport baseline;   ///< Baseline fitted on all cycles.
  double baseline_rmse_heldout = 0;
  std::vector<TrialSeries> series;
  std::vector<BandCurve> bands;
  std::vector<PhaseGap> phases;
  std::vector<SignalCorrelation> correlations;
  double best_lag = 0, best_lag_r = 0;  ///< Shift of the prediction that best matches the measurement (s).
  ReferencePredictors reference;
  std::vector<std::vector<Screening>> screening;  ///< Per selection step, ranked.
  std::vector<CandidateFit> candidates;           ///< Every full fit, in step order.
  std::vector<std::string> selected;              ///< Accepted effects in order.
  std::vector<ConfusablePair> confusable;
  UndecidedCandidate undecided;
  StructureTest structure;
  /// One of four verdicts, never more confident than the evidence: "explained" (the selected effects,
  /// nothing significant left, the withheld error consistent with the noise floor), "partly explained"
  /// (selected effects, but structure remains, or the withheld error above the floor: significantly, or by at
  /// least min_relative_improvement of its mean square without being shown consistent with it), "not explained" (nothing selected, structure remains:
  /// none of the candidates), "undecided" (nothing selected or left significant, but the withheld error
  /// cannot be told from the noise floor's tolerance: more cycles needed); and "baseline" (nothing
  /// selected, nothing left, the withheld error consistent with the noise floor).
  std::string verdict_class;
  /// "baseline", the selected effects joined by " + " (explained), "partly explained by <effects>",
  /// "none of the candidates" (not explained) or "undecided".
  std::string verdict;
  std::string verdict_text;       ///< One paragraph.
  std::string final_law;
  identify::FitReport final_fit;
  std::vector<ShrinkageRow> shrinkage;
  std::vector<Comparison> comparisons;  ///< One per alternative baseline, then per compared effect.
  std::vector<std::string> untestable;  ///< "effect: reason".
  /// Coefficients phi_1..phi_p of the prewhitening filter e_t - sum phi_k e_{t-k} estimated on the
  /// baseline's in-sample residuals less their mean over the cycle, up to 6 Hz (empty: none).
  std::vector<double> prewhitening;
};

/// Everything diagnose() found.
struct GapReport {
  std::string law, law_origin;
  std::vector<std::string> trials, activities, effects;
  bool interim_inputs = false;    ///< Some trial had interim contact areas: not a real-data result.
  bool synthetic = false;         ///< The trials are synthetic (gap/synth.hpp): not a real-data result.
  double body_mass = 0;
  int cycles = 0;
  std::string cv_scheme;
  std::vector<TargetDiagnosis> targets;
  std::vector<std::string> notes;
  /// Filled by the gap tool for gap_model.json (gap/prediction.hpp): the setup file, the plugins it
  /// loaded and the EMG envelope peaks (V) it normalised EMG channels by.
  std::string setup_file;
  std::vector<std::string> plugins;
  std::map<std::string, double> emg_peaks;
};

/// Empty if @p target names a force the diagnosis can target (total, medial or lateral), else
/// the reason in "expected X, got Y" form.
std::string findTargetProblem(const std::string& target);

/// Runs the diagnosis of @p base extended by the effects of @p catalogue on @p trials. Throws
/// InputError for no trials, fewer than two cycles, unknown targets, or anything identify::fit
/// refuses in the baseline.
GapReport diagnose(const identify::ContactLaw& base, const std::vector<Effect>& catalogue,
                   const std::vector<GapTrial>& trials, const DiagnosisOptions& options = {});

/// The identify::Trial a target analyses: measured force and channels of that compartment.
identify::Trial makeTargetTrial(const GapTrial& trial, const std::string& target);

}  // namespace kneesim::gap
