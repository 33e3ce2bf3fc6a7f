/* Gap-diagnosis effects a knee biomechanist tests after the contact law's own (issue 17): the direction
 * of motion, external loads beyond the instrumented foot's vertical force, and time. Each is NESTED
 * (its defaults give the baseline back exactly) and additive, so tangents pass through and the
 * derivatives are exact.
 *
 *   effect        parameter(s) (default)            extended force
 *   hysteresis    h (0) N; omega0 (0.3 rad/s, fixed) F_base + h tanh(dtheta/dt / omega0)
 *   load_flexion  gain (0) 1/rad                    F_base + gain GRF:vertical theta
 *   grf_left      gain (0)                          F_base + gain GRF:vertical_left
 *   grf_shear     gain_x, gain_y (0)                F_base + gain_x GRF:x + gain_y GRF:y
 *   trial_drift   rate (0) N/s                      F_base + rate trial_time
 *
 * theta is knee_flexion (rad), dtheta/dt the channel knee_flexion_rate (the flexion low-passed at
 * 6 Hz, differentiated); GRF:x and GRF:y are the instrumented foot's horizontal ground reaction in the
 * lab's axes, GRF:vertical_left the other foot's vertical force (from the C3D's plates);
 * trial_time is the time since the recording's first frame (s).
 */
#include <math.h>

#include "effect_common.h"

/* ---------------------------------------------------------------- hysteresis */
/* omega0 sets how slow a motion still counts as flexing or extending: JW's rates reach 5-7 rad/s in
 * gait, while a knee held still jitters by ~0.1 rad/s in the IK flexion; 0.3 rad/s (17 deg/s) keeps the
 * sign of that jitter out and switches within 5 % of a gait cycle's rate range. */
static const kneesim_param hysteresis_params[] = {
    {"h", "N", -3000.0, 3000.0, 0.0, 100.0, 0, "force added while flexing (subtracted while extending)"},
    {"omega0", "rad/s", 0.02, 20.0, 0.3, 0.3, 1, "flexion rate over which the direction term switches sign"},
};
static const char* const hysteresis_inputs[] = {"knee_flexion_rate"};
static int hysteresis_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                          double* force, double* tout, double* dforce, char* err, int err_len) {
  NEED(v, "knee_flexion_rate");
  const int n = in->n_frames;
  const double h = p[0], w = p[1];
  for (int i = 0; i < n; ++i) {
    const double x = v[i] / w, th = tanh(x);
    force[i] = base[i] + h * th;
    if (dforce) {
      dforce[0 * n + i] = th;
      dforce[1 * n + i] = -h * (1.0 - th * th) * x / w;
    }
  }
  pass_tangents(n, nt, tin, tout);
  return 0;
}

/* ---------------------------------------------------------------- load_flexion */
static const kneesim_param load_flexion_params[] = {
    {"gain", "1/rad", -5.0, 5.0, 0.0, 0.3, 0, "knee force per newton of vertical GRF per radian of flexion"},
};
static const char* const load_flexion_inputs[] = {"GRF:vertical", "knee_flexion"};
static int load_flexion_map(const double* p, const kneesim_inputs* in, const double* base, int nt,
                            const double* tin, double* force, double* tout, double* dforce, char* err, int err_len) {
  NEED(g, "GRF:vertical");
  NEED(th, "knee_flexion");
  const int n = in->n_frames;
  for (int i = 0; i < n; ++i) {
    const double x = g[i] * th[i];
    force[i] = base[i] + p[0] * x;
    if (dforce) dforce[i] = x;
  }
  pass_tangents(n, nt, tin, tout);
  return 0;
}

/* ---------------------------------------------------------------- grf_left, grf_shear, trial_drift */
/* F = F_base + sum_k gain_k channel_k over the effect's inputs, in order. */
static int linear_terms(int n_terms, const char* const* names, const double* p, const kneesim_inputs* in,
                        const double* base, int nt, const double* tin, double* force, double* tout, double* dforce,
                        char* err, int err_len) {
  const int n = in->n_frames;
  for (int i = 0; i < n; ++i) force[i] = base[i];
  for (int k = 0; k < n_terms; ++k) {
    NEED(x, names[k]);
    for (int i = 0; i < n; ++i) {
      force[i] += p[k] * x[i];
      if (dforce) dforce[k * n + i] = x[i];
    }
  }
  pass_tangents(n, nt, tin, tout);
  return 0;
}

