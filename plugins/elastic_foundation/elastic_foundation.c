/* Elastic-foundation ("bed of springs") contact law: a thin elastic liner on a rigid backing,
 * indented by a rigid sphere.
 *
 * Derivation. A liner of thickness h much smaller than the contact radius, bonded to a rigid
 * backing (the tibial tray), deforms in confined compression: each surface point behaves as an
 * independent spring, p(r) = K_ef * u(r) / h, with the confined (oedometric) modulus
 *
 *     K_ef = (1 - nu) E / ((1 + nu)(1 - 2 nu))
 *
 * (Johnson, Contact Mechanics, 1985, section 9.2; Blankevoort et al. 1991). A rigid sphere of
 * radius R pressed in by a depth delta gives u(r) = delta - r^2 / (2R) inside the contact circle
 * of radius a, where u(a) = 0, i.e. a^2 = 2 R delta. The force is
 *
 *     F = integral_0^a p(r) 2 pi r dr = 2 pi K_ef / h * (delta a^2 / 2 - a^4 / (8 R))
 *       = pi K_ef a^4 / (4 R h),
 *
 * and with the contact area S = pi a^2:
 *
 *     F = K_ef S^2 / (4 pi R h).
 *
 * So F grows with S^2 (Hertz: S^(3/2)), and force data determine only K_ef / (R h): E and nu enter
 * through K_ef alone, R and h only through R h. The derived quantities are K_ef and K_ef_over_h.
 *
 * Parameters: E (Pa), nu (-), R (m, fixed by default at the 37 mm cylinder-fit radius of Dao &
 * Pouletaut), h (m, fixed by default at an assumed 8 mm minimum liner thickness; measure the insert
 * of the implant studied). Input: S (m^2).
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "plugin/kneesim_plugin.h"

enum { P_E = 0, P_NU = 1, P_R = 2, P_H = 3, N_PARAMS = 4 };

static const kneesim_param params[N_PARAMS] = {
    {"E", "Pa", 1e6, 1e12, 1e9, 1e9, 0, "Young's modulus of the liner"},
    {"nu", "1", 0.0, 0.49, 0.45, 0.45, 0,
     "Poisson's ratio of the liner; not identifiable from force data (only K_ef is); K_ef grows without bound "
     "as nu -> 0.5"},
    {"R", "m", 1e-3, 1.0, 0.037, 0.037, 1, "radius of the rigid indenter (cylinder-fit radius, 37 mm)"},
    {"h", "m", 1e-4, 0.05, 0.008, 0.008, 1, "liner thickness (assumed 8 mm)"},
};

static const char* const derived_names[] = {"K_ef", "K_ef_over_h"};
static const char* const derived_units[] = {"Pa", "Pa/m"};

static double confined_modulus(double e, double nu) { return (1.0 - nu) * e / ((1.0 + nu) * (1.0 - 2.0 * nu)); }

static void calc_derived(const double* p, double* out) {
  out[0] = confined_modulus(p[P_E], p[P_NU]);
  out[1] = out[0] / p[P_H];
}

static const char* const inputs[] = {"S"};

static int calc_force(const double* p, const kneesim_inputs* in, double* force, double* dforce, char* err,
                      int err_len) {
  const double pi = 3.14159265358979323846;
  const double e = p[P_E], nu = p[P_NU], r = p[P_R], h = p[P_H];
  if (!(r > 0.0) || !(h > 0.0) || !(nu > -1.0 && nu < 0.5)) {
    snprintf(err, (size_t)err_len, "expected R > 0, h > 0 and -1 < nu < 0.5, got R = %g m, h = %g m, nu = %g", r,
             h, nu);
    return 3;
  }
  const double* s = NULL;
  for (int c = 0; c < in->n_channels; ++c)
    if (strcmp(in->names[c], "S") == 0) s = in->values[c];
  if (!s) {
    snprintf(err, (size_t)err_len, "input channel 'S' is missing");
    return 1;
  }
  const double k_ef = confined_modulus(e, nu);
  /* d ln K_ef / d nu */
  const double dlnk_dnu = -1.0 / (1.0 - nu) - 1.0 / (1.0 + nu) + 2.0 / (1.0 - 2.0 * nu);
  const double geometry = 1.0 / (4.0 * pi * r * h);
  const double c = k_ef * geometry;
  const double dk_de = confined_modulus(1.0, nu);
  const int n = in->n_frames;
  for (int i = 0; i < n; ++i) {
    if (s[i] < 0.0) {
      snprintf(err, (size_t)err_len, "expected a contact area S >= 0 m^2, got %g at frame %d", s[i], i);
      return 2;
    }
    const double s2 = s[i] * s[i];
    force[i] = c * s2;
    if (dforce) {
      dforce[P_E * n + i] = dk_de * geometry * s2;
      dforce[P_NU * n + i] = force[i] * dlnk_dnu;
      dforce[P_R * n + i] = -force[i] / r;
      dforce[P_H * n + i] = -force[i] / h;
    }
  }
  return 0;
}

static const kneesim_contact_law law = {
    sizeof(kneesim_contact_law),
    "elastic_foundation",
    "thin elastic liner under a rigid sphere: F = K_ef S^2 / (4 pi R h), K_ef = (1-nu) E / ((1+nu)(1-2nu))",
    N_PARAMS, params, 1, inputs, calc_force, 2, derived_names, derived_units, calc_derived};

KNEESIM_PLUGIN_EXPORT int kneesim_plugin_register(const kneesim_registrar* r) {
  if (r->abi_version != KNEESIM_PLUGIN_ABI_VERSION) return -1;
  return r->add_contact_law(r->host, &law);
}
