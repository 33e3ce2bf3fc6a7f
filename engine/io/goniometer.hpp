#pragma once
// The eKnee goniometer (column GON of the knee-force CSV, analog channel "goniometer" of the C3D)
// turned into the model's knee flexion: ONE calibration, used by the workflow's goniometer trials
// and by the gap diagnosis.
//
// Two steps, because JW's files hold two different quantities:
//  1. Volts -> goniometer degrees. GON is in volts in jw_stairupf1 and jw_chairrise1 (5.3-7.8;
//     in stairupf1 it is the C3D's analog goniometer channel, gain 1.007, r = 0.998) and in degrees
//     in jw_ngait_og3, where the data provider converted it: ngait_og3's GON = 38.1828 V - 200.218
//     against its C3D goniometer channel (r = 0.996, 1.7 deg RMS; 1.0 deg with the one-frame offset
//     of the two recordings). That line is the instrument's calibration as the provider applied it.
//  2. Goniometer degrees -> the model's knee_flexion. A goniometer measures the angle between two
//     end blocks strapped to the skin of thigh and shank; the model's coordinate is the angle
//     between its femur and tibia frames found by IK. On every JW trial with markers the IK flexion
//     is 1.09-1.22 times the goniometer's angle, 2.6-4.8 deg lower at extension (ngait_og1, og3,
//     og7 1.10-1.13; stairupf1 1.21). The contact geometry is evaluated at the model's coordinate,
//     so the flexion must be in the model's terms: knee_flexion = offset + gain x goniometer degrees,
//     fitted by least squares on trials that have both (fitGoniometerCalibration).
// Defaults: JW's line pooled over ngait_og3 and stairupf1 (the paper workflow's IK trials), which
// the workflow test recomputes from the data.

#include <string>
#include <vector>

#include "core/error.hpp"

namespace kneesim::io {

/// The data provider's conversion of JW's goniometer from volts to degrees (from ngait_og3: its CSV's
/// GON in degrees against its C3D's goniometer channel in volts).
constexpr double kJwGoniometerDegreesPerVolt = 38.1828;
constexpr double kJwGoniometerOffsetDeg = -200.218;

/// How a goniometer signal becomes the model's knee flexion.
struct GoniometerCalibration {
  /// Step 1 (for signals in volts): goniometer degrees = volts_gain * V + volts_offset_deg.
  double volts_gain = kJwGoniometerDegreesPerVolt;
  double volts_offset_deg = kJwGoniometerOffsetDeg;
  /// Step 2: knee flexion (deg) = offset_deg + gain * goniometer degrees. Default: JW, ngait_og3 and
  /// stairupf1 pooled (907 frames, r = 0.987, 3.8 deg RMS).
  double gain = 1.1742;
  double offset_deg = -4.437;
  /// "auto" (volts when every finite value lies within 3-10 and they span less than 5), "volts" or
  /// "degrees": the unit of the signal given to calcKneeFlexionDeg.
  std::string units = "auto";
  /// Statistics of the fit that produced gain and offset (NaN/0 when given by hand).
  double r = 0, rms_deg = 0;
  int frames = 0;
  std::string source = "JW default (ngait_og3 and stairupf1, IK knee_flexion on goniometer degrees)";

  /// Knee flexion (deg) of a goniometer reading in degrees.
  double calcFlexionDeg(double goniometer_deg) const { return offset_deg + gain * goniometer_deg; }
};

/// True when @p gon looks like volts (every finite value within 3-10, span under 5, at least one
/// finite value): JW's raw goniometer. A knee flexing through 5 degrees or more in degrees fails it.
bool isGoniometerInVolts(const std::vector<double>& gon);

/// Whether @p gon is taken as volts under @p calibration's units ("auto" detects).
bool usesVolts(const std::vector<double>& gon, const GoniometerCalibration& calibration);

/// @p gon in goniometer degrees: converted by step 1 when in volts, else as given.
std::vector<double> toGoniometerDegrees(const std::vector<double>& gon, const GoniometerCalibration& calibration);

/// The model's knee flexion in degrees from a goniometer signal (volts or degrees): steps 1 and 2.
/// NaN stays NaN. When @p note is given it receives one plain sentence saying what was done.
std::vector<double> calcKneeFlexionDeg(const std::vector<double>& gon, const GoniometerCalibration& calibration,
                                       std::string* note = nullptr);

/// One trial's goniometer (volts or degrees, as recorded) and the reference knee flexion (deg, e.g.
/// IK) at the same frames.
struct GoniometerPairs {
  std::string trial;
  std::vector<double> goniometer;
  std::vector<double> flexion_deg;
};

/// Step 2 fitted by least squares over the finite pairs of all @p trials pooled (each goniometer
/// converted to degrees by @p base's step 1, per trial as its units say); returns @p base with
/// gain, offset, r, rms, frames and source set. Throws InputError at @p where with fewer than 10
/// pairs or no spread of the goniometer.
GoniometerCalibration fitGoniometerCalibration(const std::vector<GoniometerPairs>& trials,
                                               const GoniometerCalibration& base = {},
                                               const SourceLocation& where = {});

}  // namespace kneesim::io
