#pragma once
// Identification of a contact law's parameters from measured knee forces (Dao & Pouletaut 2015,
// section 2.5.2), with an identifiability check before solving, fit statistics, confidence
// intervals and prediction of held-out trials.
//
// The fit minimises sum over the selected frames of weight * (F_law - F_measured)^2 over the free
// parameters within their bounds (Ipopt, exact gradient from the law's Jacobian, Gauss-Newton
// Hessian). Before solving, the scaled sensitivity matrix at the start point is analysed; every
// direction the data cannot determine is removed by fixing the parameter that dominates it at an
// assumed value (FitOptions::assumed_values, else the law's default) and the report says so. For
// Hertz, E and nu are not separately identifiable: nu is fixed (0.45 for UHMWPE by default) and the
// identified result is K = E / (1 - nu^2); E is then only "E at the assumed nu".

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "identify/contact_law.hpp"
#include "identify/identifiability.hpp"
#include "identify/metrics.hpp"
#include "identify/trial.hpp"

namespace kneesim::identify {

/// How confidence intervals are computed.
struct ConfidenceOptions {
  double level = 0.95;           ///< Two-sided confidence level.
  bool asymptotic = true;        ///< Gauss-Newton covariance sigma^2 (J^T W J)^-1, delta method for derived.
  bool profile = true;           ///< Profile likelihood (with an effective sample size for correlated residuals).
  int bootstrap_samples = 200;   ///< Bootstrap refits; 0 disables the bootstrap.
  /// Resampling unit: "frames" (circular blocks of frames within each trial) or "trials" (whole
  /// trials with replacement; needs at least two trials).
  std::string bootstrap_mode = "frames";
  int block_length = 0;          ///< Frames per block; 0: chosen from the data (see FitReport::bootstrap).
  unsigned long long seed = 20150101;  ///< Fixed seed: the same data give the same intervals.
};

/// What to identify and how.
struct FitOptions {
  /// Parameters to identify. Empty: every parameter the law does not fix by default.
  std::vector<std::string> free_parameters;
  /// Values overriding the law's defaults: start values of free parameters, values of fixed ones.
  std::map<std::string, double> parameter_values;
  /// Bounds overriding the law's (lower, upper).
  std::map<std::string, std::pair<double, double>> bounds;
  /// Values stated for parameters the data may not determine, e.g. {"nu", 0.45}. A parameter fixed
  /// by the identifiability check takes its value from here, else from parameter_values, else the
  /// law's default; the report names the source.
  std::map<std::string, double> assumed_values;
  /// Relative singular value below which a direction is unidentifiable, and below which it is weak.
  double identifiability_tolerance = 1e-6;
  double weak_identifiability_tolerance = 1e-3;
  /// Fix unidentifiable parameters and solve for the rest (true), or stop with an InputError (false).
  bool fix_unidentifiable = true;
  double body_mass = 0;          ///< kg, for errors in body weights; 0: unknown.
  std::vector<Phase> phases;     ///< Parts of each trial reported separately.
  ConfidenceOptions confidence;
  int max_iterations = 200;
  double tolerance = 1e-10;      ///< Ipopt tol on the scaled problem.
  bool gauss_newton = true;      ///< false: Ipopt's limited-memory quasi-Newton Hessian.
  bool verbose = false;          ///< Ipopt's iteration log.
  /// The start values are known to lie near the solution (a refit on a subset of the data from the
  /// full fit's optimum, as cross-validation does): start Ipopt's barrier small (about half the
  /// iterations). Leave false for a fresh identification.
  bool warm_start = false;
  SourceLocation where;          ///< The setup element, for error messages.
};

/// A confidence interval; NaN ends when not computed.
struct Interval {
  double lower = FitMetrics::nan;
  double upper = FitMetrics::nan;
  bool isValid() const { return lower == lower && upper == upper; }
};

/// Why a parameter has its value.
enum class ParameterStatus {
  Identified,           ///< Free and determined by the data.
  FixedBySetup,         ///< Held fixed by the law's default or the setup.
  FixedUnidentifiable,  ///< Freed, but the data cannot determine it: held at an assumed value.
};

/// Name of a status: "identified", "fixed", "fixed: not identifiable".
std::string toString(ParameterStatus s);

/// One parameter in a FitReport.
struct ParameterResult {
  std::string name, unit;
  double value = 0;     ///< Identified value, or the value it was held at.
  double start = 0;     ///< Start value of the solve.
  double lower = 0, upper = 0;
  ParameterStatus status = ParameterStatus::FixedBySetup;
  std::string value_source;  ///< For fixed parameters: "law default", "setup", "assumed value".
  bool at_bound = false;     ///< The solution lies on a bound (the interval may be cut by it).
  Interval ci_asymptotic, ci_profile, ci_bootstrap;
};

/// One derived quantity (e.g. K) in a FitReport.
struct DerivedResult {
  std::string name, unit;
  double value = 0;
  /// True when the quantity is invariant along every unidentifiable direction of the freed
  /// parameters (so the data determine it even where they do not determine the parameters).
  bool identified = true;
  Interval ci_asymptotic, ci_profile, ci_bootstrap;
};

/// A parameter fixed because the data cannot determine it.
struct FixedByIdentifiability {
  std::string name;
  double value = 0;
  std::string value_source;     ///< "assumed value", "setup" or "law default".
  std::string direction;        ///< The null direction it dominated, e.g. "0.453 E - 0.891 nu".
  double relative_singular_value = 0;
};

/// Fit statistics of one trial.
struct TrialFit {
  std::string trial;
  FitMetrics metrics;
  std::vector<std::pair<std::string, FitMetrics>> phases;
};

/// Summary of the Ipopt solve.
struct SolverSummary {
  std::string status;
  int status_code = 0;
  bool success = false;
  int iterations = 0;
  double objective = 0;        ///< Sum of weight * residual^2 at the solution, N^2.
  double start_objective = 0;  ///< The same at the start point.
};

/// What the bootstrap did.
struct BootstrapSummary {
  std::string mode;
  int samples = 0;
  int block_length = 0;
  int failures = 0;   ///< Refits that did not converge (left out of the intervals).
  unsigned long long seed = 0;
};

/// Everything fit() found.
struct FitReport {
  std::string law, law_origin;
  std::vector<std::string> trials;
  std::vector<ParameterResult> parameters;  ///< Every parameter of the law, table order.
  std::vector<DerivedResult> derived;
  IdentifiabilityReport identifiability_start;  ///< All freed parameters at the start point.
  IdentifiabilityReport identifiability_final;  ///< The parameters actually solved for, at the optimum.
  std::vector<FixedByIdentifiability> fixed_by_identifiability;
  SolverSummary solver;
  FitMetrics overall;
  std::vector<TrialFit> per_trial;
  std::vector<std::pair<std::string, FitMetrics>> per_phase;  ///< Pooled over trials.
  double residual_lag1_correlation = 0;  ///< Mean lag-1 autocorrelation of residuals within trials.
  double effective_frames = 0;  ///< n (1 - rho) / (1 + rho), used by the profile likelihood.
  double confidence_level = 0.95;
  BootstrapSummary bootstrap;
  std::vector<std::string> notes;  ///< Plain-language statements (identifiability, bounds, warnings).

