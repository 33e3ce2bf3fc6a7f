#pragma once
// The instrumented knee (eKnee) load-cell recordings of the Knee Grand Challenge: a CSV with
// columns Time(sec), PM, AM, AL, PL, GON, GRFz in pound-force, at the motion-capture rate.
// Row i belongs to C3D frame first_frame + i.

#include <string>
#include <vector>

namespace kneesim::io {

/// Coefficients of Dao & Pouletaut's equation 4 (after Zhao et al. 2007), which turns the four
/// tray load cells into medial and lateral compartment forces. Order: AM, PM, AL, PL.
struct KneeForceCoefficients {
  double medial[4] = {0.9871, 0.9683, 0.0387, 0.0211};   ///< F_medial = sum medial[k] * cell[k].
  double lateral[4] = {0.0129, 0.0317, 0.9613, 0.9789};  ///< F_lateral = sum lateral[k] * cell[k].
  /// The published coefficients (the same as a default-constructed object).
  static KneeForceCoefficients defaults() { return {}; }
};

/// Newtons per unit of the GRFz (GRF) column of JW's knee-force CSVs: the column is force plate 1's
/// vertical force divided by 2000 (against the C3D's Fz1: gain 0.000500 N^-1 on ngait_og3, where
/// plate 1 is under the left foot, r = 0.998; 0.000499 on stairupf1, right foot, r = 0.9995).
constexpr double kJwCsvGrfNewtonsPerUnit = 2000.0;

/// Pound-force in newtons.
constexpr double kNewtonsPerPoundForce = 4.4482216152605;

/// Knee contact forces over time. Load cells and compartment forces are in newtons.
struct KneeForces {
  std::string source_file;
  std::vector<double> time;                       ///< s, strictly increasing.
  std::vector<double> am, pm, al, pl;             ///< Load cells, N (anterior/posterior x medial/lateral).
  std::vector<double> medial, lateral, total;     ///< Compartment forces by equation 4 and their sum, N.
  std::vector<double> goniometer, grfz;           ///< As in the file (NaN if the file lacks the column).
  KneeForceCoefficients coefficients;             ///< The coefficients medial/lateral were computed with.

  /// Number of samples.
  int getNumSamples() const { return int(time.size()); }
};

/// Reads a knee-force CSV (any line ends, trailing commas) and converts the load cells from
/// pound-force to newtons. The time column is the first whose name starts with "time" (any
/// case); PM, AM, AL and PL are required (names compared ignoring case); GON and GRFz (or
/// GRF) are optional. Throws InputError naming the file and the missing column, a non-number,
/// or a time that does not increase.
KneeForces readKneeForces(const std::string& path,
                          const KneeForceCoefficients& coefficients = KneeForceCoefficients::defaults());

/// Computes medial, lateral and total from the load cells of @p forces with @p coefficients.
void calcCompartmentForces(KneeForces& forces, const KneeForceCoefficients& coefficients);

/// Linear interpolation of every channel at @p times. A requested time up to half a sample
/// interval outside the data takes the end value (the recordings' clocks differ from the C3D's
/// by a fraction of a frame); further outside it gets NaN. Throws InputError naming both
/// ranges if no requested time lies within the data.
KneeForces resampleKneeForces(const KneeForces& forces, const std::vector<double>& times);

/// Re-times @p forces so that row i is at the time of C3D frame first_frame + i, that is
/// (first_frame + i - 1) / rate. Throws InputError if the file's own times differ from those by
/// more than half a frame (the file does not belong to that trial).
KneeForces retimeToFrames(const KneeForces& forces, int first_frame, double rate);

}  // namespace kneesim::io
