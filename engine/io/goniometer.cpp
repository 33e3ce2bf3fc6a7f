#include "io/goniometer.hpp"

#include <cmath>

#include "core/strings.hpp"

namespace kneesim::io {

namespace {

std::string fmt(double v, int digits = 5) { return formatSignificant(v, digits); }

}  // namespace

bool isGoniometerInVolts(const std::vector<double>& gon) {
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (double x : gon)
    if (std::isfinite(x)) {
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
  return lo <= hi && lo >= 3 && hi <= 10 && hi - lo < 5;
}

bool usesVolts(const std::vector<double>& gon, const GoniometerCalibration& c) {
  if (c.units == "volts") return true;
  if (c.units == "degrees") return false;
  return isGoniometerInVolts(gon);
}

std::vector<double> toGoniometerDegrees(const std::vector<double>& gon, const GoniometerCalibration& c) {
  if (!usesVolts(gon, c)) return gon;
  std::vector<double> out(gon.size());
  for (size_t i = 0; i < gon.size(); ++i) out[i] = c.volts_gain * gon[i] + c.volts_offset_deg;
  return out;
}

std::vector<double> calcKneeFlexionDeg(const std::vector<double>& gon, const GoniometerCalibration& c,
                                       std::string* note) {
  const bool volts = usesVolts(gon, c);
  std::vector<double> out = toGoniometerDegrees(gon, c);
  for (double& x : out) x = c.calcFlexionDeg(x);
  if (note) {
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (double x : gon)
      if (std::isfinite(x)) lo = std::min(lo, x), hi = std::max(hi, x);
    std::string s = "knee flexion from the goniometer (" + fmt(lo, 4) + " to " + fmt(hi, 4) + (volts ? " V" : " deg") + "): ";
    if (volts) s += "goniometer deg = " + fmt(c.volts_gain, 6) + " V " + (c.volts_offset_deg < 0 ? "- " : "+ ") +
                    fmt(std::abs(c.volts_offset_deg), 6) + " (the provider's conversion), then ";
    s += "knee flexion = " + fmt(c.offset_deg, 4) + " + " + fmt(c.gain, 5) + " x goniometer deg (" + c.source;
    if (c.frames > 0) s += "; r = " + fmt(c.r, 4) + ", " + fmt(c.rms_deg, 3) + " deg RMS over " + std::to_string(c.frames) + " frames";
    s += ")";
    *note = s;
  }
  return out;
}

GoniometerCalibration fitGoniometerCalibration(const std::vector<GoniometerPairs>& trials,
                                               const GoniometerCalibration& base, const SourceLocation& where) {
  std::vector<double> x, y;
  std::string names;
  for (const GoniometerPairs& t : trials) {
    const std::vector<double> g = toGoniometerDegrees(t.goniometer, base);
    for (size_t i = 0; i < g.size() && i < t.flexion_deg.size(); ++i)
      if (std::isfinite(g[i]) && std::isfinite(t.flexion_deg[i])) {
        x.push_back(g[i]);
        y.push_back(t.flexion_deg[i]);
      }
    names += (names.empty() ? "" : ", ") + t.trial + (usesVolts(t.goniometer, base) ? " (volts)" : " (degrees)");
  }
  const size_t n = x.size();
  if (n < 10)
    throw InputError(where, "goniometer calibration on " + names + ": expected at least 10 frames with both a "
                            "goniometer value and a flexion, got " + std::to_string(n));
  double mx = 0, my = 0;
  for (size_t i = 0; i < n; ++i) mx += x[i] / double(n), my += y[i] / double(n);
  double sxx = 0, sxy = 0, syy = 0;
  for (size_t i = 0; i < n; ++i) {
    sxx += (x[i] - mx) * (x[i] - mx);
    sxy += (x[i] - mx) * (y[i] - my);
    syy += (y[i] - my) * (y[i] - my);
  }
  if (!(sxx > 0) || !(syy > 0))
    throw InputError(where, "goniometer calibration on " + names +
                                ": expected the goniometer and the flexion to vary, got a constant signal");
  GoniometerCalibration c = base;
  c.gain = sxy / sxx;
  c.offset_deg = my - c.gain * mx;
  c.r = sxy / std::sqrt(sxx * syy);
  double ss = 0;
  for (size_t i = 0; i < n; ++i) ss += std::pow(y[i] - c.offset_deg - c.gain * x[i], 2);
  c.rms_deg = std::sqrt(ss / double(n));
  c.frames = int(n);
  c.source = "fitted on " + names;
  return c;
}

}  // namespace kneesim::io
