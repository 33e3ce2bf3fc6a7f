#pragma once
// Muscle force as OpenSim's StaticOptimization evaluates it (Muscle::
// calcInextensibleTendonActiveFiberForce): the force along the tendon that activation a produces
// at a given path length and lengthening speed, the tendon taken as rigid, for
// Thelen2003Muscle (Thelen, J Biomech Eng 125:70-77, 2003), Millard2012EquilibriumMuscle
// (Millard et al., J Biomech Eng 135:021005, 2013), and Schutte1993Muscle_Deprecated (Schutte
// et al., 1993) and Thelen2003Muscle_Deprecated (OpenSim's deprecated muscles use their isometric
// equilibrium with the elastic tendon, passive fibre force included, times a generic
// force-velocity factor).
//
// The result is a * F(L, Ldot) with F the force at full activation (clamped activations aside),
// which makes static optimisation's muscle forces linear in activation.

#include <vector>

#include "model/model.hpp"
#include "muscle/bezier.hpp"

namespace kneesim::muscle {

/// The rigid-tendon force characteristics of a model's muscles (Model::muscles, in order).
/// Immutable; evaluation allocates nothing.
class MuscleForceSet {
 public:
  /// Reads each muscle's parameters (OpenSim's defaults where the file gives none). Throws
  /// InputError, naming the muscle, for a parameter OpenSim would refuse (e.g. Flen <= 1).
  explicit MuscleForceSet(const model::Model& model);

  int size() const { return int(muscles_.size()); }

  /// Tendon force (N) of muscle @p i at activation @p activation, path length @p length (m) and
  /// lengthening speed @p speed (m/s), with a rigid tendon.
  double calcRigidTendonForce(int i, double activation, double length, double speed) const;

  /// Fibre length (m) of muscle @p i at path length @p length with a rigid tendon.
  double calcRigidTendonFiberLength(int i, double length) const;

 private:
  enum class Type { Thelen2003, Millard2012, Schutte1993, Thelen2003Deprecated };
  struct Params {
    explicit Params(const model::Muscle& m);
    Type type = Type::Thelen2003;
    double fiso, lopt, lts, phi_opt, vmax;                       // the muscle's common properties, as Muscle names them
    double height = 0, max_pennation = 0, min_fiber_length = 0;  // fixed-width pennation model
    double min_activation = 0;
    double k_active = 0.45, af = 0.25, flen = 1.4, fv_threshold = 0.95;  // Thelen
    double k_passive = 4.0, fmax_muscle_strain = 0.6, fmax_tendon_strain = 0.033;  // Thelen, deprecated
    BezierCurve active_force_length, force_velocity;                     // Millard
    model::FunctionPtr tendon_fl, active_fl, passive_fl;                 // Schutte (passive may be null)
    double damping = 0.1;
  };
  /// Millard2012EquilibriumMuscle's curves from its properties, shaped as OpenSim 4 shapes them
  /// for the muscle's variant (damped or classic Hill, rigid or elastic tendon).
  static void readMillard(const model::Muscle& m, Params& p);
  /// The deprecated classes' parameters: Schutte1993's curves, Thelen2003_Deprecated's shape factors.
  static void readDeprecated(const model::Muscle& m, Params& p);
  double calcThelen(const Params& p, double a, double fiber_length, double fiber_velocity) const;
  double calcMillard(const Params& p, double a, double fiber_length, double fiber_velocity) const;
  /// OpenSim's computeIsometricForce of a deprecated muscle (force_deprecated.cpp).
  double calcDeprecatedIsometric(const Params& p, double a, double length) const;
  double calcPennationAngle(const Params& p, double fiber_length) const;
  std::vector<Params> muscles_;
};

/// Thelen 2003's normalised fibre velocity (Eqs. 6-7, linearly extrapolated outside
/// 0 < Fm < fv_threshold * Flen * a * fal) for activation @p a, active force-length factor @p fal
/// and normalised fibre force @p fm; OpenSim's Thelen2003Muscle::calcdlceN.
double calcThelenFiberVelocity(double a, double fal, double fm, double af, double flen, double fv_threshold);

}  // namespace kneesim::muscle
