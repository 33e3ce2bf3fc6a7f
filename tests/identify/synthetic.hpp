#pragma once
// Synthetic trials for identification tests: a stance-phase contact-area curve and the force a
// known law gives on it, optionally with seeded Gaussian noise.

#include <cmath>
#include <random>
#include <string>

#include "identify/trial.hpp"

namespace kneesim::identify::test {

/// Contact area (m^2) over a 1.2 s gait cycle at 120 Hz: two stance humps (loading response and
/// push-off, peaks near 1000 mm^2 as in Dao & Pouletaut's figure 7) on a 100 mm^2 swing baseline.
inline double gaitArea(double t, double shift = 0.0) {
  const auto bump = [](double x, double c, double w) { return std::exp(-((x - c) / w) * ((x - c) / w)); };
  return 1e-6 * (100 + 800 * bump(t, 0.15 + shift, 0.08) + 900 * bump(t, 0.45 + shift, 0.09) +
                 250 * bump(t, 0.30 + shift, 0.12));
}

/// Hertz force of Dao & Pouletaut's equation 2 written out independently of the plugin.
inline double hertzForce(double s, double k, double r) { return 2.0 / (3.0 * r) * k * std::pow(s / M_PI, 1.5); }

/// A 1.2 s trial at 120 Hz with channels S, S_medial (55 %), S_lateral (45 %) and measured force
/// force(S) + N(0, sigma^2) noise from seed.
template <class ForceOfArea>
Trial makeTrial(const std::string& name, ForceOfArea force, double sigma = 0.0, unsigned seed = 1,
                double shift = 0.0) {
  Trial t;
  t.name = name;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int i = 0; i < 144; ++i) {
    const double time = i / 120.0;
    const double s = gaitArea(time, shift);
    t.time.push_back(time);
    t.channels["S"].push_back(s);
    t.channels["S_medial"].push_back(0.55 * s);
    t.channels["S_lateral"].push_back(0.45 * s);
    t.measured_force.push_back(force(s) + (sigma > 0 ? sigma * noise(rng) : 0.0));
  }
  return t;
}

}  // namespace kneesim::identify::test
