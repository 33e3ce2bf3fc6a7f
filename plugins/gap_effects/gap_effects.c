/* The catalogue of gap-diagnosis effects (issue 5): candidate explanations for the difference
 * between a contact law's force and the measured knee force, each a NESTED extension of any
 * baseline law: with every parameter at its default the baseline's force comes back exactly.
 *
 *   effect             parameter(s) (default)      extended force
 *   exponent           dm (0)                      F_base * (S / S_ref)^dm
 *   radius_flexion     rho (0) 1/rad               F_base * exp(-rho (theta - theta_ref))     [R = R_ref exp(rho (theta - theta_ref))]
 *   ml_compartments    delta (0)                   F_base * (1 + delta q),  q = (s_m^n - s_l^n) / (s_m^n + s_l^n)
 *   rate               tau (0) s                   F_base * (1 + tau dS_dt / S_ref)             [Hunt-Crossley]
 *   time_delay         delay (0) s                 F_base(t - delay)                            [cubic Hermite in time]
 *   creep              kappa (0)                   F_base * (1 - kappa h),  h = EWMA(S / S_ref, tau_c)
 *   flexion_offset     offset (0) rad              F_base(S + dS_dflexion * offset)
 *   flexion_gain       gain (0)                    F_base(S + dS_dflexion * gain * theta)
 *   ap_translation     shift (0) m                 F_base(S + dS_dap * shift)
 *   threshold          dh (0) m                    F_base(S(h0 + dh)),  S(h) through S@2mm..S@6mm, h0 = S_threshold or 4 mm
 *   grf_load           gain (0)                    F_base + gain * GRF:vertical
 *   emg_cocontraction  gain (0) N                  F_base + gain * EMG:cocontraction
 *   adhesion_jkr       psi (0) N/m^1.5, 0..7e4     F_base - psi (S / pi)^(3/4)                  [negative control]
 *   knee_load          flexion, adduction (0)      F_base + flexion M_flex + adduction M_add    [knee_load.c]
 *
 * and, in motion_load_effects.c (issue 17): hysteresis (flexing vs extending), load_flexion (GRF through a
 * flexion-dependent lever), grf_left and grf_shear (the other foot's vertical GRF, the instrumented foot's
 * horizontal components), trial_drift (a slow drift over a recording).
 * theta is the channel knee_flexion (rad), s_m = S_medial / (S_medial + S_lateral), s_l = 1 - s_m.
 * Force maps give exact derivatives; the engine differentiates rewrites numerically (tests/gap checks both).
 */
#include <math.h>

#include "effect_common.h"

static const double kPi = 3.14159265358979323846;

/* The factor array is written into force first (force doubles as scratch), then applied in place. */
static void apply_factor_in_place(int n, const double* base, int n_tangents, const double* tin, double* force,
                                  double* tout) {
  for (int k = 0; k < n_tangents; ++k)
    for (int i = 0; i < n; ++i) tout[k * n + i] = tin[k * n + i] * force[i];
  for (int i = 0; i < n; ++i) force[i] *= base[i];
}

/* ---------------------------------------------------------------- exponent */
static const kneesim_param exponent_params[] = {
    {"dm", "1", -1.0, 2.0, 0.0, 0.2, 0, "change of the contact law's exponent on the contact area"},
    /* 2500 mm^2: the middle of a TKA insert's 4 mm proximity areas (JW: 2000-2740 mm^2). A reference
       far from the data's areas couples dm with the law's stiffness (F ~ K S_ref^-dm S^(m+dm)) and
       makes the joint fit ill-conditioned. */
    {"S_ref", "m^2", 1e-6, 1.0, 2.5e-3, 1e-3, 1, "reference area at which the exponent change leaves F unchanged"},
};
static const char* const exponent_inputs[] = {"S"};
static int exponent_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                        double* force, double* tout, double* dforce, char* err, int err_len) {
  NEED(s, "S");
  const int n = in->n_frames;
  const double dm = p[0], sref = p[1];
  for (int i = 0; i < n; ++i) {
    const double x = (s[i] > 1e-12 ? s[i] : 1e-12) / sref;
    force[i] = pow(x, dm);
    if (dforce) {
      dforce[0 * n + i] = base[i] * force[i] * log(x);
      dforce[1 * n + i] = base[i] * force[i] * (-dm / sref);
    }
  }
  apply_factor_in_place(n, base, nt, tin, force, tout);
  return 0;
}

