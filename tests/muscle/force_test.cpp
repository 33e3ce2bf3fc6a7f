// Rigid-tendon muscle forces against hand-derived points of Thelen's equations, the defining
// points and slopes of Millard's Bezier curves, and an independent solution of the Schutte
// muscle's fibre-tendon equilibrium.
#include "muscle/force.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "support/input_error.hpp"

using namespace kneesim;

namespace {

model::Muscle makeMuscle(const std::string& type, double phi_opt = 0.0) {
  model::Muscle m;
  m.name = "m";
  m.type = type;
  m.max_isometric_force = 1000.0;
  m.optimal_fiber_length = 0.1;
  m.tendon_slack_length = 0.2;
  m.pennation_angle_at_optimal = phi_opt;
  m.max_contraction_velocity = 10.0;
  return m;
}

model::Model modelWith(const model::Muscle& m) {
  model::Model model;
  model.muscles.push_back(m);
  return model;
}

}  // namespace

// At the optimal fibre length and zero velocity fal = fv = 1: the tendon carries F0 cos(phi0).
// Thelen's Eq. 6 (Af = 0.25, a = 1): a normalised velocity of -0.5 needs Fm = 1/6, and
// Fm = 1.2 (eccentric, Flen = 1.4) gives (Fm - 1) / ((2 + 2/Af)(Flen - Fm)/(Flen - 1)) = 0.04.
TEST(MuscleForceSet, ThelenMatchesHandDerivedPoints) {
  const double phi0 = 0.2;
  const muscle::MuscleForceSet forces(modelWith(makeMuscle("Thelen2003Muscle", phi0)));
  const double L_opt = 0.2 + 0.1 * std::cos(phi0);
  EXPECT_NEAR(forces.calcRigidTendonFiberLength(0, L_opt), 0.1, 1e-15);
  EXPECT_NEAR(forces.calcRigidTendonForce(0, 1.0, L_opt, 0.0), 1000.0 * std::cos(phi0), 1e-9);
  EXPECT_NEAR(forces.calcRigidTendonForce(0, 0.5, L_opt, 0.0), 500.0 * std::cos(phi0), 1e-9);

  const muscle::MuscleForceSet straight(modelWith(makeMuscle("Thelen2003Muscle")));
  const double vmax_lopt = 10.0 * 0.1;
  EXPECT_NEAR(straight.calcRigidTendonForce(0, 1.0, 0.3, -0.5 * vmax_lopt), 1000.0 / 6.0, 1e-9);
  EXPECT_NEAR(straight.calcRigidTendonForce(0, 1.0, 0.3, 0.04 * vmax_lopt), 1200.0, 1e-9);
  // Gaussian active force-length curve, KshapeActive = 0.45: fal(1.3) = exp(-0.09 / 0.45).
  EXPECT_NEAR(straight.calcRigidTendonForce(0, 1.0, 0.33, 0.0), 1000.0 * std::exp(-0.2), 1e-9);
}

TEST(MuscleForceSet, ThelenVelocityIsContinuousIntoItsLinearExtrapolation) {
  // Above 0.95 Flen a fal the curve continues linearly with the slope it had there.
  const double a = 1, fal = 1, af = 0.25, flen = 1.4, th = 0.95;
  const double f0 = th * flen, h = 1e-7;
  const double below = muscle::calcThelenFiberVelocity(a, fal, f0 - h, af, flen, th);
  const double above = muscle::calcThelenFiberVelocity(a, fal, f0 + h, af, flen, th);
  const double slope = (muscle::calcThelenFiberVelocity(a, fal, f0 - h, af, flen, th) -
                        muscle::calcThelenFiberVelocity(a, fal, f0 - 3 * h, af, flen, th)) /
                       (2 * h);
  EXPECT_NEAR(above - below, 2 * h * slope, 1e-9);
  // Maximum shortening velocity at zero force, a = 1: -(0.25 + 0.75 a).
  EXPECT_NEAR(muscle::calcThelenFiberVelocity(a, fal, 1e-12, af, flen, th), -1.0, 1e-9);
}

