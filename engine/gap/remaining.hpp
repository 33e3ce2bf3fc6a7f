#pragma once
// What remains of the gap once a model is fitted, judged without a model of what it might be (issue 17):
//  - the model-agnostic check: boosted trees (gap/boosting.hpp) regress the model's WITHHELD residual on
//    every signal the trials carry (flexion, its rate and acceleration; contact areas and their rates;
//    both feet's GRF components; EMG envelopes; time in the cycle and in the recording, and which
//    recording; the model's own prediction; short lags of the kinematic and load signals; depth-2 trees give their pairwise
//    products), cross-validated over the same folds of cycles as the diagnosis; whether it removes
//    significantly more of the withheld error than zero is tested over cycles (withheld-error reduction
//    and cross-fitted score, Bonferroni), and the signals that carry what it finds are reported
//    (share of the trees' gain, partial dependence);
//  - the noise floor: the scatter of the withheld residual between cycles at matched phase, kinematics,
//    load and time in the recording (nearest frame of another cycle of the same activity), against the
//    withheld error itself, with intervals over cycles;
//  - cycle-to-cycle heterogeneity: whether the residual's offset and gain differ between cycles of an
//    activity (the thirds of a cycle agree beyond chance);
//  - a wander within a recording: whether the quarter cycles' mean residuals agree with their neighbours
//    in time (an offset of the recording, a wander from cycle to cycle or within long cycles) more than
//    their successive differences allow.

#include <string>
#include <vector>

#include "gap/boosting.hpp"
#include "identify/trial.hpp"

