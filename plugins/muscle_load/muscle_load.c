/* The gap-diagnosis effect muscle_load (issue 19): the musculoskeletal knee force as a candidate
 * load term and, at gain 1, as an alternative baseline:
 *
 *   muscle_load   gain (0), 0..1.5
 *                 F = F_base + gain * (knee_muscle_total - F_base)
 *
 * knee_muscle_total is the compressive force on the tibial component from static optimization and
 * the knee's joint reaction (the knee contact workflow's <MuscleChain>, docs/jw_muscle_chain.md); on
 * the medial and lateral targets the diagnosis hands over the chain's split of it under this name
 * (knee_muscle_medial, knee_muscle_lateral of <trial>_knee_loads_muscles.sto; gap::makeTargetTrial):
 * gain 0 gives the baseline back, gain 1 replaces it by the muscle-driven estimate, a fitted gain
 * between says how far the measured force leans towards the muscles. A plugin of its own, not part
 * of gap_effects' catalogue: a gap setup that tests it loads it (share/gap/jw_gap_muscle.xml).
 */
#include <stdio.h>
#include <string.h>

#include "plugin/kneesim_plugin.h"

static const kneesim_param muscle_load_params[] = {
    {"gain", "1", 0.0, 1.5, 0.0, 0.3, 0, "share of the way from the baseline to the musculoskeletal force"},
};
static const char* const muscle_load_inputs[] = {"knee_muscle_total"};

static int muscle_load_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                           double* force, double* tout, double* dforce, char* err, int err_len) {
  const double* m = NULL;
  for (int c = 0; c < in->n_channels; ++c)
    if (strcmp(in->names[c], muscle_load_inputs[0]) == 0) m = in->values[c];
  if (!m) {
    snprintf(err, (size_t)err_len, "input channel '%s' is missing", muscle_load_inputs[0]);
    return 1;
  }
  const int n = in->n_frames;
  const double g = p[0];
  for (int i = 0; i < n; ++i) {
    force[i] = base[i] + g * (m[i] - base[i]);
    if (dforce) dforce[i] = m[i] - base[i];
  }
  for (int k = 0; k < nt; ++k)
    for (int i = 0; i < n; ++i) tout[k * n + i] = (1.0 - g) * tin[k * n + i];
  return 0;
}

static const kneesim_effect muscle_load_effect = {
    sizeof(kneesim_effect),
    "muscle_load",
    "F = F_base + gain (F_muscles - F_base) (static optimization and the knee's joint reaction)",
    1,
    muscle_load_params,
    1,
    muscle_load_inputs,
    0,
    NULL,
    NULL,
    muscle_load_map,
    "the muscles' pull, which static optimization estimates from the motion and the ground reaction, presses "
    "the components together beyond what the contact area shows",
    "EMG against the estimated muscle forces; activities where the muscles co-contract without a net knee "
    "moment"};

KNEESIM_PLUGIN_EXPORT int kneesim_plugin_register(const kneesim_registrar* r) {
  if (r->abi_version < 2) return -1; /* add_effect arrived with ABI version 2 */
  return r->add_effect(r->host, &muscle_load_effect) ? 1 : 0;
}
