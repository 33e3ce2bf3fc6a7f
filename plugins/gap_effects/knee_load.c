/* The gap-diagnosis effect knee_load (issue 18): part of the knee force follows the knee's net
 * moments from inverse dynamics, which the muscles must balance:
 *
 *   knee_load   flexion (0) N/(N m), adduction (0) N/(N m)
 *               F = F_base + flexion * knee_flexion_moment + adduction * knee_adduction_moment
 *
 * The channels are the net load the femoral component applies to the tibial component (without
 * muscles), in clinical terms (docs/inverse_dynamics.md). A flexion moment is carried by the
 * quadriceps or the hamstrings at a lever arm of a few centimetres, so each N m adds tens of
 * newtons of contact force; an adduction moment is balanced by the lateral structures and the
 * medial compartment. The net axial force is not a term: on JW's trials it follows the ground
 * reaction (correlation 0.997 of the force changes they make), which grf_load already tests, and
 * with it the two effects could not be told apart; it stays a signal of the where-analysis.
 * Registered with the catalogue in gap_effects.c.
 */
#include <stdio.h>
#include <string.h>

#include "plugin/kneesim_plugin.h"

static const kneesim_param knee_load_params[] = {
    /* 50 N/(N m) is a 2 cm lever arm: beyond the patellar tendon's and the hamstrings' (3-5 cm). */
    {"flexion", "N/(N m)", -50.0, 50.0, 0.0, 10.0, 0, "knee force per N m of net flexion moment"},
    {"adduction", "N/(N m)", -50.0, 50.0, 0.0, 10.0, 0, "knee force per N m of net adduction moment"},
};
static const char* const knee_load_inputs[] = {"knee_flexion_moment", "knee_adduction_moment"};

static int knee_load_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                         double* force, double* tout, double* dforce, char* err, int err_len) {
  const double* ch[2] = {NULL, NULL};
  for (int k = 0; k < 2; ++k) {
    for (int c = 0; c < in->n_channels; ++c)
      if (strcmp(in->names[c], knee_load_inputs[k]) == 0) ch[k] = in->values[c];
    if (!ch[k]) {
      snprintf(err, (size_t)err_len, "input channel '%s' is missing", knee_load_inputs[k]);
      return 1;
    }
  }
  const int n = in->n_frames;
  for (int i = 0; i < n; ++i) {
    force[i] = base[i] + p[0] * ch[0][i] + p[1] * ch[1][i];
    if (dforce)
      for (int k = 0; k < 2; ++k) dforce[k * n + i] = ch[k][i];
  }
  if (nt > 0) memcpy(tout, tin, sizeof(double) * (size_t)nt * (size_t)n);
  return 0;
}

/* Not static: gap_effects.c registers it after its own table (one plugin, one registration). */
const kneesim_effect kneesim_gap_effect_knee_load = {
    sizeof(kneesim_effect),
    "knee_load",
    "F = F_base + flexion M_flex + adduction M_add (net knee moments, inverse dynamics)",
    2,
    knee_load_params,
    2,
    knee_load_inputs,
    0,
    NULL,
    NULL,
    knee_load_map,
    "muscles balancing the knee's net flexion and adduction moments (inverse dynamics) press the components "
    "together beyond what the contact area shows",
    "EMG of the quadriceps and hamstrings; activities with the same ground reaction but other knee moments "
    "(stair ascent, chair rise, a forward trunk lean)"};
