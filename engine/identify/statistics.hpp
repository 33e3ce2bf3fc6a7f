#pragma once
// The standard normal distribution, shared by the fit's confidence intervals (identify) and the
// gap diagnosis's tests (gap).

namespace kneesim::identify {

/// Standard normal quantile: the x with P(Z <= x) = @p p (Acklam's rational approximation,
/// refined by one Halley step; about 1e-15 relative). -infinity for p <= 0, +infinity for p >= 1.
double normalQuantile(double p);

/// Standard normal cumulative distribution P(Z <= @p x).
double normalCdf(double x);

}  // namespace kneesim::identify