static const kneesim_param grf_left_params[] = {
    {"gain", "1", -3.0, 3.0, 0.0, 0.3, 0, "knee force per newton of the other foot's vertical GRF"},
};
static const char* const grf_left_inputs[] = {"GRF:vertical_left"};
static int grf_left_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                        double* force, double* tout, double* dforce, char* err, int err_len) {
  return linear_terms(1, grf_left_inputs, p, in, base, nt, tin, force, tout, dforce, err, err_len);
}

/* Horizontal GRF is ~20 % of the vertical in gait, so its gains may be larger than grf_load's. */
static const kneesim_param grf_shear_params[] = {
    {"gain_x", "1", -10.0, 10.0, 0.0, 1.0, 0, "knee force per newton of the instrumented foot's GRF along lab x"},
    {"gain_y", "1", -10.0, 10.0, 0.0, 1.0, 0, "knee force per newton of the instrumented foot's GRF along lab y"},
};
static const char* const grf_shear_inputs[] = {"GRF:x", "GRF:y"};
static int grf_shear_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                         double* force, double* tout, double* dforce, char* err, int err_len) {
  return linear_terms(2, grf_shear_inputs, p, in, base, nt, tin, force, tout, dforce, err, err_len);
}

static const kneesim_param drift_params[] = {
    {"rate", "N/s", -500.0, 500.0, 0.0, 10.0, 0, "change of the measured force per second since the recording began"},
};
static const char* const drift_inputs[] = {"trial_time"};
static int drift_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                     double* force, double* tout, double* dforce, char* err, int err_len) {
  return linear_terms(1, drift_inputs, p, in, base, nt, tin, force, tout, dforce, err, err_len);
}

static const kneesim_effect motion_load_effects[] = {
    MAP_EFFECT("hysteresis", "F = F_base + h tanh(dtheta/dt / omega0)", hysteresis_params, hysteresis_inputs,
               hysteresis_map,
               "the knee force differs between flexing and extending through the same pose (soft-tissue and "
               "contact hysteresis, friction, the muscles' force-velocity relation)",
               "the same pose reached while flexing and while extending: stair ascent next to descent, rising next "
               "to sitting down"),
    MAP_EFFECT("load_flexion", "F = F_base + gain GRF:vertical theta", load_flexion_params, load_flexion_inputs,
               load_flexion_map,
               "the external load acts through a lever that grows with flexion (the quadriceps balancing the "
               "external flexion moment)",
               "the same ground reaction at different flexion: gait next to stairs and chair rise"),
    MAP_EFFECT("grf_left", "F = F_base + gain GRF:vertical_left", grf_left_params, grf_left_inputs, grf_left_map,
               "the load on the other foot changes the instrumented knee's force (weight transfer in double "
               "support, pelvic and hip muscles)",
               "single-leg stance next to double support; trials with the other foot on a plate"),
    MAP_EFFECT("grf_shear", "F = F_base + gain_x GRF:x + gain_y GRF:y", grf_shear_params, grf_shear_inputs,
               grf_shear_map,
               "the horizontal ground reaction (braking, propulsion, medio-lateral) loads the knee beyond the "
               "vertical force",
               "walking at different speeds (braking and propulsion scale); turning or side-stepping"),
    MAP_EFFECT("trial_drift", "F = F_base + rate trial_time", drift_params, drift_inputs, drift_map,
               "the load cells' zero (or the subject's loading) drifts slowly during a recording",
               "a static trial at a known load at the start and the end of a recording; re-zeroed repeats"),
};

int kneesim_gap_register_motion_load_effects(const kneesim_registrar* r) {
  for (int i = 0; i < N_OF(motion_load_effects); ++i)
    if (r->add_effect(r->host, &motion_load_effects[i])) return 1 + i;
  return 0;
}