/* ---------------------------------------------------------------- radius_flexion */
static const kneesim_param radius_params[] = {
    {"rho", "1/rad", -2.0, 2.0, 0.0, 0.3, 0, "relative change of the sagittal radius per radian of flexion"},
    {"theta_ref", "rad", -1.0, 2.5, 0.35, 0.35, 1, "flexion at which the radius equals the law's R"},
};
static const char* const radius_inputs[] = {"knee_flexion"};
static int radius_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                      double* force, double* tout, double* dforce, char* err, int err_len) {
  NEED(th, "knee_flexion");
  const int n = in->n_frames;
  for (int i = 0; i < n; ++i) {
    const double d = th[i] - p[1];
    force[i] = exp(-p[0] * d);
    if (dforce) {
      dforce[0 * n + i] = -d * base[i] * force[i];
      dforce[1 * n + i] = p[0] * base[i] * force[i];
    }
  }
  apply_factor_in_place(n, base, nt, tin, force, tout);
  return 0;
}

/* ---------------------------------------------------------------- ml_compartments */
static const kneesim_param ml_params[] = {
    {"delta", "1", -0.95, 0.95, 0.0, 0.2, 0,
     "stiffness asymmetry: the medial compartment is (1 + delta), the lateral (1 - delta) times as stiff"},
    {"n", "1", 0.5, 3.0, 1.5, 1.5, 1, "exponent of each compartment's share (1.5 for Hertz)"},
};
static const char* const ml_inputs[] = {"S_medial", "S_lateral"};
static int ml_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                  double* force, double* tout, double* dforce, char* err, int err_len) {
  NEED(sm, "S_medial");
  NEED(sl, "S_lateral");
  const int n = in->n_frames;
  const double delta = p[0], e = p[1];
  for (int i = 0; i < n; ++i) {
    const double m = sm[i] > 0 ? sm[i] : 0.0, l = sl[i] > 0 ? sl[i] : 0.0, tot = m + l;
    double q = 0.0, dq = 0.0;
    if (tot > 0) {
      const double a_s = m / tot, b_s = l / tot;
      const double a = a_s > 0 ? pow(a_s, e) : 0.0, b = b_s > 0 ? pow(b_s, e) : 0.0;
      const double da = a_s > 0 ? a * log(a_s) : 0.0, db = b_s > 0 ? b * log(b_s) : 0.0;
      q = (a - b) / (a + b);
      dq = 2.0 * (da * b - a * db) / ((a + b) * (a + b));
    }
    force[i] = 1.0 + delta * q;
    if (dforce) {
      dforce[0 * n + i] = base[i] * q;
      dforce[1 * n + i] = base[i] * delta * dq;
    }
  }
  apply_factor_in_place(n, base, nt, tin, force, tout);
  return 0;
}

/* ---------------------------------------------------------------- rate */
static const kneesim_param rate_params[] = {
    {"tau", "s", -0.5, 0.5, 0.0, 0.02, 0, "damping time: relative force change per relative area rate"},
    {"S_ref", "m^2", 1e-6, 1.0, 1e-3, 1e-3, 1, "area that normalises the rate"},
};
static const char* const rate_inputs[] = {"dS_dt"};
static int rate_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                    double* force, double* tout, double* dforce, char* err, int err_len) {
  NEED(ds, "dS_dt");
  const int n = in->n_frames;
  for (int i = 0; i < n; ++i) {
    const double r = ds[i] / p[1];
    force[i] = 1.0 + p[0] * r;
    if (dforce) {
      dforce[0 * n + i] = base[i] * r;
      dforce[1 * n + i] = -base[i] * p[0] * r / p[1];
    }
  }
  apply_factor_in_place(n, base, nt, tin, force, tout);
  return 0;
}

