#pragma once
// INTERIM CONTACT AREAS -- NOT THE CONTACT-AREA TOOL'S OUTPUT, NOT REAL-DATA RESULTS.
//
// Until the contact-area tool (issue 4) writes its per-trial .sto files, the gap diagnosis and its
// synthetic test suite need contact areas with a realistic shape. This file makes a stand-in:
// each compartment's area is the Hertz law INVERTED on the smoothed MEASURED compartment force,
//
//     S_c = pi (3 R F_c / (2 K))^(2/3),
//
// multiplied by a smooth random perturbation (so the area is not an exact function of the force),
// with areas at other proximity thresholds from a paraboloid gap, S_c(h) = S_c + 2 pi R_eff (h - 4 mm)
// (R_eff varying smoothly over time by a random factor exp(0.3 xi_r)),
// and a sensitivity to an anterior-posterior shift of the femur, dS_dap = S k_ap xi(t) with xi a
// smooth random signal of unit SD (the real one needs the contact-area tool).
// Because it is built from the measured force, a diagnosis run on these areas says nothing about
// the real sim-to-real gap; its only use is to drive the synthetic trials (gap/synth.hpp) and
// tests. Files written from it carry the header line kneesim_interim=true, the trial assembler
// marks such trials, and every report made from them says so in its first line.

#include "io/knee_forces.hpp"
#include "io/storage.hpp"

namespace kneesim::gap::interim {

/// Settings of the interim areas (defaults give peaks near the paper's 1000-1100 mm^2).
struct InterimAreaOptions {
  double modulus = 2.5e7;        ///< K (Pa) of the inverted Hertz law.
  double radius = 0.037;         ///< R (m), the paper's.
  double gap_radius = 0.02;      ///< R_eff (m) of the paraboloid giving the S@<x>mm channels.
  double min_force = 30;         ///< Compartment forces below this (N) are held at it before inverting.
  double cutoff = 8;             ///< Low-pass of the measured force before inverting (Hz).
  double perturbation = 0.05;    ///< Relative SD of the smooth random factor on each compartment's area.
  double perturbation_time = 0.1;  ///< Its correlation time (s).
  double ap_sensitivity = 50;    ///< k_ap (1/m): relative area change per metre of AP shift (SD).
  unsigned seed = 1;
};

/// The stand-in contact-area table for @p forces (columns time, S, S_medial, S_lateral, dmin,
/// dmin_medial, dmin_lateral, S@2mm, S@3mm, S@5mm, S@6mm, dS_dap; header kneesim_interim=true and
/// threshold=0.004). Not real contact areas: see the file comment.
io::Storage makeInterimContactAreas(const io::KneeForces& forces, const InterimAreaOptions& options = {});

}  // namespace kneesim::gap::interim
