#pragma once
// Synthetic trials with known hidden effects, for testing the gap diagnosis blind.
//
// Each synthetic recording starts from a real recording's inputs (contact areas from the paper
// workflow's files, flexion, GRF, EMG), varied smoothly between replicates the way repeated trials
// vary -- the flexion by a smooth offset, the areas with it through their flexion derivative when
// the trial has dS_dflexion (the model's areas are a function of the flexion), GRF and EMG by a
// smooth factor -- and gets a "measured" force made by
// the baseline law at chosen parameters, extended by chosen effects at chosen sizes (or by a force
// component outside the catalogue), plus noise at the real between-trial level: smooth noise of
// the measured force's between-cycle scatter and a small white part.

#include <map>
#include <string>
#include <vector>

#include <functional>
#include <memory>
#include <mutex>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "gap/diagnosis.hpp"
#include "gap/effect.hpp"
#include "gap/trial_inputs.hpp"

namespace kneesim::gap {

/// An effect injected into synthetic trials: its name and the values of its parameters (others at
/// their defaults).
struct InjectedEffect {
  std::string effect;
  std::map<std::string, double> values;
};

/// How synthetic trials are made.
struct SynthOptions {
  /// Baseline parameter values (others at the law's defaults), e.g. {"E", 2e7}.
  std::map<std::string, double> base_values;
  std::vector<InjectedEffect> effects;  ///< Injected catalogue effects (may be empty).
  /// A force component outside the catalogue: "" (none) or "phase_bump", a Gaussian bump of
  /// outside_size N centred at 30 % of every cycle (width 6 % of the cycle), locked to the cycle
  /// and unrelated to any input channel.
  std::string outside;
  double outside_size = 0;
  double noise_sd = 100;          ///< N: smooth noise (between-cycle scatter of ngait_og3: 105 N).
  double noise_time = 0.05;       ///< s: its correlation time.
  double white_sd = 5;            ///< N: white measurement noise.
  int replicates = 3;             ///< Synthetic recordings per source recording.
  /// Relative SD of a smooth factor on the areas between replicates, independent of the flexion
  /// (0: the areas vary only with the flexion; use it for areas without dS_dflexion).
  double area_variation = 0.0;
  /// rad: SD of a smooth offset on the flexion between replicates. With a dS_dflexion channel the
  /// areas follow it to first order: S += dS_dflexion * offset (S_medial, S_lateral likewise with
  /// their own derivatives; the S@<x>mm channels by the relative change of S).
  double flexion_variation = 0.03;
  double load_variation = 0.05;   ///< Relative SD of the smooth factor on GRF and EMG between replicates.
  unsigned long long seed = 1;
};

/// The metric of the synthetic noise (makeSyntheticTrials): squared Mahalanobis distances of force
/// differences under the noise's exact covariance -- the smooth part (white noise through the
/// generator's low-pass filter, scaled to noise_sd) plus the white part -- each recording's noise
/// independent. Optionally the difference is low-passed at @p bandwidth Hz first (0: not).
/// Covariance factors are cached per recording length and rate; thread-safe.
class NoiseMetric {
 public:
  NoiseMetric(const SynthOptions& options, double bandwidth = 0);
  /// d^T Sigma^-1 d for one recording's force difference @p d (N) sampled at @p rate (Hz).
  double calcSquaredDistance(const std::vector<double>& d, double rate) const;