/* ---------------------------------------------------------------- time_delay */
/* Cubic Hermite interpolation of a series y(t_j) with central-difference slopes, written as
 * weights on the samples so the same weights map the tangents. For target time tau (clamped to
 * the data) fills up to 6 (index, weight, d weight / d tau) triples; returns their count. */
static int hermite_weights(const double* t, int n, double tau, int* hint, int* idx, double* w, double* dw) {
  if (n == 1) {
    idx[0] = 0;
    w[0] = 1.0;
    dw[0] = 0.0;
    return 1;
  }
  int clamped = 0;
  if (tau <= t[0]) {
    tau = t[0];
    clamped = 1;
  } else if (tau >= t[n - 1]) {
    tau = t[n - 1];
    clamped = 1;
  }
  /* segment j with t[j] <= tau <= t[j+1]: walk from the previous call's segment (targets usually
   * increase frame by frame), binary search otherwise */
  int j = *hint;
  if (j < 0 || j > n - 2 || t[j] > tau) {
    int lo = 0, hi = n - 1;
    while (hi - lo > 1) {
      const int mid = (lo + hi) / 2;
      if (t[mid] <= tau) lo = mid;
      else hi = mid;
    }
    j = lo;
  }
  while (j < n - 2 && t[j + 1] <= tau) ++j;
  *hint = j;
  const double h = t[j + 1] - t[j];
  const double u = (tau - t[j]) / h;
  const double u2 = u * u, u3 = u2 * u;
  const double h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2, h11 = u3 - u2;
  const double d00 = (6 * u2 - 6 * u) / h, d10 = (3 * u2 - 4 * u + 1) / h, d01 = (-6 * u2 + 6 * u) / h,
               d11 = (3 * u2 - 2 * u) / h;
  int k = 0;
  idx[k] = j, w[k] = h00, dw[k] = d00, ++k;
  idx[k] = j + 1, w[k] = h01, dw[k] = d01, ++k;
  /* slope m_q = (y[b] - y[a]) / (t[b] - t[a]) with a = max(q-1, 0), b = min(q+1, n-1) */
  for (int side = 0; side < 2; ++side) {
    const int q = j + side;
    const int a = q > 0 ? q - 1 : 0, b = q < n - 1 ? q + 1 : n - 1;
    const double c = h / (t[b] - t[a]);
    const double hw = side == 0 ? h10 : h11, hd = side == 0 ? d10 : d11;
    idx[k] = b, w[k] = c * hw, dw[k] = c * hd, ++k;
    idx[k] = a, w[k] = -c * hw, dw[k] = -c * hd, ++k;
  }
  if (clamped)
    for (int m = 0; m < k; ++m) dw[m] = 0.0;
  return k;
}

static const kneesim_param delay_params[] = {
    {"delay", "s", -0.15, 0.15, 0.0, 0.01, 0,
     "lag of the load cells behind motion capture: F(t) = F_base(t - delay)"},
};
static const char* const delay_inputs[] = {"time"};
static int delay_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                     double* force, double* tout, double* dforce, char* err, int err_len) {
  NEED(t, "time");
  const int n = in->n_frames;
  int idx[6], hint = 0;
  double w[6], dw[6];
  for (int i = 0; i < n; ++i) {
    const int k = hermite_weights(t, n, t[i] - p[0], &hint, idx, w, dw);
    double f = 0.0, df = 0.0;
    for (int m = 0; m < k; ++m) {
      f += w[m] * base[idx[m]];
      df += dw[m] * base[idx[m]];
    }
    force[i] = f;
    if (dforce) dforce[i] = -df;
    for (int q = 0; q < nt; ++q) {
      double v = 0.0;
      for (int m = 0; m < k; ++m) v += w[m] * tin[q * n + idx[m]];
      tout[q * n + i] = v;
    }
  }
  return 0;
}

