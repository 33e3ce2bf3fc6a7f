/* Hertz contact laws after Dao & Pouletaut 2015, equations 2 and 3.
 *
 *   F = 2 / (3 R) * K * a^3,   a = sqrt(S / pi),   K = E / (1 - nu^2)
 *
 * S is the implant contact area of the frame (m^2), R the radius of the cylinder fitted to the
 * femoral component (m), E Young's modulus (Pa) and nu Poisson's ratio of the insert.
 *
 * R is a parameter, not an input channel: the paper assumes one constant radius (37 mm from its
 * cylinder fit, section 3.1), so it is held fixed at 0.037 m unless the setup file gives another
 * value or frees it. A per-frame radius would be a different law.
 *
 * Only K / R is determined by force data: E and nu enter through K alone and R only through K / R.
 * The derived quantities K and K_over_R are what an identification reports.
 *
 * Two laws:
 *   "hertz"     input S (total contact area), the paper's law;
 *   "hertz_ml"  inputs S_medial, S_lateral: one Hertz contact per compartment with the same K and R,
 *               F = 2 / (3 R) * K * (a_medial^3 + a_lateral^3).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "plugin/kneesim_plugin.h"

enum { P_E = 0, P_NU = 1, P_R = 2, N_PARAMS = 3 };

static const kneesim_param params[N_PARAMS] = {
    /* Lower bound 0, not a material floor: areas from a 4 mm proximity threshold are about ten times
     * the true contact, so identified moduli are MPa, and with a second force source in the law
     * (an effect such as grf_load) the data may want less; a 1 MPa floor bound JW's fits. */
    {"E", "Pa", 0.0, 1e12, 1e9, 1e9, 0,
     "Young's modulus of the insert (UHMWPE about 0.5-1.5 GPa; Dao & Pouletaut report 4.67 GPa)"},
    {"nu", "1", 0.0, 0.5, 0.45, 0.45, 0,
     "Poisson's ratio of the insert; not identifiable from force data (only K = E/(1-nu^2) is)"},
    {"R", "m", 1e-3, 1.0, 0.037, 0.037, 1,
     "radius of the cylinder fitted to the femoral component (Dao & Pouletaut: 37 mm)"},
};

static const char* const derived_names[] = {"K", "K_over_R"};
static const char* const derived_units[] = {"Pa", "Pa/m"};

static void calc_derived(const double* p, double* out) {
  const double k = p[P_E] / (1.0 - p[P_NU] * p[P_NU]);
  out[0] = k;
  out[1] = k / p[P_R];
}

static const double* find_channel(const kneesim_inputs* in, const char* name) {
  for (int c = 0; c < in->n_channels; ++c)
    if (strcmp(in->names[c], name) == 0) return in->values[c];
  return NULL;
}

/* Sum over the listed area channels of a^3 = (S / pi)^(3/2) into cube[]; returns non-zero with a
 * message on a missing channel or a negative area. NaN areas give NaN forces. */
static int sum_cubes(const kneesim_inputs* in, const char* const* names, int n_names, double* cube, char* err,
                     int err_len) {
  const double pi = 3.14159265358979323846;
  for (int i = 0; i < in->n_frames; ++i) cube[i] = 0.0;
  for (int k = 0; k < n_names; ++k) {
    const double* s = find_channel(in, names[k]);
    if (!s) {
      snprintf(err, (size_t)err_len, "input channel '%s' is missing", names[k]);
      return 1;
    }
    for (int i = 0; i < in->n_frames; ++i) {
      if (s[i] < 0.0) {
        snprintf(err, (size_t)err_len, "expected a contact area %s >= 0 m^2, got %g at frame %d", names[k], s[i], i);
        return 2;
      }
      const double a = sqrt(s[i] / pi);
      cube[i] += a * a * a;
    }
  }
  return 0;
}

static int calc_force_from(const char* const* names, int n_names, const double* p, const kneesim_inputs* in,
                           double* force, double* dforce, char* err, int err_len) {
  const double e = p[P_E], nu = p[P_NU], r = p[P_R];
  if (!(r > 0.0) || !(nu * nu < 1.0)) {
    snprintf(err, (size_t)err_len, "expected R > 0 and |nu| < 1, got R = %g m, nu = %g", r, nu);
    return 3;
  }
  /* force doubles as scratch for a^3 */
  const int rc = sum_cubes(in, names, n_names, force, err, err_len);
  if (rc) return rc;
  const double one_m_nu2 = 1.0 - nu * nu;
  const double c = 2.0 / (3.0 * r) * e / one_m_nu2; /* F = c * a^3 */
  const int n = in->n_frames;
  for (int i = 0; i < n; ++i) {
    const double cube = force[i];
    force[i] = c * cube;
    if (dforce) {
      dforce[P_E * n + i] = 2.0 / (3.0 * r) / one_m_nu2 * cube;
      dforce[P_NU * n + i] = force[i] * 2.0 * nu / one_m_nu2;
      dforce[P_R * n + i] = -force[i] / r;
    }
  }
  return 0;
}

static const char* const hertz_inputs[] = {"S"};
static const char* const hertz_ml_inputs[] = {"S_medial", "S_lateral"};

static int hertz_force(const double* p, const kneesim_inputs* in, double* force, double* dforce, char* err,
                       int err_len) {
  return calc_force_from(hertz_inputs, 1, p, in, force, dforce, err, err_len);
}

static int hertz_ml_force(const double* p, const kneesim_inputs* in, double* force, double* dforce, char* err,
                          int err_len) {
  return calc_force_from(hertz_ml_inputs, 2, p, in, force, dforce, err, err_len);
}

static const kneesim_contact_law hertz = {
    sizeof(kneesim_contact_law),
    "hertz",
    "Hertz, Dao & Pouletaut 2015 eq. 2: F = 2/(3R) E/(1-nu^2) (S/pi)^(3/2) on the total contact area S",
    N_PARAMS, params, 1, hertz_inputs, hertz_force, 2, derived_names, derived_units, calc_derived};

static const kneesim_contact_law hertz_ml = {
    sizeof(kneesim_contact_law),
    "hertz_ml",
    "Hertz per compartment: F = 2/(3R) E/(1-nu^2) ((S_medial/pi)^(3/2) + (S_lateral/pi)^(3/2))",
    N_PARAMS, params, 2, hertz_ml_inputs, hertz_ml_force, 2, derived_names, derived_units, calc_derived};

KNEESIM_PLUGIN_EXPORT int kneesim_plugin_register(const kneesim_registrar* r) {
  if (r->abi_version != KNEESIM_PLUGIN_ABI_VERSION) return -1;
  if (r->add_contact_law(r->host, &hertz)) return 1;
  if (r->add_contact_law(r->host, &hertz_ml)) return 2;
  return 0;
}