// Millard's curves pass through their defining points with their defining slopes: fal(1) = 1
// with zero slope, fal = minimum_value (0.1) at 0.47561 and 1.8123; fv(-1) = 0, fv(0) = 1 with
// the isometric slope 5, fv(1) = 1.4.
TEST(MuscleForceSet, MillardCurvesPassThroughTheirDefiningPoints) {
  const auto fal = muscle::BezierCurve::makeActiveForceLength(0.47561, 0.73, 1.0, 1.8123, 0.1, 0.8616, 1.0);
  EXPECT_NEAR(fal.calcValue(1.0), 1.0, 1e-12);
  EXPECT_NEAR(fal.calcDerivative(1.0), 0.0, 1e-9);
  EXPECT_NEAR(fal.calcValue(0.47561), 0.1, 1e-12);
  EXPECT_NEAR(fal.calcValue(1.8123), 0.1, 1e-12);
  EXPECT_NEAR(fal.calcValue(3.0), 0.1, 1e-12);
  // Joints of the elbows (Millard's construction, shoulder at xs = 0.95): the plateau's
  // midpoint x1s = 0.84 with the shallow slope, the ascending limb's midpoint x01 = 0.602805
  // with slope 1.25 y1 / (x1 - x0), y1 = 1 - 0.8616 (0.95 - 0.73).
  const double y1 = 1 - 0.8616 * (0.95 - 0.73);
  EXPECT_NEAR(fal.calcValue(0.84), y1 + 0.5 * (1 - y1), 1e-12);
  EXPECT_NEAR(fal.calcDerivative(0.84), 0.8616, 1e-9);
  EXPECT_NEAR(fal.calcValue(0.47561 + 0.5 * (0.73 - 0.47561)), 0.5 * y1, 1e-12);
  EXPECT_NEAR(fal.calcDerivative(0.47561 + 0.5 * (0.73 - 0.47561)), 1.25 * y1 / (0.73 - 0.47561), 1e-9);
  const auto fv = muscle::BezierCurve::makeForceVelocity(1.4, 0.0, 0.25, 5.0, 0.0, 0.15, 0.6, 0.9);
  EXPECT_NEAR(fv.calcValue(-1.0), 0.0, 1e-12);
  EXPECT_NEAR(fv.calcValue(0.0), 1.0, 1e-12);
  EXPECT_NEAR(fv.calcDerivative(0.0), 5.0, 1e-9);
  EXPECT_NEAR(fv.calcValue(1.0), 1.4, 1e-12);
  EXPECT_NEAR(fv.calcDerivative(-0.9), 0.25, 1e-9);
  EXPECT_NEAR(fv.calcDerivative(0.9), 0.15, 1e-9);
  for (double v = -0.99; v < 1.0; v += 0.01) EXPECT_GT(fv.calcDerivative(v), 0.0) << v;

  const muscle::MuscleForceSet forces(modelWith(makeMuscle("Millard2012EquilibriumMuscle")));
  EXPECT_NEAR(forces.calcRigidTendonForce(0, 1.0, 0.3, 0.0), 1000.0, 1e-9);
  EXPECT_NEAR(forces.calcRigidTendonForce(0, 1.0, 0.3, -0.1), 1000.0 * fv.calcValue(-0.1), 1e-9);
}