/* ---------------------------------------------------------------- creep */
static const kneesim_param creep_params[] = {
    {"kappa", "1", -0.5, 0.9, 0.0, 0.1, 0, "force lost per unit of recent loading (area history)"},
    {"tau_c", "s", 0.05, 100.0, 1.0, 1.0, 1, "time constant of the loading history"},
    {"S_ref", "m^2", 1e-6, 1.0, 1e-3, 1e-3, 1, "area that normalises the loading history"},
};
static const char* const creep_inputs[] = {"time", "S"};
static int creep_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                     double* force, double* tout, double* dforce, char* err, int err_len) {
  NEED(t, "time");
  NEED(s, "S");
  const int n = in->n_frames;
  const double kappa = p[0], tau = p[1], sref = p[2];
  double h = s[0] / sref, dh_dtau = 0.0;
  for (int i = 0; i < n; ++i) {
    if (i > 0) {
      const double dt = t[i] - t[i - 1];
      const double ex = exp(-dt / tau), alpha = 1.0 - ex, dalpha = -ex * dt / (tau * tau);
      const double x = s[i] / sref;
      dh_dtau = (1.0 - alpha) * dh_dtau + dalpha * (x - h);
      h = h + alpha * (x - h);
    }
    force[i] = 1.0 - kappa * h;
    if (dforce) {
      dforce[0 * n + i] = -base[i] * h;
      dforce[1 * n + i] = -base[i] * kappa * dh_dtau;
      dforce[2 * n + i] = base[i] * kappa * h / sref; /* h is proportional to 1 / S_ref */
    }
  }
  apply_factor_in_place(n, base, nt, tin, force, tout);
  return 0;
}

/* ---------------------------------------------------------------- kinematic input errors */
/* S' = max(S + d * x, 0) with d the sensitivity channel and x the parameter term. */
static const kneesim_param offset_params[] = {
    {"offset", "rad", -0.25, 0.25, 0.0, 0.03, 0, "error of the measured flexion: true = measured + offset"},
};
static const char* const offset_inputs[] = {"S", "dS_dflexion"};
static const char* const s_only[] = {"S"};
static int offset_rewrite(const double* p, const kneesim_inputs* in, double* values, char* err, int err_len) {
  NEED(s, "S");
  NEED(d, "dS_dflexion");
  for (int i = 0; i < in->n_frames; ++i) {
    const double v = s[i] + d[i] * p[0];
    values[i] = v > 0 ? v : 0.0;
  }
  return 0;
}

static const kneesim_param gain_params[] = {
    {"gain", "1", -0.5, 0.5, 0.0, 0.05, 0, "relative error of the measured flexion: true = (1 + gain) measured"},
};
static const char* const gain_inputs[] = {"S", "dS_dflexion", "knee_flexion"};
static int gain_rewrite(const double* p, const kneesim_inputs* in, double* values, char* err, int err_len) {
  NEED(s, "S");
  NEED(d, "dS_dflexion");
  NEED(th, "knee_flexion");
  for (int i = 0; i < in->n_frames; ++i) {
    const double v = s[i] + d[i] * p[0] * th[i];
    values[i] = v > 0 ? v : 0.0;
  }
  return 0;
}

static const kneesim_param ap_params[] = {
    {"shift", "m", -0.01, 0.01, 0.0, 0.001, 0, "anterior-posterior error of the femur on the insert"},
};
static const char* const ap_inputs[] = {"S", "dS_dap"};
static int ap_rewrite(const double* p, const kneesim_inputs* in, double* values, char* err, int err_len) {
  NEED(s, "S");
  NEED(d, "dS_dap");
  for (int i = 0; i < in->n_frames; ++i) {
    const double v = s[i] + d[i] * p[0];
    values[i] = v > 0 ? v : 0.0;
  }
  return 0;
}

/* ---------------------------------------------------------------- threshold */
/* The threshold of S itself is data, not a parameter: the optional constant channel S_threshold
 * (m), else the paper's 4 mm. */
