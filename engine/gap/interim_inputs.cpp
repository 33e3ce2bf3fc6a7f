#include "gap/interim_inputs.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include "gap/signals.hpp"

namespace kneesim::gap::interim {

namespace {

// Smooth zero-mean noise of unit SD and correlation time `tau` (low-passed white noise).
std::vector<double> smoothNoise(int n, double rate, double tau, std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> w(n);
  for (double& x : w) x = g(rng);
  const double fc = std::min(1.0 / (2 * M_PI * tau), 0.45 * rate);
  std::vector<double> s = lowPass(w, rate, fc);
  double ss = 0;
  for (double x : s) ss += x * x;
  const double sd = std::sqrt(ss / std::max(1, n));
  for (double& x : s) x = sd > 0 ? x / sd : 0.0;
  return s;
}

}  // namespace

io::Storage makeInterimContactAreas(const io::KneeForces& forces, const InterimAreaOptions& o) {
  const int n = forces.getNumSamples();
  const std::vector<double>& t = forces.time;
  const double rate = n > 1 ? (n - 1) / (t.back() - t.front()) : 120.0;
  std::mt19937_64 rng(o.seed);
  io::Storage s;
  s.name = "interim_contact_areas";
  s.labels = {"time", "S", "S_medial", "S_lateral", "dmin", "dmin_medial", "dmin_lateral",
              "S@2mm", "S@3mm", "S@5mm", "S@6mm", "dS_dap"};
  s.data.resize(n, static_cast<Eigen::Index>(s.labels.size()));
  std::ostringstream method;
  method << "Hertz inverted on the measured compartment force low-passed at " << o.cutoff << " Hz, K=" << o.modulus
         << " Pa, R=" << o.radius << " m, smooth perturbation " << o.perturbation << " (tau " << o.perturbation_time
         << " s, seed " << o.seed << ")";
  s.header = {{"kneesim_interim", "true"},
              {"interim_warning", "NOT the contact-area tool's output: derived from the measured force"},
              {"interim_method", method.str()},
              {"threshold", "0.004"}};
  const double cutoff = std::min(o.cutoff, 0.45 * rate);
  std::vector<double> sc[2], dmin[2], sh[2][4];
  const double thresholds[4] = {0.002, 0.003, 0.005, 0.006};
  for (int c = 0; c < 2; ++c) {
    std::vector<double> f = lowPass(c == 0 ? forces.medial : forces.lateral, rate, cutoff);
    const std::vector<double> xi = smoothNoise(n, rate, o.perturbation_time, rng);
    // The gap's curvature radius varies over time (conformity changes with flexion in a real
    // multi-radius component), so S@<x>mm is not S plus a constant.
    const std::vector<double> xr = smoothNoise(n, rate, 0.3, rng);
    sc[c].resize(n);
    dmin[c].resize(n);
    for (int k = 0; k < 4; ++k) sh[c][k].resize(n);
    for (int i = 0; i < n; ++i) {
      const double fc = std::max(f[i], o.min_force);
      const double area = M_PI * std::pow(3 * o.radius * fc / (2 * o.modulus), 2.0 / 3.0) *
                          std::max(0.2, 1 + o.perturbation * xi[i]);
      sc[c][i] = area;
      const double per_m = 2 * M_PI * o.gap_radius * std::exp(0.3 * xr[i]);  // area per metre of threshold
      dmin[c][i] = 0.004 - area / per_m;
      for (int k = 0; k < 4; ++k) sh[c][k][i] = std::max(0.0, area + per_m * (thresholds[k] - 0.004));
    }
  }
  const std::vector<double> xi_ap = smoothNoise(n, rate, 0.3, rng);
  for (int i = 0; i < n; ++i) {
    s.data(i, 0) = t[i];
    s.data(i, 1) = sc[0][i] + sc[1][i];
    s.data(i, 2) = sc[0][i];
    s.data(i, 3) = sc[1][i];
    s.data(i, 4) = std::min(dmin[0][i], dmin[1][i]);
    s.data(i, 5) = dmin[0][i];
    s.data(i, 6) = dmin[1][i];
    for (int k = 0; k < 4; ++k) s.data(i, 7 + k) = sh[0][k][i] + sh[1][k][i];
    s.data(i, 11) = s.data(i, 1) * o.ap_sensitivity * xi_ap[i];
  }
  return s;
}

}  // namespace kneesim::gap::interim