// OpenSim 4's Millard defaults and the reshaping its extendFinalizeFromProperties applies: the
// active force-length curve starts at 0.47 - 0.0259 = 0.4441 (fal(0.45) > 0), its floor is 0 in the
// damped model (the default, fiber_damping 0.1) and at least 0.1 in the classic Hill model with an
// elastic tendon, whose force-velocity curve gets end slopes of half the near ones (0.125, 0.075).
TEST(MuscleForceSet, MillardCurvesTakeOpenSimsDefaultsAndTheModelVariantsShape) {
  const double L_at = 0.2;  // tendon slack length: L = 0.2 + lce_n * 0.1 with a rigid tendon
  const muscle::MuscleForceSet damped(modelWith(makeMuscle("Millard2012EquilibriumMuscle")));
  const auto fal0 = muscle::BezierCurve::makeActiveForceLength(0.4441, 0.73, 1.0, 1.8123, 0.0, 0.8616, 1.0);
  EXPECT_GT(fal0.calcValue(0.45), 0.0);
  EXPECT_NEAR(damped.calcRigidTendonForce(0, 1.0, L_at + 0.045, 0.0), 1000.0 * fal0.calcValue(0.45), 1e-9);
  EXPECT_NEAR(damped.calcRigidTendonForce(0, 1.0, L_at + 0.040, 0.0), 0.0, 1e-12);
  EXPECT_NEAR(damped.calcRigidTendonForce(0, 1.0, L_at + 0.2, 0.0), 0.0, 1e-12);

  model::Muscle hill = makeMuscle("Millard2012EquilibriumMuscle");
  hill.parameters["fiber_damping"] = 0.0;
  const muscle::MuscleForceSet classic(modelWith(hill));
  EXPECT_NEAR(classic.calcRigidTendonForce(0, 1.0, L_at + 0.040, 0.0), 100.0, 1e-9);
  EXPECT_NEAR(classic.calcRigidTendonForce(0, 1.0, L_at + 0.2, 0.0), 100.0, 1e-9);
  const auto fv_hill = muscle::BezierCurve::makeForceVelocity(1.4, 0.125, 0.25, 5.0, 0.075, 0.15, 0.6, 0.9);
  const auto fv_damped = muscle::BezierCurve::makeForceVelocity(1.4, 0.0, 0.25, 5.0, 0.0, 0.15, 0.6, 0.9);
  // vmax lopt = 1 m/s: a lengthening speed of -0.95 m/s is a normalised fibre velocity of -0.95.
  EXPECT_NEAR(classic.calcRigidTendonForce(0, 1.0, 0.3, -0.95), 1000.0 * fv_hill.calcValue(-0.95), 1e-9);
  EXPECT_NEAR(damped.calcRigidTendonForce(0, 1.0, 0.3, -0.95), 1000.0 * fv_damped.calcValue(-0.95), 1e-9);
  EXPECT_GT(std::abs(fv_hill.calcValue(-0.95) - fv_damped.calcValue(-0.95)), 1e-3);

  hill.parameters["ignore_tendon_compliance"] = 1.0;  // rigid and undamped: shaped as the damped model
  const muscle::MuscleForceSet rigid(modelWith(hill));
  EXPECT_NEAR(rigid.calcRigidTendonForce(0, 1.0, L_at + 0.040, 0.0), 0.0, 1e-12);
}