static const kneesim_param threshold_params[] = {
    {"dh", "m", -0.002, 0.002, 0.0, 0.0005, 0, "change of the proximity threshold that defines the contact area"},
};
static const char* const threshold_inputs[] = {"S", "S@3mm", "S@5mm"};

/* Knots (threshold in m, channel) sorted by threshold: S at h0 and every "S@<x>mm" channel. */
#define MAX_KNOTS 16
static int collect_knots(const kneesim_inputs* in, double h0, double* hk, const double** sk) {
  int k = 0;
  hk[k] = h0;
  sk[k] = find_channel(in, "S");
  ++k;
  for (int c = 0; c < in->n_channels && k < MAX_KNOTS; ++c) {
    const char* nm = in->names[c];
    double mm;
    char tail[8];
    if (strncmp(nm, "S@", 2) != 0 || sscanf(nm + 2, "%lf%7s", &mm, tail) != 2 || strcmp(tail, "mm") != 0) continue;
    const double h = mm * 1e-3;
    if (fabs(h - h0) < 1e-9) continue;
    hk[k] = h;
    sk[k] = in->values[c];
    ++k;
  }
  for (int a = 1; a < k; ++a) /* insertion sort */
    for (int b = a; b > 0 && hk[b] < hk[b - 1]; --b) {
      const double th = hk[b];
      hk[b] = hk[b - 1];
      hk[b - 1] = th;
      const double* ts = sk[b];
      sk[b] = sk[b - 1];
      sk[b - 1] = ts;
    }
  return k;
}

static int threshold_rewrite(const double* p, const kneesim_inputs* in, double* values, char* err, int err_len) {
  double hk[MAX_KNOTS];
  const double* sk[MAX_KNOTS];
  const double* h0c = find_channel(in, "S_threshold");
  const double h0 = h0c && in->n_frames > 0 ? h0c[0] : 0.004;
  const int k = collect_knots(in, h0, hk, sk);
  if (k < 2 || !sk[0]) {
    snprintf(err, (size_t)err_len, "expected channel S and at least one channel S@<x>mm");
    return 1;
  }
  const double h = h0 + p[0];
  /* segment a..a+1 containing h (extrapolate linearly outside) */
  int a = 0;
  while (a + 2 < k && h > hk[a + 1]) ++a;
  const double len = hk[a + 1] - hk[a];
  const int outside = h < hk[0] || h > hk[k - 1];
  const double u = (h - hk[a]) / len;
  for (int i = 0; i < in->n_frames; ++i) {
    /* slopes by central differences on the knots (one-sided at the ends) */
    double m[2];
    for (int side = 0; side < 2; ++side) {
      const int q = a + side, lo = q > 0 ? q - 1 : 0, hi = q < k - 1 ? q + 1 : k - 1;
      m[side] = (sk[hi][i] - sk[lo][i]) / (hk[hi] - hk[lo]);
    }
    double v;
    if (outside) {
      const int e = h < hk[0] ? 0 : k - 1;
      v = sk[e][i] + m[h < hk[0] ? 0 : 1] * (h - hk[e]);
    } else {
      const double u2 = u * u, u3 = u2 * u;
      v = (2 * u3 - 3 * u2 + 1) * sk[a][i] + (u3 - 2 * u2 + u) * len * m[0] + (-2 * u3 + 3 * u2) * sk[a + 1][i] +
          (u3 - u2) * len * m[1];
    }
    values[i] = v > 0 ? v : 0.0;
  }
  return 0;
}

/* ---------------------------------------------------------------- grf_load, emg_cocontraction */
static const kneesim_param grf_params[] = {
    {"gain", "1", -3.0, 3.0, 0.0, 0.3, 0, "knee force per newton of vertical ground reaction force"},
};
static const char* const grf_inputs[] = {"GRF:vertical"};
static int grf_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                   double* force, double* tout, double* dforce, char* err, int err_len) {
  NEED(g, "GRF:vertical");
  const int n = in->n_frames;
  for (int i = 0; i < n; ++i) {
    force[i] = base[i] + p[0] * g[i];
    if (dforce) dforce[i] = g[i];
  }
  pass_tangents(n, nt, tin, tout);
  return 0;
}

