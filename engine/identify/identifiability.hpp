#pragma once
// Local identifiability of a law's parameters from force data: singular values of the scaled
// sensitivity matrix.
//
// Column j of the sensitivity matrix is dF/dp_j * |p_j| (the force change per relative change of
// p_j; typical_scale when p_j = 0) over the fitted frames, rows weighted by sqrt(weight). A right
// singular vector whose singular value is tiny relative to the largest is a combination of
// relative parameter changes that leaves every predicted force unchanged: the data cannot
// determine it. For Hertz, F depends on E and nu only through K = E/(1-nu^2), so the matrix of
// (E, nu) has rank one whatever the data.

#include <string>
#include <vector>

#include <Eigen/Core>

namespace kneesim::identify {

/// A right singular vector of the scaled sensitivity matrix.
struct SensitivityDirection {
  double singular_value = 0;      ///< RMS force change per unit of the direction, N.
  double relative = 0;            ///< singular_value / largest singular value.
  std::vector<double> components; ///< Unit vector over IdentifiabilityReport::parameters (relative changes);
                                  ///< sign chosen so the largest component is positive.
};

/// Result of analyzeSensitivity.
struct IdentifiabilityReport {
  std::string label;                    ///< Where it was evaluated, e.g. "start point", "optimum".
  std::vector<std::string> parameters;  ///< The parameters analysed (the free ones).
  std::vector<double> values;           ///< Their values at the evaluation point.
  std::vector<double> column_rms;       ///< RMS of each scaled sensitivity column, N.
  std::vector<double> singular_values;  ///< Descending, RMS-normalised (N).
  double condition_number = 0;          ///< Largest / smallest singular value (inf if the smallest is 0).
  double tolerance = 0;                 ///< Relative singular value below which a direction is unidentifiable.
  double weak_tolerance = 0;            ///< Below this (and above tolerance) a direction is poorly determined.
  std::vector<SensitivityDirection> null_directions;  ///< Unidentifiable directions, smallest first.
  std::vector<SensitivityDirection> weak_directions;  ///< Poorly determined directions, smallest first.

  /// True when no direction is below tolerance.
  bool isIdentifiable() const { return null_directions.empty(); }
  /// Per parameter, the length of its projection onto the null space (0: not involved, 1: entirely
  /// undetermined). Empty null space gives zeros.
  std::vector<double> calcNullSpaceLeverage() const;
  /// "0.453 E - 0.891 nu" for a direction.
  std::string describe(const SensitivityDirection& d) const;
};

/// Analyses @p scaled_sensitivity (rows: frames already multiplied by sqrt(weight); columns:
/// dF/dp_j * scale_j for @p names) at the point @p values. Directions with relative singular value
/// below @p tolerance are null directions, below @p weak_tolerance weak ones. A matrix with fewer
/// rows than columns is padded: the missing directions are null.
IdentifiabilityReport analyzeSensitivity(const Eigen::MatrixXd& scaled_sensitivity,
                                         const std::vector<std::string>& names, const std::vector<double>& values,
                                         double tolerance = 1e-6, double weak_tolerance = 1e-3,
                                         const std::string& label = "");

}  // namespace kneesim::identify
