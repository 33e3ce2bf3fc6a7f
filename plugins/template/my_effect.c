/* A kneesim gap-diagnosis effect in one file: copy it, rename the effect, build it beside my_law.c
 * (see CMakeLists.txt), and name its plugin in a <GapTool> setup file. The diagnosis then screens,
 * fits and ranks it with the shipped catalogue (plugins/gap_effects/).
 *
 * The effect here is a load-cell drift, a force growing linearly over the recording:
 *
 *     F = F_base + rate * (t - t_first)
 *
 * An effect is a NESTED extension of whichever baseline law the user chose: with every parameter at
 * its default_value (rate = 0 here) the force must be the baseline's exactly.
 *
 * Two optional stages (plugin/kneesim_plugin.h has the full contract):
 *  - rewrite_inputs: new values of input channels before the baseline law sees them (a flexion
 *    offset changes the area). The engine differentiates it numerically.
 *  - map_force (used here): the baseline force of the whole trial -> the effect's force. It also
 *    maps the "tangents" (derivatives of the baseline force with respect to the other parameters)
 *    the way its own derivative with respect to the baseline force says: for an additive term
 *    like this one that derivative is 1, so tangents pass through unchanged. dforce receives the
 *    exact derivative with respect to the effect's own parameters.
 * SI units; one line into err and a non-zero return on bad input; static tables.
 */
#include <stdio.h>
#include <string.h>

#include "plugin/kneesim_plugin.h"

/* name, unit, lower, upper, default (= no effect), typical scale, fixed by default, description */
static const kneesim_param params[] = {
    {"rate", "N/s", -500.0, 500.0, 0.0, 10.0, 0, "drift of the load cells"},
};

static const char* const inputs[] = {"time"};

static int map_force(const double* p, const kneesim_inputs* in, const double* base, int n_tangents,
                     const double* tangent_in, double* force, double* tangent_out, double* dforce, char* err,
                     int err_len) {
  const double* t = NULL;
  for (int c = 0; c < in->n_channels; ++c)
    if (strcmp(in->names[c], "time") == 0) t = in->values[c];
  if (!t) {
    snprintf(err, (size_t)err_len, "input channel 'time' is missing");
    return 1;
  }
  const int n = in->n_frames;
  for (int i = 0; i < n; ++i) {
    force[i] = base[i] + p[0] * (t[i] - t[0]);
    if (dforce) dforce[i] = t[i] - t[0]; /* d force / d rate */
  }
  /* d force_i / d base_j is 1 when i == j: tangents pass through */
  if (n_tangents > 0) memcpy(tangent_out, tangent_in, sizeof(double) * (size_t)n_tangents * (size_t)n);
  return 0;
}

static const kneesim_effect effect = {
    sizeof(kneesim_effect),
    "drift", /* the name setup files and reports use; unique across loaded effects */
    "F = F_base + rate (t - t_first)",
    1, params,
    1, inputs,
    0, NULL, NULL, /* no rewrite_inputs stage */
    map_force,
    "the load cells drift during a recording",               /* physics, for reports */
    "a static trial with a known load before and after", /* what data would tell it apart */
};

KNEESIM_PLUGIN_EXPORT int kneesim_plugin_register(const kneesim_registrar* r) {
  if (r->abi_version < 2) return -1; /* add_effect arrived with ABI version 2 */
  return r->add_effect(r->host, &effect);
}