// The Schutte muscle's isometric force: the fibre length where the elastic tendon's force
// equals the fibres' (active + passive) force along it, found here by bisection.
TEST(MuscleForceSet, SchutteIsometricForceBalancesTendonAndFibres) {
  model::Muscle m = makeMuscle("Schutte1993Muscle_Deprecated", 0.1);
  m.optimal_fiber_length = 0.1031;
  m.tendon_slack_length = 0.036;
  m.max_isometric_force = 303.7;
  // JW's addbrev curves (Schutte 1993 / SIMM defaults).
  m.functions["tendon_force_length_curve"] = model::makeSimmSpline(
      {-10, -0.002, -0.001, 0, 0.00131, 0.00281, 0.00431, 0.00581, 0.00731, 0.00881, 0.0103, 0.0118, 0.0123, 9.2, 9.201,
       9.202, 20},
      {0, 0, 0, 0, 0.0108, 0.0257, 0.0435, 0.0652, 0.0915, 0.123, 0.161, 0.208, 0.227, 345, 345, 345, 345});
  m.functions["active_force_length_curve"] = model::makeSimmSpline(
      {-5.30769, -4.30769, -1.92308, -0.884615, -0.269231, 0.230769, 0.461538, 0.52725, 0.62875, 0.71875, 0.86125,
       1.045,    1.2175,   1.43875,  1.5,       1.61539,   2,        2.96154,  3.69231, 5.46154, 9.9019},
      {0.012188, 0.021899, 0.036466, 0.052493, 0.075312, 0.114158, 0.157859, 0.226667, 0.636667, 0.856667, 0.95,
       0.993333, 0.77,     0.246667, 0.193821, 0.133252, 0.072683, 0.044417, 0.036341, 0.021899, 0.007332});
  m.functions["passive_force_length_curve"] =
      model::makeSimmSpline({-5, 0.998, 0.999, 1, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.601, 1.602, 5},
                            {0, 0, 0, 0, 0.035, 0.12, 0.26, 0.55, 1.17, 2, 2, 2, 2});
  const muscle::MuscleForceSet forces(modelWith(m));
  const double lopt = m.optimal_fiber_length, lts = m.tendon_slack_length, F0 = m.max_isometric_force;
  const double width = lopt * std::sin(0.1);
  // The deprecated muscles' force-velocity factor at zero velocity: 1.8 - 1.8 / (1 + e^(0.04/0.18)).
  const double fv0 = 1.8 - 1.8 / (1.0 + std::exp(0.04 / 0.18));
  for (double L : {0.13, 0.14, 0.15, 0.16}) {
    auto imbalance = [&](double lce) {
      const double cosp = std::cos(std::asin(width / lce));
      const double tendon = L - lce * cosp;
      const double strain = tendon / lts - 1.0;
      const double ft = strain < 0 ? 0 : m.functions["tendon_force_length_curve"]->calcValue(strain) * F0;
      const double fa = std::max(0.0, m.functions["active_force_length_curve"]->calcValue(lce / lopt));
      const double fp = std::max(0.0, m.functions["passive_force_length_curve"]->calcValue(lce / lopt));
      return ft - (fa + fp) * F0 * cosp;
    };
    double lo = width * 1.0001, hi = (L - lts) / std::cos(std::asin(width / (L - lts)));
    ASSERT_GT(imbalance(lo), 0);
    ASSERT_LT(imbalance(hi), 0);
    for (int i = 0; i < 200; ++i) (imbalance(0.5 * (lo + hi)) > 0 ? lo : hi) = 0.5 * (lo + hi);
    const double lce = 0.5 * (lo + hi);
    const double cosp = std::cos(std::asin(width / lce));
    const double f_ref = (std::max(0.0, m.functions["active_force_length_curve"]->calcValue(lce / lopt)) +
                          std::max(0.0, m.functions["passive_force_length_curve"]->calcValue(lce / lopt))) *
                         F0 * cosp;
    // OpenSim stops when the two forces agree within 0.01 N.
    EXPECT_NEAR(forces.calcRigidTendonForce(0, 1.0, L, 0.0), f_ref * fv0, 0.02) << "L = " << L;
  }
}

