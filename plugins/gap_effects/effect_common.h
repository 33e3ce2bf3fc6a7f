/* Helpers shared by the gap-effect catalogue's source files (internal to the gap_effects plugin). */
#ifndef KNEESIM_GAP_EFFECTS_COMMON_H
#define KNEESIM_GAP_EFFECTS_COMMON_H

#include <stdio.h>
#include <string.h>

#include "plugin/kneesim_plugin.h"

static inline const double* find_channel(const kneesim_inputs* in, const char* name) {
  for (int c = 0; c < in->n_channels; ++c)
    if (strcmp(in->names[c], name) == 0) return in->values[c];
  return NULL;
}

/* Looks up a channel the effect listed; the engine checks them, this only guards against misuse. */
#define NEED(var, name)                                                        \
  const double* var = find_channel(in, name);                                  \
  if (!var) {                                                                  \
    snprintf(err, (size_t)err_len, "input channel '%s' is missing", name);     \
    return 1;                                                                  \
  }

/* For an additive force term d force_i / d base_i is 1: tangents pass through unchanged. */
static inline void pass_tangents(int n, int n_tangents, const double* tin, double* tout) {
  if (n_tangents > 0) memcpy(tout, tin, sizeof(double) * (size_t)n_tangents * (size_t)n);
}

#define N_OF(a) ((int)(sizeof(a) / sizeof((a)[0])))
#define MAP_EFFECT(nm, desc, params, inputs, fn, phys, sep) \
  {sizeof(kneesim_effect), nm, desc, N_OF(params), params, N_OF(inputs), inputs, 0, NULL, NULL, fn, phys, sep}

/* Registers the effects of motion_load_effects.c (direction, load x flexion, either foot's GRF and its
 * components, drift over a trial); returns 0 or the 1-based index of the table that was refused. */
__attribute__((visibility("hidden"))) int kneesim_gap_register_motion_load_effects(const kneesim_registrar* r);

#endif
