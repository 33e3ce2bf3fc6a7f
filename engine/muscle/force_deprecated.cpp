// The isometric force of OpenSim's deprecated muscles (Schutte1993Muscle_Deprecated,
// Thelen2003Muscle_Deprecated): the fibre and elastic-tendon lengths that balance their forces,
// found by OpenSim's iteration (computeIsometricForce, after SIMM), each class with its own curves.
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

/// Schutte1993Muscle_Deprecated's curves: the model's splines of normalised fibre length and of
/// tendon strain (a slack tendon carries nothing); the default passive curve is Raasch and
/// Schutte's exponential, equal to 1 at 1.5 optimal lengths.
struct SchutteCurves {
  const model::Function& active_fl;
  const model::Function* passive_fl;
  const model::Function& tendon_fl;
  double active(double ln) const { return active_fl.calcValue(ln); }
  double passive(double ln) const {
    return passive_fl ? passive_fl->calcValue(ln) : std::exp(8.0 * (ln - 1.0)) / std::exp(4.0);
  }
  double tendon(double strain) const { return strain < 0.0 ? 0.0 : tendon_fl.calcValue(strain); }
};

/// Thelen2003Muscle_Deprecated's closed forms (Thelen 2003 as OpenSim's deprecated class writes
/// them): the Gaussian active curve, the exponential passive curve continued linearly beyond
/// 1 + FmaxMuscleStrain, and the exponential-linear tendon with a small stiffness 0.001 (1 + strain)
/// added everywhere, so it never goes quite slack.
struct ThelenCurves {
  double k_active, k_passive, muscle_strain, tendon_strain;
  double active(double ln) const { return std::exp(-(ln - 1.0) * (ln - 1.0) / k_active); }
  double passive(double ln) const {
    if (ln > 1.0 + muscle_strain) {
      // OpenSim's slope (Kp / strain) exp(Kp) / exp(Kp): the exponential's at its end.
      return 1.0 + k_passive / muscle_strain * (ln - (1.0 + muscle_strain));
    }
    return std::exp(k_passive * (ln - 1.0) / muscle_strain) / std::exp(k_passive);
  }
  double tendon(double strain) const {
    constexpr double k_toe = 3.0, toe_force = 0.333333;
    const double toe_strain = 0.609 * tendon_strain, k_lin = 1.712 / tendon_strain;
    double f = 0.0;
    if (strain > toe_strain) f = k_lin * (strain - toe_strain) + toe_force;
    else if (strain > 0.0) f = toe_force * (std::exp(k_toe * strain / toe_strain) - 1.0) / (std::exp(k_toe) - 1.0);
    return f + 0.001 * (1.0 + strain);
  }
};

/// OpenSim's computeIsometricForce at activation @p a and path length @p length: the tendon force
/// (N) where it equals the fibres' (active + passive) force along it within 0.01 N.
template <class Curves>
double isometricForce(const Curves& c, double lopt, double lts, double fiso, double phi0, double a, double length) {
  constexpr int kMaxIterations = 100;
  constexpr double kErrorLimit = 0.01;  // N
  constexpr double kRoundoff = 2e-13;
  auto active = [&](double lce) { return std::max(0.0, c.active(lce / lopt)); };
  auto passive = [&](double lce) { return std::max(0.0, c.passive(lce / lopt)); };
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
    const double fp = passive(fiber);
    const double fiber_force = (fa + fp) * fiso * cos_factor;
    const double strain = tendon / lts - 1.0;
    tendon_force = c.tendon(strain) * fiso;
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
      // Newton-like step on the two stiffnesses (OpenSim takes the tendon's force over its slack
      // length for its stiffness); the tendon's is raised to at least the current normalised
      // force times its maximum (modulus 1200, max stress 32) so the step does not overshoot, and
      // the step is limited to half an optimal fibre length.
      double tendon_stiffness = c.tendon(strain) * fiso / lts;
      const double min_tendon_stiffness = (fa + fp) * 1200.0 * fiso / (32.0 * lts);
      if (tendon_stiffness < min_tendon_stiffness) tendon_stiffness = min_tendon_stiffness;
      const double fiber_stiffness = fiso / lopt * (c.active(fiber / lopt) + c.passive(fiber / lopt));
      double change = std::abs(error / (fiber_stiffness / cos_factor + tendon_stiffness));
      if (std::abs(change / lopt) > 0.5) change = 0.5 * lopt;
      old_fiber = fiber;
      fiber += error > 0.0 ? change : -change;
    }
    place(fiber, false);
  }
  return tendon_force;
}

}  // namespace

double MuscleForceSet::calcDeprecatedIsometric(const Params& p, double a, double length) const {
  if (p.type == Type::Schutte1993)
    return isometricForce(SchutteCurves{*p.active_fl, p.passive_fl.get(), *p.tendon_fl}, p.lopt, p.lts, p.fiso,
                          p.phi_opt, a, length);
  return isometricForce(ThelenCurves{p.k_active, p.k_passive, p.fmax_muscle_strain, p.fmax_tendon_strain}, p.lopt,
                        p.lts, p.fiso, p.phi_opt, a, length);
}

}  // namespace kneesim::muscle