  /// All parameter values in table order (for predict()).
  Eigen::VectorXd getValues() const;
  /// The result for parameter or derived quantity @p name; throws InternalError if absent.
  const ParameterResult& getParameter(const std::string& name) const;
  const DerivedResult& getDerived(const std::string& name) const;
};

/// Predicted force of one trial and its agreement with the measurement.
struct PredictionReport {
  std::string trial;
  std::vector<int> frames;         ///< Frames in the trial's windows.
  std::vector<double> time;        ///< Their times, s.
  std::vector<double> measured;    ///< Measured force, N.
  std::vector<double> predicted;   ///< Law's force, N.
  FitMetrics metrics;
  std::vector<std::pair<std::string, FitMetrics>> phases;
};

/// Identifies @p law's parameters from @p trials. Throws InputError (at options.where or the
/// trial's source) for malformed trials, windows that select no frames, a channel the law needs
/// but a trial lacks, unknown parameter names, bad bounds, and (with fix_unidentifiable = false)
/// an unidentifiable parameter set. A solver that does not converge is reported, not thrown.
FitReport fit(const ContactLaw& law, const std::vector<Trial>& trials, const FitOptions& options = {});

/// Force of @p law at @p params (all parameters, table order) on @p trial's windowed frames and the
/// agreement with its measured force (e.g. for a held-out trial). body_mass and phases are taken
/// from @p options.
PredictionReport predict(const ContactLaw& law, const Eigen::VectorXd& params, const Trial& trial,
                         const FitOptions& options = {});

}  // namespace kneesim::identify
