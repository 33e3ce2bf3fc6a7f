// Rigid-tendon muscle force for static optimisation: Thelen2003Muscle, Millard2012EquilibriumMuscle,
// Schutte1993Muscle_Deprecated and Thelen2003Muscle_Deprecated as OpenSim evaluates
// calcInextensibleTendonActiveFiberForce.
#include "muscle/force.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/strings.hpp"

namespace kneesim::muscle {

namespace {

double param(const model::Muscle& m, const std::string& key, double fallback) {
  auto it = m.parameters.find(key);
  return it == m.parameters.end() ? fallback : it->second;
}

[[noreturn]] void refuse(const model::Muscle& m, const std::string& what) {
  throw InputError(m.where, "muscle '" + m.name + "': " + what);
}

}  // namespace

double calcThelenFiberVelocity(double a, double fal, double fm, double af, double flen, double fv_threshold) {
  const double afl = a * fal;
  const double fm_asy_c = 0.0, fm_asy_e = afl * flen;
  auto velocity = [&](double f, double& b, double& db) {
    if (f <= afl) {  // concentric
      b = afl + f / af;
      db = 1 / af;
    } else {  // eccentric
      b = ((2 + 2 / af) * (afl * flen - f)) / (flen - 1);
      db = ((2 + 2 / af) * (-1)) / (flen - 1);
    }
    return (0.25 + 0.75 * a) * (f - afl) / b;
  };
  double b, db;
  if (fm > fm_asy_c && fm < fm_asy_e * fv_threshold) return velocity(fm, b, db);
  // Linear extrapolation from the last point where Thelen's equations hold.
  const double fm0 = fm <= fm_asy_c ? fm_asy_c : fv_threshold * fm_asy_e;
  const double v0 = velocity(fm0, b, db);
  const double slope = (0.25 + 0.75 * a) / b - ((0.25 + 0.75 * a) * (fm0 - afl) / (b * b)) * db;
  return v0 + slope * (fm - fm0);
}

MuscleForceSet::Params::Params(const model::Muscle& m)
    : fiso(m.max_isometric_force),
      lopt(m.optimal_fiber_length),
      lts(m.tendon_slack_length),
      phi_opt(m.pennation_angle_at_optimal),
      vmax(m.max_contraction_velocity) {}

MuscleForceSet::MuscleForceSet(const model::Model& model) {
  for (const model::Muscle& m : model.muscles) {
    Params p(m);
    if (!(p.vmax > 0)) refuse(m, "expected a positive max_contraction_velocity, got " + formatSignificant(p.vmax, 6));
    p.height = p.lopt * std::sin(p.phi_opt);
    p.max_pennation = param(m, "maximum_pennation_angle", std::acos(0.1));
    p.min_fiber_length = std::max(1e-8, p.height / std::sin(p.max_pennation));
    if (m.type == "Thelen2003Muscle") {
      p.type = Type::Thelen2003;
      p.k_active = param(m, "KshapeActive", 0.45);
      p.af = param(m, "Af", 0.25);
      p.flen = param(m, "Flen", 1.4);
      p.fv_threshold = param(m, "fv_linear_extrap_threshold", 0.95);
      p.min_activation = param(m, "minimum_activation", 0.01);
      if (!(p.k_active > 0) || !(p.af > 0)) refuse(m, "expected positive KshapeActive and Af");
      if (!(p.flen > 1)) refuse(m, "expected Flen > 1, got " + formatSignificant(p.flen, 6));
      if (!(p.fv_threshold > 1.0 / p.flen)) refuse(m, "expected fv_linear_extrap_threshold > 1/Flen");
    } else if (m.type == "Millard2012EquilibriumMuscle") {
      readMillard(m, p);
    } else if (m.type == "Schutte1993Muscle_Deprecated" || m.type == "Thelen2003Muscle_Deprecated") {
      readDeprecated(m, p);
    } else {
      refuse(m,
             "expected a Thelen2003Muscle, Millard2012EquilibriumMuscle, Schutte1993Muscle_Deprecated or "
             "Thelen2003Muscle_Deprecated, got " +
                 m.type);
    }
    muscles_.push_back(std::move(p));
  }
}

void MuscleForceSet::readDeprecated(const model::Muscle& m, Params& p) {
  if (m.type == "Thelen2003Muscle_Deprecated") {
    // Thelen2003Muscle_Deprecated's defaults (not Thelen2003Muscle's).
    p.type = Type::Thelen2003Deprecated;
    p.k_active = param(m, "KshapeActive", 0.5);
    p.k_passive = param(m, "KshapePassive", 4.0);
    p.fmax_muscle_strain = param(m, "FmaxMuscleStrain", 0.6);
    p.fmax_tendon_strain = param(m, "FmaxTendonStrain", 0.033);
    if (!(p.k_active > 0) || !(p.fmax_muscle_strain > 0) || !(p.fmax_tendon_strain > 0))
      refuse(m, "expected positive KshapeActive, FmaxMuscleStrain and FmaxTendonStrain");
    return;
  }
  p.type = Type::Schutte1993;
  p.damping = param(m, "damping", 0.1);
  auto curve = [&](const char* name) -> model::FunctionPtr {
    auto it = m.functions.find(name);
    return it == m.functions.end() ? nullptr : it->second;
  };
  p.tendon_fl = curve("tendon_force_length_curve");
  p.active_fl = curve("active_force_length_curve");
  p.passive_fl = curve("passive_force_length_curve");
  if (!p.tendon_fl || !p.active_fl)
    refuse(m, "expected its tendon_force_length_curve and active_force_length_curve, got " +
                  std::string(!p.tendon_fl ? "no tendon curve" : "no active curve"));
}

void MuscleForceSet::readMillard(const model::Muscle& m, Params& p) {
  p.type = Type::Millard2012;
  p.min_activation = param(m, "minimum_activation", 0.01);
  const std::string fl = "ActiveForceLengthCurve.", fv = "ForceVelocityCurve.";
  // OpenSim 4's ActiveForceLengthCurve defaults (0.47 - 0.0259 for the corner's width).
  const double x0 = param(m, fl + "min_norm_active_fiber_length", 0.47 - 0.0259);
  const double x1 = param(m, fl + "transition_norm_fiber_length", 0.73);
  const double x3 = param(m, fl + "max_norm_active_fiber_length", 1.8123);
  const double dydx = param(m, fl + "shallow_ascending_slope", 0.8616);
  double ylow = param(m, fl + "minimum_value", 0.1);
  // OpenSim's extendFinalizeFromProperties reshapes the curves for the model variant the
  // muscle runs: the damped model (fiber_damping >= 0.001, the default 0.1) sets the active
  // force-length curve's minimum to 0 and the force-velocity slopes at +-vmax to 0; the
  // classic Hill model with an elastic tendon raises them to at least 0.1 and half the near slopes.
  const bool damped = param(m, "fiber_damping", 0.1) >= 0.001;
  const bool rigid = param(m, "ignore_tendon_compliance", 0.0) != 0.0;
  if (damped || rigid) ylow = 0.0;
  else ylow = std::max(ylow, 0.1);
  if (!(x0 >= 0 && x1 > x0 && 1.0 > x1 && x3 > 1.0) || !(ylow >= 0) || !(dydx >= 0 && dydx < (1 - ylow) / (1 - x1)))
    refuse(m,
           "expected 0 <= min_norm_active_fiber_length < transition_norm_fiber_length < 1 < "
           "max_norm_active_fiber_length and a shallow_ascending_slope below (1 - minimum_value) / (1 - "
           "transition_norm_fiber_length)");
  p.active_force_length = BezierCurve::makeActiveForceLength(x0, x1, 1.0, x3, ylow, dydx, 1.0);
  const double fmax = param(m, fv + "max_eccentric_velocity_force_multiplier", 1.4);
  double dc = param(m, fv + "concentric_slope_at_vmax", 0.0);
  const double dnc = param(m, fv + "concentric_slope_near_vmax", 0.25);
  const double diso = param(m, fv + "isometric_slope", 5.0);
  double de = param(m, fv + "eccentric_slope_at_vmax", 0.0);
  const double dne = param(m, fv + "eccentric_slope_near_vmax", 0.15);
  if (damped || rigid) {
    dc = 0.0;
    de = 0.0;
  } else {
    dc = std::max(dc, 0.5 * dnc);
    de = std::max(de, 0.5 * dne);
  }
  if (!(fmax > 1) || !(dc >= 0 && dc < 1) || !(dnc > dc && dnc <= 1) || !(diso > 1) ||
      !(de >= 0 && de < fmax - 1) || !(dne >= de && dne < fmax - 1))
    refuse(m,
           "expected a force-velocity curve OpenSim accepts (1 < max_eccentric_velocity_force_multiplier, "
           "slopes within their bounds)");
  p.force_velocity =
      BezierCurve::makeForceVelocity(fmax, dc, dnc, diso, de, dne, param(m, fv + "concentric_curviness", 0.6),
                                     param(m, fv + "eccentric_curviness", 0.9));
}

double MuscleForceSet::calcPennationAngle(const Params& p, double fiber_length) const {
  if (fiber_length <= p.min_fiber_length) return p.max_pennation;
  const double s = p.height / fiber_length;
  return s < std::sin(p.max_pennation) ? std::asin(s) : p.max_pennation;
}

double MuscleForceSet::calcRigidTendonFiberLength(int i, double length) const {
  const Params& p = muscles_[i];
  const double along = length - p.lts;
  return std::sqrt(p.height * p.height + along * along);
}

double MuscleForceSet::calcThelen(const Params& p, double a, double lce, double dlce) const {
  if (!(lce > p.min_fiber_length)) return 0.0;
  const double ca = std::clamp(a, p.min_activation, 1.0);
  const double lce_n = std::max(lce, p.min_fiber_length) / p.lopt;
  const double dlce_n = dlce / (p.lopt * p.vmax);
  const double fal = std::exp(-(lce_n - 1.0) * (lce_n - 1.0) / p.k_active);
  const double afl = ca * fal;
  if (!(afl > 1e-300)) return 0.0;
  // OpenSim's calcfvInv: the normalised force a fal fv whose fibre velocity is dlce_n; the
  // velocity rises monotonically with the force, so bracket it and refine.
  auto residual = [&](double fm) {
    return calcThelenFiberVelocity(ca, fal, fm, p.af, p.flen, p.fv_threshold) - dlce_n;
  };
  double lo = afl, hi = afl, step = 0.1 * afl;
  while (residual(lo) > 0) lo -= (step *= 2);
  step = 0.1 * afl;
  while (residual(hi) < 0) hi += (step *= 2);
  double fm = 0.5 * (lo + hi);
  for (int it = 0; it < 200 && hi - lo > 1e-15 * (1 + std::abs(fm)); ++it) {
    fm = 0.5 * (lo + hi);
    (residual(fm) > 0 ? hi : lo) = fm;
  }
  const double fv = fm / afl;
  return p.fiso * ca * fal * fv * std::cos(calcPennationAngle(p, lce));
}

double MuscleForceSet::calcMillard(const Params& p, double a, double lce, double dlce) const {
  if (lce <= p.min_fiber_length) return 0.0;
  const double ca = std::clamp(a, p.min_activation, 1.0);
  const double lce_n = lce / p.lopt;
  const double dlce_n = dlce / (p.lopt * p.vmax);
  const double fal = p.active_force_length.calcValue(lce_n);
  const double fv = p.force_velocity.calcValue(dlce_n);
  // OpenSim (calcActiveFiberForceAlongTendon) takes the pennation angle of the normalised
  // fibre length; reproduced as written.
  return p.fiso * ca * fal * fv * std::cos(calcPennationAngle(p, lce_n));
}

double MuscleForceSet::calcRigidTendonForce(int i, double a, double length, double speed) const {
  const Params& p = muscles_[i];
  if (p.type == Type::Schutte1993 || p.type == Type::Thelen2003Deprecated) {
    const double iso = calcDeprecatedIsometric(p, a, length);
    // The deprecated muscles' generic force-velocity factor at the shortening velocity
    // -cos(phi_opt) Ldot, normalised by vmax lopt.
    const double v = -std::cos(p.phi_opt) * speed / (p.vmax * p.lopt);
    const double fv = 1.8 - 1.8 / (1.0 + std::exp((0.04 - v) / 0.18));
    return iso * fv;
  }
  const double lce = calcRigidTendonFiberLength(i, length);
  if (p.type == Type::Thelen2003 && !(lce > p.min_fiber_length)) return 0.0;
  const double phi = calcPennationAngle(p, lce);
  const double dlce = speed * std::cos(phi);
  return p.type == Type::Thelen2003 ? calcThelen(p, a, lce, dlce) : calcMillard(p, a, lce, dlce);
}

}  // namespace kneesim::muscle