 private:
  const Eigen::LLT<Eigen::MatrixXd>& findFactor(int n, double rate) const;
  SynthOptions options_;
  double bandwidth_ = 0;
  mutable std::mutex mutex_;
  mutable std::map<std::pair<int, long>, std::unique_ptr<Eigen::LLT<Eigen::MatrixXd>>> cache_;
};

/// Synthetic recordings from @p sources (each replicated options.replicates times, named
/// "<source>_r<k>"): channels varied smoothly, cycles kept, measured total force from @p base
/// extended by the injected effects (found in @p catalogue by name), medial/lateral split by the
/// compartments' Hertz shares. Throws InputError for an unknown effect or parameter, or a source
/// lacking a channel an injected effect needs.
std::vector<GapTrial> makeSyntheticTrials(const identify::ContactLaw& base, const std::vector<Effect>& catalogue,
                                          const std::vector<GapTrial>& sources, const SynthOptions& options);

/// The baseline parameters of synthetic trials: @p base fitted (identify::fit with @p options, no
/// intervals) to the measured forces of @p sources, so synthetic forces have the real magnitude.
std::map<std::string, double> fitSyntheticBaseline(const identify::ContactLaw& base,
                                                   const std::vector<GapTrial>& sources,
                                                   const identify::FitOptions& options);

/// The between-cycle scatter of the measured force: for each activity, the force over the
/// normalised cycle in @p bins bins per cycle, the SD across cycles in each bin, pooled (RMS) over
/// bins and activities. NaN when no activity has two cycles covering a bin.
double estimateBetweenCycleScatter(const std::vector<GapTrial>& trials, int bins = 20);

/// One case of the blind test: what is injected and what the diagnosis should answer.
struct BlindCase {
  std::string name;          ///< Row label, e.g. "time_delay" or "nothing".
  std::vector<InjectedEffect> effects;  ///< Injected catalogue effects (empty: none).
  std::string outside;       ///< A force component outside the catalogue (SynthOptions::outside).
  double outside_size = 0;
  /// The right answer: an effect name, "baseline" or "none of the candidates". runBlindSuite turns
  /// an effect's expectation into "baseline" when the baseline absorbs it (BlindSuiteOptions::visible_floor);
  /// naming the absorbed effect itself is then right too (isRightAnswer).
  std::string expected;
};

/// The default cases: nothing injected, each catalogued effect alone at a size whose force change
/// is comparable to the noise, and a force bump locked to the cycle (outside the catalogue).
std::vector<BlindCase> getDefaultBlindCases();

/// Whether @p answer (an effect, "baseline", "none of the candidates" or "undecided") is right for a
/// case whose right answer is @p expected and into which @p injected was put. Where the baseline
/// absorbs the injected effects (@p expected is "baseline" although something is injected), naming one
/// of them is right too: it is there, so naming it is no false claim; so is "undecided" (what the
/// baseline leaves of it is there too, under the noise: "cannot tell" claims nothing false); naming
/// any other effect, or "none of the candidates", is wrong. With nothing injected only "baseline" is.
bool isRightAnswer(const std::string& answer, const std::string& expected, const std::vector<InjectedEffect>& injected);

/// One blind diagnosis.
struct BlindOutcome {
  std::string case_name, expected;
  unsigned long long seed = 0;
  /// The first selected effect (explained or partly explained), "baseline", "none of the candidates"
  /// (not explained) or "undecided".
  std::string answer;
  std::string verdict_class;  ///< TargetDiagnosis::verdict_class.
  /// isRightAnswer: the expected answer or, for an absorbed effect, that effect; for an effect outside
  /// the catalogue (expected "none of the candidates") "partly explained" is right too.
  bool correct = false;
  /// Effects the diagnosis reported as confusable with its answer (pairs it could not tell apart).
  std::vector<std::string> confusable_with_answer;
  /// The answer is right, or the diagnosis reported it confusable with the injected effect.
  bool correct_or_confusable = false;
  /// TargetDiagnosis::undecided's effect (empty: none); with the answer "baseline" and this the
  /// injected effect, the diagnosis said what it suspected and what data would decide it.
  std::string undecided;
  double injected_rms = 0;   ///< RMS force change the injected component makes on the noise-free trials, N.
  double rmse_baseline = 0;  ///< Held-out RMSE of the baseline, N.
  double rmse_final = 0;     ///< Held-out RMSE of the selected model, N.
  /// For a single injected effect: its first parameter's true value, estimate (the fit of the
  /// baseline plus that effect at the first selection step) and intervals.
  double truth = 0, estimate = 0;
  identify::Interval ci, ci_jackknife;
  bool covered = false, covered_jackknife = false;
  bool has_estimate = false;
  /// How the answer came about, one line per selection step: the screening order and, for each
  /// effect fitted fully, its withheld MSE reduction (%), that reduction's one-sided lower bound
  /// (significance), its prewhitened reduction (the choice among eligible ones) with that reduction's
  /// lower bound, and dBIC ("*" marks the one selected); then the final verdict with the remaining-
  /// structure test's figures (sign-flip p, systematic gap, repeatability band).
  std::vector<std::string> trace;
};

/// The best any method could do on a single-effect case against its closest rival: the rival
/// effect (or "baseline") fitted to the case's noise-free synthetic forces (seed 1) mimics them
/// as well as it can; D is the Mahalanobis distance between the two noise-free force histories
/// under the synthetic noise's exact covariance (smooth noise and white part, each recording
/// independent), over all frames. Between the two worlds -- the injected effect at its size, the
/// rival at its best-mimicking size -- no method, even one told both hypotheses and the noise
/// model, names the truth first more often on average than Phi(D/2) (the Bayes rate of two
/// Gaussian hypotheses with equal priors); so a method naming the injected effect in a fraction p
/// of its draws names it in at least 2 p - 2 Phi(D/2) + 1 of the rival world's draws too.
struct OracleBound {
  std::string rival;           ///< Closest rival: an effect name or "baseline".
  double rival_rms = 0;        ///< N: RMS of the noise-free force the rival cannot mimic.
  double distance = 0;         ///< D, dimensionless.
  double accuracy = 1;         ///< Phi(D/2).
  /// Every rival tried: name -> (RMS N, D); rivals whose fit failed are absent.
  std::map<std::string, std::pair<double, double>> all;
};

/// Outcomes of the blind suite and their confusion matrix.
struct BlindSuiteResult {
  std::vector<BlindOutcome> outcomes;
  std::vector<std::string> rows;     ///< Case names, in order.
  std::vector<std::string> columns;  ///< Answers: every effect, "baseline", "none of the candidates".
  std::vector<std::vector<int>> counts;  ///< [row][column].
  /// Per case: RMS (N) of what the injected component leaves after the baseline is refitted to the
  /// noise-free synthetic trials of seed 1 (the part of it the data can show), and the expected answer.
  std::map<std::string, double> visible_rms;
  std::map<std::string, std::string> expected;
  /// Per single-effect case (BlindSuiteOptions::oracle): the best any method could do (OracleBound).
  std::map<std::string, OracleBound> oracle;
  double seconds = 0;
  /// Outcomes of one case.
  std::vector<const BlindOutcome*> getOutcomes(const std::string& case_name) const;
  /// The confusion matrix as a Markdown table, with per-case accuracy and interval coverage.
  std::string formatMarkdown() const;
};

/// How the blind suite runs.
struct BlindSuiteOptions {
  std::vector<BlindCase> cases;      ///< Empty: getDefaultBlindCases().
  int seeds = 20;                    ///< Seeds per case (1..seeds).
  SynthOptions synth;                ///< Baseline values, noise, replicates (effects/outside/seed are set per case).
  DiagnosisOptions diagnosis;        ///< Diagnosis settings (run blind: it is not told the case).
  /// Worker threads (Ipopt solves still run one at a time; the rest overlaps). Results do not
  /// depend on it.
  int threads = 2;
  /// N: a case whose injected effect leaves less than this RMS once the baseline is refitted to
  /// the noise-free trials cannot be seen through the noise on these inputs; its right answer is
  /// "baseline" (the diagnosis must not claim an effect it cannot see). Default: 0.3 x 100 N.
  double visible_floor = 30;
  /// Compute OracleBound for each single-effect case (one fit per rival and case).
  bool oracle = true;
  /// Hz: the difference between the two noise-free force histories is low-passed here before D is
  /// computed (0: not). The synthetic force follows the contact areas exactly, even their
  /// frame-to-frame jitter from the kinematics, where the noise is only its 5 N white part; a real
  /// force does not carry the jitter of a model's inputs, so differences faster than the
  /// kinematics' usual bandwidth (6 Hz) are no evidence a real method could use.
  double oracle_bandwidth = 6;
  std::function<void(int done, int total)> progress;
};

/// The blind suite's standard settings around a baseline identification @p fit: @p seeds seeds,
/// three replicates per source, noise 100 N, 5-fold cross-validation, top 4 screened (as GapTool), at most 2
/// effects, no where-analysis and no leave-one-activity-out (not needed for the verdict), baseline
/// intervals off. `kneesim synth --blind-suite` and tests/gap/blind_suite_test.cpp both use it.
BlindSuiteOptions getStandardBlindSuiteOptions(const identify::FitOptions& fit, int seeds = 20);

/// Makes synthetic trials for every case and seed from @p sources and diagnoses them blind.
BlindSuiteResult runBlindSuite(const identify::ContactLaw& base, const std::vector<Effect>& catalogue,
                               const std::vector<GapTrial>& sources, const BlindSuiteOptions& options);

}  // namespace kneesim::gap