namespace kneesim::gap {

/// A signal's share of what the model-agnostic check found (its splits' gain over all trees, lags
/// included, over the total).
struct SignalImportance {
  std::string signal;
  double share = 0;
};

/// The model-agnostic fit as a function of one signal, the others as observed (partial dependence).
struct PartialDependence {
  std::string signal;
  std::vector<double> x;  ///< Signal values (the medians of its bins).
  std::vector<double> y;  ///< Mean fitted residual, N.
};

/// The model-agnostic check of a withheld residual.
struct AgnosticCheck {
  bool run = false;
  std::string note;                 ///< Why it did not run, or what it read.
  int units = 0, frames = 0, features = 0;
  std::vector<std::string> signals;  ///< Signals it read (lags and derived signals named by their source).
  /// Withheld mean-square-error reduction of the residual by the cross-validated trees (ratio estimator
  /// over cycles) and its one-sided lower bound at alpha / 2.
  double reduction = 0, reduction_lower = 0;
  /// Cross-fitted score: per cycle, the trees' withheld prediction times the residual, summed; its
  /// Student t over cycles and the t it must exceed (one-sided, alpha / 2).
  double score_t = 0, score_critical = 0;
  double p_value = 1;               ///< The smaller of the two tests' one-sided p, times 2 (Bonferroni).
  bool significant = false;
  /// Not significant but the score positive: the cycles that would make it significant if the score
  /// and its spread over cycles held, n (critical t / t)^2 (0: significant or no positive score).
  int cycles_needed = 0;
  std::vector<SignalImportance> importance;   ///< Fit on all cycles, largest share first.
  std::vector<PartialDependence> dependence;  ///< Of the leading signals.
};

/// The noise floor of a withheld residual and whether the withheld error is consistent with it.
struct NoiseFloor {
  bool run = false;
  std::string note;
  std::string matched_on;          ///< Signals the matching used.
  int units = 0, pairs = 0;
  double rmse = 0;                 ///< RMS of the residual over the matched frames, N.
  double floor = 0;                ///< Noise floor: sqrt of half the mean squared matched difference, N.
  /// Share of the withheld mean square error above the floor, 1 - floor^2 / rmse^2 (ratio estimator over
  /// cycles), its one-sided lower bound at alpha and its one-sided upper bound at the level.
  double excess = 0, excess_lower = 0, excess_upper = 0;
  double tolerance = 1.25;         ///< RMSE / floor consistent with noise: excess_upper below 1 - 1/tolerance^2.
  bool above = false;              ///< excess_lower > 0: the withheld error exceeds the floor.
  bool consistent = false;         ///< excess_upper below the tolerance's share.
  /// Neither above nor consistent: the cycles that would settle it either way (the fewer of those that
  /// would lift the lower bound above zero and those that would bring the upper bound under the
  /// tolerance) if the excess and its spread held (0: settled or not estimable).
  int cycles_needed = 0;
};

/// Whether the residual's offset and gain change from cycle to cycle. Each third of a cycle (by phase,
/// its outer fifths dropped, so that two thirds' noise is independent) gets its own offset (mean
/// residual) and relative gain (projection of the residual on the prediction, sum(r F) / sum(F^2)); a
/// cycle's own offset or gain shows in all its thirds, so over the cycles of an activity the thirds'
/// centred estimates correlate only when the cycles differ. The null gives each third another cycle's
/// (a permutation test: no model of the noise).
struct CycleHeterogeneity {
  bool run = false;
  std::string note;
  int units = 0;
  double statistic = 0;
  double dof = 0;                  ///< Pairings the permutation null counted.
  double p_value = 1;
  bool significant = false;
  /// Between-cycle SD of the relative gain and of the offset (N): from the covariance of a cycle's thirds
  /// (an offset also shows in the gain and a gain in the offset: sizes, not a decomposition).
  double gain_sd = 0, offset_sd = 0;
};

/// Whether the residual moves slowly over a recording's time (a slow drift of the load cells' zero, a
/// subject's loading changing over a trial, the recording's own offset, a gain per cycle): each quarter of
/// a cycle (by phase, its middle half, so that neighbouring quarters' noise is nearly independent; a
/// quarter cut by the recording's edge is kept if it holds a fifth of the recording's median frames) gets
/// its mean in-sample residual. Per recording, in time order, their mean square is compared with half the
/// mean squared difference of neighbouring quarters (von Neumann's successive differences: the quarters'
/// noise variance, free of whatever moves slowly from one quarter to the next); the statistic
/// sum n ln(mean square / successive variance) over recordings is referred to draws of independent
/// quarters, which it does not depend on the noise level of (recordings of different noise combine).
/// Unlike a test against the cycles' scatter, a wander does not inflate its own yardstick.
struct RecordingWander {
  bool run = false;
  std::string note;
  int recordings = 0, units = 0;  ///< Recordings with at least 3 quarters, and their cycles.
  int cells = 0;                  ///< Quarters used.
  double statistic = 0;
  int draws = 0;                  ///< Draws of the null.
  double p_value = 1;
  bool significant = false;
  /// RMS of the quarters' means beyond their successive-difference noise, N.
  double wander_sd = 0;
};

/// What the four read: per trial and frame, and the units and folds of cross-validation.
struct RemainingData {
  std::vector<const identify::Trial*> trials;            ///< Channels and time.
  std::vector<std::vector<double>> residual;             ///< Withheld residual, N (NaN: frame not used).
  std::vector<std::vector<double>> fitted_residual;      ///< In-sample residual of the fit on all cycles, N.
  std::vector<std::vector<double>> prediction;           ///< The model's withheld prediction, N.
  std::vector<std::vector<double>> phase;                ///< Normalised cycle position (NaN: none).
  std::vector<std::vector<int>> unit;                    ///< Unit (cycle) of each frame, -1 none.
  std::vector<std::string> unit_activity;                ///< Per unit.
  std::vector<std::vector<int>> folds;                   ///< Units of each cross-validation fold.
};

/// Settings of the four.
struct RemainingOptions {
  /// Level of each test: the model-agnostic check, the noise floor's excess, the cycles' heterogeneity,
  /// the wander within a recording (and the diagnosis's F-type test of the mean gap) share a family
  /// level of 0.05.
  double alpha = 0.05 / 5;
  double level = 0.95;              ///< Level of the noise floor's interval.
  double noise_tolerance = 1.25;    ///< NoiseFloor::tolerance.
  BoostingOptions boosting;
  double sample_rate = 40;          ///< Hz: frames are thinned to about this (the gap is smooth).
  std::vector<double> lags{0.05, 0.1};  ///< s: lags of the kinematic and load signals.
  int dependence_signals = 3;       ///< Partial-dependence curves reported.
};

/// The model-agnostic check (see the file comment).
AgnosticCheck runAgnosticCheck(const RemainingData& data, const RemainingOptions& options = {});
/// The noise floor of the withheld residual (see the file comment).
NoiseFloor estimateNoiseFloor(const RemainingData& data, const RemainingOptions& options = {});
/// Cycle-to-cycle heterogeneity of the in-sample residual (see the file comment).
CycleHeterogeneity testCycleHeterogeneity(const RemainingData& data, const RemainingOptions& options = {});
/// A slow wander of the in-sample residual within each recording (RecordingWander).
RecordingWander testRecordingWander(const RemainingData& data, const RemainingOptions& options = {});

}  // namespace kneesim::gap
