/* A kneesim contact law in one file: copy this folder, rename the law, build it against the installed
 * kneesim package (see CMakeLists.txt beside this file), and name it in a setup file.
 *
 * The law here is the simplest useful one, a mean contact pressure:
 *
 *     F = p * S + F0
 *
 * with the contact area S (m^2) as input, the mean pressure p (Pa) as the parameter to identify and an
 * offset F0 (N) that is held at 0 unless the setup frees it. Replace calc_force, the parameter table
 * and the input list with your own; keep the rest.
 *
 * Rules (plugin/kneesim_plugin.h has the full contract):
 *  - SI units in and out: m^2, m, N, rad, s, Pa.
 *  - calc_force fills force[i] for every frame and, when dforce is not NULL, the exact derivatives
 *    dforce[p * n_frames + i] = dF_i / dparam_p for every parameter p (the identification uses them
 *    for its gradient and Gauss-Newton Hessian; kneesim::identify::calcDerivativeError checks them).
 *  - On bad input write ONE line into err and return non-zero; never abort or print.
 *  - Everything handed to add_contact_law must be static: the engine keeps pointers to it.
 */
#include <stdio.h>
#include <string.h>

#include "plugin/kneesim_plugin.h"

/* name, unit, lower, upper, default, typical scale, fixed by default, description */
static const kneesim_param params[] = {
    {"p", "Pa", 0.0, 1e9, 2e6, 1e6, 0, "mean contact pressure"},
    {"F0", "N", -1e4, 1e4, 0.0, 100.0, 1, "force offset (load-cell bias)"},
};

/* Channels the law reads; the engine checks they exist before calling calc_force. */
static const char* const inputs[] = {"S"};

static int calc_force(const double* p, const kneesim_inputs* in, double* force, double* dforce, char* err,
                      int err_len) {
  const double* s = NULL;
  for (int c = 0; c < in->n_channels; ++c)
    if (strcmp(in->names[c], "S") == 0) s = in->values[c];
  if (!s) {
    snprintf(err, (size_t)err_len, "input channel 'S' is missing");
    return 1;
  }
  const int n = in->n_frames;
  for (int i = 0; i < n; ++i) {
    force[i] = p[0] * s[i] + p[1];
    if (dforce) {
      dforce[0 * n + i] = s[i]; /* dF/dp  */
      dforce[1 * n + i] = 1.0;  /* dF/dF0 */
    }
  }
  return 0;
}

static const kneesim_contact_law law = {
    sizeof(kneesim_contact_law),
    "my_law", /* the law name setup files refer to; unique across loaded plugins */
    "mean contact pressure: F = p S + F0",
    2, params,
    1, inputs,
    calc_force,
    0, NULL, NULL, NULL, /* no derived quantities */
};

KNEESIM_PLUGIN_EXPORT int kneesim_plugin_register(const kneesim_registrar* r) {
  if (r->abi_version < KNEESIM_PLUGIN_ABI_VERSION) return -1; /* an engine older than this plugin's header */
  return r->add_contact_law(r->host, &law);
}
