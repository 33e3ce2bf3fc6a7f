#include "io/knee_forces.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "io/csv.hpp"

namespace kneesim::io {

namespace {

std::string listColumns(const CsvTable& t) {
  std::string s;
  for (const auto& l : t.labels) s += (s.empty() ? "" : ", ") + l;
  return s;
}

std::string formatRange(double a, double b) {
  std::ostringstream os;
  os.precision(6);
  os << std::fixed << a << " to " << b << " s";
  return os.str();
}

}  // namespace

void calcCompartmentForces(KneeForces& f, const KneeForceCoefficients& c) {
  const size_t n = f.time.size();
  f.coefficients = c;
  f.medial.resize(n);
  f.lateral.resize(n);
  f.total.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const double cell[4] = {f.am[i], f.pm[i], f.al[i], f.pl[i]};
    double med = 0, lat = 0;
    for (int k = 0; k < 4; ++k) {
      med += c.medial[k] * cell[k];
      lat += c.lateral[k] * cell[k];
    }
    f.medial[i] = med;
    f.lateral[i] = lat;
    f.total[i] = med + lat;
  }
}

KneeForces readKneeForces(const std::string& path, const KneeForceCoefficients& coefficients) {
  const CsvTable t = readCsv(path);
  int time_col = -1;
  for (size_t i = 0; i < t.labels.size() && time_col < 0; ++i)
    if (startsWith(toLower(trim(t.labels[i])), "time")) time_col = int(i);
  if (time_col < 0)
    throw InputError({path, 1, "Time(sec)"}, "expected a time column (a name starting with 'Time'), got columns " + listColumns(t));
  auto require = [&](const char* name) {
    const int c = t.findColumnIgnoreCase(name);
    if (c < 0)
      throw InputError({path, 1, name}, std::string("expected the load-cell column '") + name +
                                            "' (PM, AM, AL, PL are required), got columns " + listColumns(t));
    return c;
  };
  const int c_pm = require("PM"), c_am = require("AM"), c_al = require("AL"), c_pl = require("PL");
  const int c_gon = t.findColumnIgnoreCase("GON");
  int c_grf = t.findColumnIgnoreCase("GRFz");
  if (c_grf < 0) c_grf = t.findColumnIgnoreCase("GRF");  // chairrise1 names it so

  KneeForces f;
  f.source_file = path;
  const Eigen::Index n = t.data.rows();
  auto column = [&](int c, double scale) {
    std::vector<double> v(size_t(n), std::numeric_limits<double>::quiet_NaN());
    if (c >= 0)
      for (Eigen::Index r = 0; r < n; ++r) v[size_t(r)] = t.data(r, c) * scale;
    return v;
  };
  f.time = column(time_col, 1.0);
  for (Eigen::Index r = 0; r < n; ++r) {
    const double ti = f.time[size_t(r)];
    if (!std::isfinite(ti) || (r > 0 && !(ti > f.time[size_t(r - 1)])))
      throw InputError({path, 0, t.labels[size_t(time_col)] + "[row " + std::to_string(r + 1) + "]"},
                       "expected strictly increasing times, got " + std::to_string(ti) +
                           (r > 0 ? " after " + std::to_string(f.time[size_t(r - 1)]) : std::string()));
  }
  f.pm = column(c_pm, kNewtonsPerPoundForce);
  f.am = column(c_am, kNewtonsPerPoundForce);
  f.al = column(c_al, kNewtonsPerPoundForce);
  f.pl = column(c_pl, kNewtonsPerPoundForce);
  f.goniometer = column(c_gon, 1.0);
  f.grfz = column(c_grf, 1.0);
  calcCompartmentForces(f, coefficients);
  return f;
}

KneeForces resampleKneeForces(const KneeForces& f, const std::vector<double>& times) {
  const size_t n = f.time.size();
  if (n == 0) throw InputError({f.source_file, 0, ""}, "expected knee-force samples to resample, the table is empty");
  const double t0 = f.time.front(), t1 = f.time.back();
  const double half = n > 1 ? 0.5 * (t1 - t0) / double(n - 1) : 0.0;
  KneeForces out;
  out.source_file = f.source_file;
  out.coefficients = f.coefficients;
  out.time = times;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> KneeForces::*const channels[] = {&KneeForces::am, &KneeForces::pm, &KneeForces::al,
                                                        &KneeForces::pl, &KneeForces::medial, &KneeForces::lateral,
                                                        &KneeForces::total, &KneeForces::goniometer, &KneeForces::grfz};
  for (auto ch : channels) {
    (out.*ch).assign(times.size(), nan);
  }
  size_t inside = 0;
  for (size_t k = 0; k < times.size(); ++k) {
    const double t = times[k];
    if (!(t >= t0 - half && t <= t1 + half)) continue;  // also rejects NaN
    ++inside;
    size_t hi;
    double a;
    if (t <= t0) {
      hi = 0;
      a = 1;
    } else if (t >= t1) {
      hi = n - 1;
      a = 1;
    } else {
      hi = size_t(std::upper_bound(f.time.begin(), f.time.end(), t) - f.time.begin());
      const size_t lo = hi - 1;
      a = (t - f.time[lo]) / (f.time[hi] - f.time[lo]);
    }
    const size_t lo = hi > 0 ? hi - 1 : 0;
    for (auto ch : channels) {
      const std::vector<double>& src = f.*ch;
      (out.*ch)[k] = (a == 1) ? src[hi] : (1 - a) * src[lo] + a * src[hi];
    }
  }
  if (inside == 0) {
    const double r0 = times.empty() ? 0 : *std::min_element(times.begin(), times.end());
    const double r1 = times.empty() ? 0 : *std::max_element(times.begin(), times.end());
    throw InputError({f.source_file, 0, ""}, "requested times " + formatRange(r0, r1) +
                                                 " do not overlap the knee-force data " + formatRange(t0, t1));
  }
  return out;
}

KneeForces retimeToFrames(const KneeForces& f, int first_frame, double rate) {
  KNEESIM_CHECK(rate > 0, "retimeToFrames: rate must be positive");
  KneeForces out = f;
  for (size_t i = 0; i < f.time.size(); ++i) {
    const double t = (double(first_frame) + double(i) - 1.0) / rate;
    if (std::fabs(t - f.time[i]) > 0.5 / rate)
      throw InputError({f.source_file, 0, "row " + std::to_string(i + 1)},
                       "expected a time within half a frame of C3D frame " + std::to_string(first_frame + int(i)) +
                           " (" + std::to_string(t) + " s at " + std::to_string(rate) + " Hz), got " +
                           std::to_string(f.time[i]) + " s: does this file belong to that trial?");
    out.time[i] = t;
  }
  return out;
}

}  // namespace kneesim::io
