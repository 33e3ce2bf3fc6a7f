// Schutte1993Muscle_Deprecated's isometric force: the fibre and elastic-tendon lengths that
// balance their forces, found by OpenSim's iteration (computeIsometricForce, after SIMM).
#include <cmath>

#include "muscle/force.hpp"

namespace kneesim::muscle {

namespace {

/// OpenSim's ActivationFiberLengthMuscle_Deprecated::calcPennation (constant muscle width).
double pennation(double fiber_length, double lopt, double phi_opt) {
  if (fiber_length < 2.2e-16) return 0.0;
  const double value = lopt * std::sin(phi_opt) / fiber_length;
  if (std::isnan(value) || value <= 0.0) return 0.0;
  if (value >= 1.0) return M_PI / 2.0;
  return std::asin(value);
}

int dsign(double a) { return a >= 0.0 ? 1 : -1; }

}  // namespace

double MuscleForceSet::calcSchutteIsometric(const Params& p, double a, double length) const {
  constexpr int kMaxIterations = 100;
  constexpr double kErrorLimit = 0.01;  // N
  constexpr double kRoundoff = 2e-13;
  const double lopt = p.lopt, lts = p.lts, fiso = p.fiso, phi0 = p.phi_opt;
  auto active = [&](double lce) { return std::max(0.0, p.active_fl->calcValue(lce / lopt)); };
  auto passive = [&](double lce) {
    // The default curve is Raasch and Schutte's exponential, equal to 1 at 1.5 optimal lengths.
    return p.passive_fl ? p.passive_fl->calcValue(lce / lopt) : std::exp(8.0 * (lce / lopt - 1.0)) / std::exp(4.0);
  };
  if (lopt < kRoundoff) return 0.0;
  const double width = lopt * std::sin(phi0);
  double fiber = 0, cos_factor = 1, tendon = 0;
  if (lts < kRoundoff) {
    cos_factor = std::cos(std::atan(width / length));
    fiber = length / cos_factor;
    return (active(fiber) * a + passive(fiber)) * fiso * cos_factor;
  }
  if (length < lts) return 0.0;
  // Lengths for a fibre length guess; a tendon shorter than its slack length is set to it and
  // the fibre recomputed.
  auto place = [&](double guess, bool at_least_width) {
    fiber = guess;
    cos_factor = std::cos(pennation(fiber, lopt, phi0));
    tendon = length - fiber * cos_factor;
    if (tendon < lts) {
      tendon = lts;
      cos_factor = std::cos(std::atan(width / (length - tendon)));
      fiber = (length - tendon) / cos_factor;
      if (at_least_width && fiber < width) fiber = width;
    }
  };
  place(lopt, true);
  double old_fiber = NAN, error = 0.0, tendon_force = 0.0;
  for (int i = 0; i < kMaxIterations; ++i) {
    const double fa = active(fiber) * a;
    const double fp = std::max(0.0, passive(fiber));
    const double fiber_force = (fa + fp) * fiso * cos_factor;
    const double strain = tendon / lts - 1.0;
    tendon_force = strain < 0.0 ? 0.0 : p.tendon_fl->calcValue(strain) * fiso;
    double old_error = error;
    error = tendon_force - fiber_force;
    if (std::abs(error) <= kErrorLimit) break;
    if (i == 0) old_error = error;
    if (dsign(error) != dsign(old_error)) {
      // The sign changed: interpolate between the last two fibre lengths.
      const double percent = std::abs(error) / (std::abs(error) + std::abs(old_error));
      const double tmp = old_fiber;
      old_fiber = fiber;
      fiber += percent * (tmp - fiber);
    } else {
      // Newton-like step on the two stiffnesses; the tendon's is raised to at least the
      // current normalised force times its maximum (modulus 1200, max stress 32) so the step
      // does not overshoot, and the step is limited to half an optimal fibre length.
      double tendon_stiffness = (strain < 0.0 ? 0.0 : p.tendon_fl->calcValue(strain)) * fiso / lts;
      const double min_tendon_stiffness = (fa + fp) * 1200.0 * fiso / (32.0 * lts);
      if (tendon_stiffness < min_tendon_stiffness) tendon_stiffness = min_tendon_stiffness;
      const double fiber_stiffness = fiso / lopt * (p.active_fl->calcValue(fiber / lopt) + passive(fiber));
      double change = std::abs(error / (fiber_stiffness / cos_factor + tendon_stiffness));
      if (std::abs(change / lopt) > 0.5) change = 0.5 * lopt;
      old_fiber = fiber;
      fiber += error > 0.0 ? change : -change;
    }
    place(fiber, false);
  }
  return tendon_force;
}

}  // namespace kneesim::muscle
