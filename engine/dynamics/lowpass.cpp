#include "dynamics/lowpass.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/error.hpp"
#include "dynamics/natural_spline.hpp"

namespace kneesim::dynamics {

std::vector<double> padOddReflection(const std::vector<double>& x, int pad) {
  const int n = int(x.size());
  KNEESIM_CHECK(pad >= 0 && pad < n, "padding longer than the signal");
  std::vector<double> s(size_t(n + 2 * pad));
  for (int i = 0, j = pad; i < pad; ++i, --j) s[i] = 2.0 * x[0] - x[j];
  for (int i = 0; i < n; ++i) s[pad + i] = x[i];
  for (int i = pad + n, j = n - 2; i < 2 * pad + n; ++i, --j) s[i] = 2.0 * x[n - 1] - x[j];
  return s;
}

std::vector<double> lowpassIIR(const std::vector<double>& x, double dt, double cutoff_hz) {
  const int n = int(x.size());
  KNEESIM_CHECK(dt > 0 && n >= 4, "low-pass filter needs a positive step and four samples");
  const double fs = 1.0 / dt;
  if (cutoff_hz >= 0.5 * fs) cutoff_hz = 0.49 * fs;
  const double wa = std::tan(2.0 * M_PI * cutoff_hz * dt / 2.0);
  const double wa2 = wa * wa, wa3 = wa2 * wa;
  const double denom = (wa + 1) * (wa2 + wa + 1.0);
  const double a0 = wa3 / denom, a1 = 3 * wa3 / denom, a2 = 3 * wa3 / denom, a3 = wa3 / denom;
  const double b1 = (3 * wa3 + 2 * wa2 - 2 * wa - 3) / denom;
  const double b2 = (3 * wa3 - 2 * wa2 - 2 * wa + 3) / denom;
  const double b3 = (wa - 1) * (wa2 - wa + 1) / denom;
  auto pass = [&](const std::vector<double>& in) {
    std::vector<double> out(in.begin(), in.begin() + 3);
    out.resize(in.size());
    for (int i = 3; i < n; ++i)
      out[i] = a0 * in[i] + a1 * in[i - 1] + a2 * in[i - 2] + a3 * in[i - 3] - b1 * out[i - 1] - b2 * out[i - 2] -
               b3 * out[i - 3];
    std::reverse(out.begin(), out.end());
    return out;
  };
  return pass(pass(x));
}

void padTable(SampledTable& table, int pad) {
  if (pad <= 0) return;
  table.time = padOddReflection(table.time, pad);
  for (auto& c : table.columns) c = padOddReflection(c, pad);
}

void lowpassTable(SampledTable& table, double cutoff_hz) {
  const int n = int(table.time.size());
  if (n < 4) throw std::invalid_argument("expected at least 4 samples to filter, got " + std::to_string(n));
  double dt_min = std::numeric_limits<double>::infinity();
  for (int i = 1; i < n; ++i) {
    const double dt = table.time[i] - table.time[i - 1];
    if (!(dt > 0))
      throw std::invalid_argument("expected strictly increasing times, got " + std::to_string(table.time[i - 1]) +
                                  " then " + std::to_string(table.time[i]));
    dt_min = std::min(dt_min, dt);
  }
  const double dt_mean = (table.time.back() - table.time.front()) / (n - 1);
  if (dt_mean - dt_min > std::numeric_limits<double>::epsilon()) {
    const NaturalSplineFitter fitter(table.time, 5);
    std::vector<double> t;
    for (double x = table.time.front(); x <= table.time.back(); x += dt_min) t.push_back(x);
    for (auto& c : table.columns) {
      const NaturalSpline s = fitter.fit(c);
      c.resize(t.size());
      for (size_t i = 0; i < t.size(); ++i) c[i] = s.calcValue(t[i]);
    }
    table.time = std::move(t);
    if (table.time.size() < 4) throw std::invalid_argument("expected at least 4 samples to filter after resampling");
  }
  for (auto& c : table.columns) c = lowpassIIR(c, dt_min, cutoff_hz);
}

}  // namespace kneesim::dynamics