static const kneesim_param emg_params[] = {
    {"gain", "N", -5000.0, 5000.0, 0.0, 300.0, 0, "knee force at full co-contraction (envelope 1)"},
};
static const char* const emg_inputs[] = {"EMG:cocontraction"};
static int emg_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                   double* force, double* tout, double* dforce, char* err, int err_len) {
  NEED(c, "EMG:cocontraction");
  const int n = in->n_frames;
  for (int i = 0; i < n; ++i) {
    force[i] = base[i] + p[0] * c[i];
    if (dforce) dforce[i] = c[i];
  }
  pass_tangents(n, nt, tin, tout);
  return 0;
}

/* ---------------------------------------------------------------- adhesion_jkr */
/* psi = sqrt(8 pi w K) is bounded by its physical size: the work of adhesion w of dry polyethylene
 * on a metal oxide is at most ~0.1 J/m^2 (less in synovial fluid) and K = E / (1 - nu^2) of UHMWPE
 * at most ~2 GPa, so psi <= sqrt(8 pi 0.1 2e9) = 7.1e4 N/m^1.5. The proximity area (up to 4 mm of
 * gap) is larger than the true contact, so even this overstates the pull-off. Unbounded, the term
 * is no longer adhesion but any -S^(3/4) shape: at psi ~ 2.4e5 (w ~ 1 J/m^2) it mimics an exponent
 * change on JW's areas. */
static const kneesim_param jkr_params[] = {
    {"psi", "N/m^1.5", 0.0, 7e4, 0.0, 1e4, 0,
     "JKR adhesion term sqrt(8 pi w K): pull-off grows as a^(3/2); at most 7e4 (w 0.1 J/m^2, K 2 GPa)"},
};
static const char* const jkr_inputs[] = {"S"};
static int jkr_map(const double* p, const kneesim_inputs* in, const double* base, int nt, const double* tin,
                   double* force, double* tout, double* dforce, char* err, int err_len) {
  NEED(s, "S");
  const int n = in->n_frames;
  for (int i = 0; i < n; ++i) {
    const double a15 = s[i] > 0 ? pow(s[i] / kPi, 0.75) : 0.0;
    force[i] = base[i] - p[0] * a15;
    if (dforce) dforce[i] = -a15;
  }
  pass_tangents(n, nt, tin, tout);
  return 0;
}

/* ---------------------------------------------------------------- tables */
#define REWRITE_EFFECT(nm, desc, params, inputs, fn, phys, sep) \
  {sizeof(kneesim_effect), nm, desc, N_OF(params), params, N_OF(inputs), inputs, 1, s_only, fn, NULL, phys, sep}

