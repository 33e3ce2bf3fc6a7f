#pragma once
// Signal processing and small statistics used by the gap diagnosis: zero-phase filters, EMG
// envelopes, derivatives, resampling, isotonic regression, correlations with effective sample
// sizes, and the distributions their tests need (normal, Student t, chi-square).

#include <utility>
#include <vector>

#include "identify/statistics.hpp"

namespace kneesim::gap {

/// Zero-phase Butterworth low-pass of @p x sampled at @p rate Hz with cut-off @p cutoff Hz: a
/// second-order section run forwards and backwards (fourth order overall, like Matlab's filtfilt
/// of a second-order design), with the ends padded by odd reflection. NaN-free input expected.
std::vector<double> lowPass(const std::vector<double>& x, double rate, double cutoff);

/// Linear-envelope of a raw EMG signal: mean removed, full-wave rectified, low-passed (@p cutoff Hz,
/// 6 Hz by convention) and clipped at 0.
std::vector<double> emgEnvelope(const std::vector<double>& raw, double rate, double cutoff = 6.0);

/// Derivative of @p x over time @p t: central differences inside, one-sided at the ends.
std::vector<double> derivative(const std::vector<double>& t, const std::vector<double>& x);

/// Linear interpolation of (t, x) at @p at; times outside [t.front(), t.back()] by more than
/// @p tolerance get NaN, those within it the end value.
std::vector<double> interpolate(const std::vector<double>& t, const std::vector<double>& x,
                                const std::vector<double>& at, double tolerance = 0.0);

/// The best non-decreasing fit of y on x in weighted least squares (pool-adjacent-violators).
struct IsotonicFit {
  std::vector<double> x;  ///< Knots: both ends of each pooled block's x range, non-decreasing.
  std::vector<double> y;  ///< The block's value at its knots, non-decreasing.
  double sse = 0;         ///< Weighted sum of squared residuals of the fit on its own data.
  /// The fit at @p v: the block's value inside a block's range (so the fit reproduces itself at
  /// its data), linear between blocks, constant beyond the ends.
  double evaluate(double v) const;
};
/// Fits y = f(x) with f non-decreasing; @p w empty means unit weights. Pairs with non-finite
/// values are skipped.
IsotonicFit fitIsotonic(const std::vector<double>& x, const std::vector<double>& y, const std::vector<double>& w = {});

/// Pearson correlation of the finite pairs (NaN with fewer than 3 or a constant series).
double pearson(const std::vector<double>& x, const std::vector<double>& y);
/// Lag-1 autocorrelation of the finite values (0 when undefined).
double lag1Autocorrelation(const std::vector<double>& x);
/// Effective number of independent pairs for a correlation of two AR(1)-like series with lag-1
/// autocorrelations @p rx, @p ry (Bartlett): n (1 - rx ry) / (1 + rx ry), at least 3.
double effectiveSampleSize(int n, double rx, double ry);
/// Two-sided confidence interval of a correlation @p r from @p n_eff pairs (Fisher z).
std::pair<double, double> correlationInterval(double r, double n_eff, double level = 0.95);

/// Standard normal quantile and cumulative distribution (identify/statistics.hpp).
using identify::normalQuantile;
using identify::normalCdf;
/// Student t cumulative distribution with @p dof degrees of freedom (dof > 0, may be fractional).
double studentCdf(double t, double dof);
/// Student t quantile.
double studentQuantile(double p, double dof);
/// Upper tail P(X > x) of a chi-square variable with @p dof degrees of freedom.
double chiSquareSurvival(double x, double dof);
/// Upper tail P(X > f) of Fisher's F with @p dof1 and @p dof2 degrees of freedom (both > 0, may be
/// fractional); NaN otherwise.
double fisherSurvival(double f, double dof1, double dof2);

/// Mean and a two-sided Student-t confidence interval of the mean of @p v (NaN when fewer than 2).
struct MeanInterval {
  double mean = 0, lower = 0, upper = 0, sd = 0;
  int n = 0;
};
MeanInterval meanInterval(const std::vector<double>& v, double level = 0.95);
/// Least-squares autoregression x_t = sum_k phi_k x_{t-k} + e_t over @p runs of consecutive samples
/// (NaN samples break a run; only samples with p finite predecessors in their run count). @p order > 0
/// fixes p; -1 chooses p in 1..10 by BIC (n ln(SSE/n) + p ln n). Returns phi_1..phi_p; empty when
/// there are fewer than 10 p + 20 usable samples.
std::vector<double> fitAutoregression(const std::vector<std::vector<double>>& runs, int order = -1);
/// Sum of squared innovations e_t = x_t - sum_k phi_k x_{t-k} of one run @p x over the samples with
/// p finite predecessors (the first p samples, and any after a NaN, are left out).
double whitenedSumOfSquares(const std::vector<double>& phi, const std::vector<double>& x);
/// Relative reduction R = 1 - sum(b) / sum(a) of paired per-unit totals (e.g. held-out SSEs of a
/// reference model @p a and a candidate @p b over cycles), with a Student-t interval (n - 1 dof) on
/// the delta-method standard error of the ratio estimator: se^2 = n / (n - 1) sum_u (d_u - R a_u)^2
/// / (sum a)^2, d = a - b. sd is reported as se sqrt(n) so that se = sd / sqrt(n) as for a mean.
/// NaN bounds when fewer than 2 units; NaN throughout when sum(a) is not positive.
MeanInterval relativeReductionInterval(const std::vector<double>& a, const std::vector<double>& b, double level = 0.95);
/// Weighted mean of @p v (weights @p w > 0) with a Student-t interval on the effective number of
/// values (sum w)^2 / sum w^2; n is the number of values. NaN bounds when fewer than 2.
MeanInterval weightedMeanInterval(const std::vector<double>& v, const std::vector<double>& w, double level = 0.95);
/// The effective number of values (sum w)^2 / sum w^2 of weights @p w.
double effectiveCount(const std::vector<double>& w);

}  // namespace kneesim::gap