// Thelen2003Muscle_Deprecated's isometric force from Thelen 2003's curves as that class writes them
// (Gaussian active curve, exponential passive curve, exponential-linear tendon plus 0.001 (1 + strain)),
// its equilibrium found here by bisection; the deprecated classes' force-velocity factor on top.
TEST(MuscleForceSet, ThelenDeprecatedIsometricForceBalancesTendonAndFibres) {
  model::Muscle m = makeMuscle("Thelen2003Muscle_Deprecated", 0.15);
  m.optimal_fiber_length = 0.0858;  // arm26's BRA, with a pennation angle
  m.tendon_slack_length = 0.0535;
  m.max_isometric_force = 987.26;
  m.parameters["KshapeActive"] = 0.5;
  m.parameters["KshapePassive"] = 4.0;
  m.parameters["FmaxMuscleStrain"] = 0.6;
  m.parameters["FmaxTendonStrain"] = 0.033;
  const muscle::MuscleForceSet forces(modelWith(m));
  const double lopt = m.optimal_fiber_length, lts = m.tendon_slack_length, F0 = m.max_isometric_force;
  const double width = lopt * std::sin(0.15);
  auto active = [](double ln) { return std::exp(-(ln - 1) * (ln - 1) / 0.5); };
  auto passive = [](double ln) {
    return ln > 1.6 ? 1.0 + 4.0 / 0.6 * (ln - 1.6) : std::exp(4.0 * (ln - 1) / 0.6) / std::exp(4.0);
  };
  auto tendon = [](double e) {
    const double toe = 0.609 * 0.033;
    const double f = e > toe ? 1.712 / 0.033 * (e - toe) + 0.333333
                     : e > 0 ? 0.333333 * (std::exp(3 * e / toe) - 1) / (std::exp(3.0) - 1)
                             : 0.0;
    return f + 0.001 * (1 + e);
  };
  const double fv0 = 1.8 - 1.8 / (1.0 + std::exp(0.04 / 0.18));
  for (double L : {0.125, 0.135, 0.145, 0.16, 0.19, 0.215}) {  // fibres short, optimal, long, beyond 1.6 lopt
    auto fiberForce = [&](double lce) {
      return (active(lce / lopt) + passive(lce / lopt)) * F0 * std::cos(std::asin(width / lce));
    };
    auto imbalance = [&](double lce) {
      return tendon((L - lce * std::cos(std::asin(width / lce))) / lts - 1) * F0 - fiberForce(lce);
    };
    double lo = width * 1.0001, hi = (L - lts) / std::cos(std::atan(width / (L - lts)));
    ASSERT_GT(imbalance(lo), 0) << L;
    ASSERT_LT(imbalance(hi), 0) << L;
    for (int i = 0; i < 200; ++i) (imbalance(0.5 * (lo + hi)) > 0 ? lo : hi) = 0.5 * (lo + hi);
    // OpenSim stops when the two forces agree within 0.01 N.
    EXPECT_NEAR(forces.calcRigidTendonForce(0, 1.0, L, 0.0), fiberForce(0.5 * (lo + hi)) * fv0, 0.02) << "L = " << L;
  }
  // Shortening at 2 optimal lengths per second: the generic factor 1.8 - 1.8 / (1 + e^((0.04 - v) / 0.18)).
  const double v = std::cos(0.15) * 2 * lopt / (10 * lopt);
  EXPECT_NEAR(forces.calcRigidTendonForce(0, 1.0, 0.145, -2 * lopt) / forces.calcRigidTendonForce(0, 1.0, 0.145, 0.0),
              (1.8 - 1.8 / (1.0 + std::exp((0.04 - v) / 0.18))) / fv0, 1e-12);
}

TEST(MuscleForceSet, ParametersOpenSimRefusesAreOneLineErrors) {
  model::Muscle m = makeMuscle("Thelen2003Muscle");
  m.parameters["Flen"] = 1.0;
  m.where = {"/tmp/m.osim", 12, "Thelen2003Muscle[m]"};
  const std::string msg = test::inputErrorOf([&] { muscle::MuscleForceSet forces(modelWith(m)); });
  EXPECT_NE(msg.find("/tmp/m.osim:12:"), std::string::npos) << msg;
  EXPECT_NE(msg.find("expected Flen > 1, got 1"), std::string::npos) << msg;
  model::Muscle s = makeMuscle("Schutte1993Muscle_Deprecated");
  EXPECT_NE(test::inputErrorOf([&] { muscle::MuscleForceSet forces(modelWith(s)); }).find("tendon_force_length_curve"),
            std::string::npos);
  model::Muscle d = makeMuscle("Thelen2003Muscle_Deprecated");
  d.parameters["FmaxMuscleStrain"] = 0.0;
  EXPECT_NE(test::inputErrorOf([&] { muscle::MuscleForceSet forces(modelWith(d)); })
                .find("expected positive KshapeActive, FmaxMuscleStrain and FmaxTendonStrain"),
            std::string::npos);
}