static const kneesim_effect effects[] = {
    MAP_EFFECT("exponent", "F = F_base (S / S_ref)^dm", exponent_params, exponent_inputs, exponent_map,
               "the force grows with the area by another power than the law's (non-Hertzian geometry, "
               "conformity, a thin liner)",
               "trials spanning a wide range of contact areas at similar flexion and loading rate"),
    MAP_EFFECT("radius_flexion", "F = F_base exp(-rho (theta - theta_ref)), R = R_ref exp(rho (theta - theta_ref))",
               radius_params, radius_inputs, radius_map,
               "a multi-radius femoral component: the sagittal radius changes with flexion",
               "the same load at different flexion angles (e.g. stair ascent or chair rise next to gait); the "
               "cylinder fit's R(theta) table"),
    MAP_EFFECT("ml_compartments", "F = F_base (1 + delta q), q = (s_m^n - s_l^n) / (s_m^n + s_l^n)", ml_params,
               ml_inputs, ml_map,
               "medial and lateral compartments of different stiffness (or a load share that is not the area share)",
               "the measured medial/lateral forces; activities that shift load between compartments (medial thrust)"),
    MAP_EFFECT("rate", "F = F_base (1 + tau dS_dt / S_ref)  (Hunt-Crossley)", rate_params, rate_inputs, rate_map,
               "viscoelastic (rate-dependent) contact: more force while the contact loads, less while it unloads",
               "the same trial at different speeds (rate scales, a delay does not); a synchronisation pulse"),
    MAP_EFFECT("time_delay", "F(t) = F_base(t - delay)", delay_params, delay_inputs, delay_map,
               "the load cells lag (or lead) motion capture: clocks or filters not aligned",
               "a synchronisation event seen by both systems (heel strike on a plate and the load cells)"),
    MAP_EFFECT("creep", "F = F_base (1 - kappa h), h = EWMA(S / S_ref, tau_c)", creep_params, creep_inputs, creep_map,
               "polyethylene creep: recent loading leaves the insert more conforming, so the same area carries less "
               "force",
               "long static holds (single-leg stance) and repeated cycles in one recording"),
    REWRITE_EFFECT("flexion_offset", "F = F_base(S + dS_dflexion offset)", offset_params, offset_inputs,
                   offset_rewrite, "the flexion driving the contact area is off by a constant (marker placement, "
                   "goniometer zero)",
                   "fluoroscopy or a static calibration trial at known flexion"),
    REWRITE_EFFECT("flexion_gain", "F = F_base(S + dS_dflexion gain theta)", gain_params, gain_inputs, gain_rewrite,
                   "the flexion driving the contact area is scaled wrongly (goniometer calibration, soft-tissue "
                   "artefact growing with flexion)",
                   "activities reaching high flexion (chair rise, stairs) next to gait"),
    {sizeof(kneesim_effect), "ap_translation", "F = F_base(S + dS_dap shift)", N_OF(ap_params), ap_params,
     N_OF(ap_inputs), ap_inputs, 1, s_only, ap_rewrite, NULL,
     "the femur sits further anterior or posterior on the insert than the kinematics say",
     "fluoroscopy; needs the contact-area tool's dS_dap channel"},
    {sizeof(kneesim_effect), "threshold", "F = F_base(S(h0 + dh)), S(h) through the S@<x>mm channels",
     N_OF(threshold_params), threshold_params, N_OF(threshold_inputs), threshold_inputs, 1, s_only,
     threshold_rewrite, NULL,
     "the proximity threshold defining the contact area (the paper's 4 mm, calibrated on cadavers) is off",
     "pressure-film or fluoroscopic contact areas; areas at several thresholds over trials of different load"},
    MAP_EFFECT("grf_load", "F = F_base + gain GRF:vertical", grf_params, grf_inputs, grf_map,
               "part of the knee load follows the external load (body weight, inertia) rather than the contact area",
               "activities with the same contact area but different ground reaction (stance on one and two legs)"),
    MAP_EFFECT("emg_cocontraction", "F = F_base + gain EMG:cocontraction", emg_params, emg_inputs, emg_map,
               "muscle co-contraction compresses the joint beyond what the kinematics show",
               "trials with deliberate co-contraction; EMG of more muscles"),
    MAP_EFFECT("adhesion_jkr", "F = F_base - psi (S / pi)^(3/4)  (JKR)", jkr_params, jkr_inputs, jkr_map,
               "adhesion between the components (Johnson-Kendall-Roberts); negligible in a lubricated joint, so a "
               "negative control",
               "pull-off tests; it should not be selected"),
};

extern const kneesim_effect kneesim_gap_effect_knee_load; /* knee_load.c */

KNEESIM_PLUGIN_EXPORT int kneesim_plugin_register(const kneesim_registrar* r) {
  if (r->abi_version < 2) return -1; /* add_effect arrived with ABI version 2 */
  for (int i = 0; i < N_OF(effects); ++i)
    if (r->add_effect(r->host, &effects[i])) return 1 + i;
  if (r->add_effect(r->host, &kneesim_gap_effect_knee_load)) return 1 + N_OF(effects);
  const int rc = kneesim_gap_register_motion_load_effects(r);
  return rc ? N_OF(effects) + 1 + rc : 0;
}
