#pragma once
// The standard normal distribution and a binomial interval, shared by the fit's confidence
// intervals (identify) and the gap diagnosis's tests and blind suite (gap).

#include <utility>

namespace kneesim::identify {

/// Standard normal quantile: the x with P(Z <= x) = @p p (Acklam's rational approximation,
/// refined by one Halley step; about 1e-15 relative). -infinity for p <= 0, +infinity for p >= 1.
double normalQuantile(double p);

/// Standard normal cumulative distribution P(Z <= @p x).
double normalCdf(double x);

/// Wilson's score interval for a binomial proportion: @p k successes in @p n trials, two-sided at
/// @p level (e.g. 0.95). Unlike the Wald interval it stays within [0, 1] and is not empty at k = 0
/// or k = n. {NaN, NaN} for n < 1 or k outside 0..n.
std::pair<double, double> calcWilsonInterval(int k, int n, double level);

}  // namespace kneesim::identify
