/* kneesim plugin ABI (C, like MuJoCo's mjplugin.h).
 *
 * A plugin is a shared library that exports one function,
 *
 *     int kneesim_plugin_register(const kneesim_registrar* r);
 *
 * which the engine calls right after loading the library. The plugin calls r->add_* once per
 * thing it provides (contact laws, distance providers, gap-diagnosis effects). Tables passed to
 * add_* must stay valid while the library is loaded (use static storage).
 *
 * Versions: the engine passes its KNEESIM_PLUGIN_ABI_VERSION in r->abi_version. Fields are only
 * ever appended (to the registrar and, behind struct_size, to the tables), so a plugin works with
 * any engine whose version is at least the one it was built against: check
 * r->abi_version >= KNEESIM_PLUGIN_ABI_VERSION. Version 2 added kneesim_effect and add_effect.
 *
 * Units are SI throughout: areas in m^2, distances in m, forces in N, angles in rad, time in s.
 * Functions return 0 on success; on failure they write a one-line message into err (at most
 * err_len bytes including the terminating NUL) and return non-zero.
 */
#ifndef KNEESIM_PLUGIN_H
#define KNEESIM_PLUGIN_H

#ifdef __cplusplus
extern "C" {
#endif

#define KNEESIM_PLUGIN_ABI_VERSION 2

#if defined(_WIN32)
#define KNEESIM_PLUGIN_EXPORT __declspec(dllexport)
#else
#define KNEESIM_PLUGIN_EXPORT __attribute__((visibility("default")))
#endif

/* A model parameter with bounds. */
typedef struct kneesim_param {
  const char* name;          /* identifier, e.g. "E" */
  const char* unit;          /* e.g. "Pa", "m", "1" */
  double lower;              /* bound used by the identification (may be -1e20) */
  double upper;              /* bound used by the identification (may be +1e20) */
  double default_value;      /* starting value; for effects, the value that gives the baseline back */
  double typical_scale;      /* magnitude used to scale sensitivities (> 0) */
  int fixed_by_default;      /* 1: held at default unless the setup frees it (e.g. a geometric radius) */
  const char* description;
} kneesim_param;

/* Per-frame time series handed to a law: channel c has values[c][0..n_frames-1].
 * Channel names used by the engine (a law lists the ones it needs in required_inputs):
 *   "time", "S", "S_medial", "S_lateral" (contact area), "dmin", "dmin_medial", "dmin_lateral"
 *   (signed minimum distance), "dS_dt" (and "dS_medial_dt", ...), "R" (cylinder radius), coordinates
 *   by model name (e.g. "knee_flexion", rad), and measured channels "GRF:<name>", "EMG:<name>". */
typedef struct kneesim_inputs {
  int n_frames;
  int n_channels;
  const char* const* names;
  const double* const* values;
} kneesim_inputs;

/* A contact law: force over a whole trial from its inputs and parameters. */
typedef struct kneesim_contact_law {
  int struct_size;            /* sizeof(kneesim_contact_law), for forward compatibility */
  const char* name;           /* unique, e.g. "hertz" */
  const char* description;
  int n_params;
  const kneesim_param* params;
  int n_inputs;
  const char* const* inputs;  /* channel names the law reads */
  /* force[i] for each frame; if dforce is not NULL also dforce[p * n_frames + i] = dF_i/dparam_p. */
  int (*calc_force)(const double* params, const kneesim_inputs* in, double* force, double* dforce,
                    char* err, int err_len);
  /* Optional quantities derived from the parameters that the data can determine even when the
   * parameters themselves are not (e.g. K = E / (1 - nu^2) for Hertz). May be 0 / NULL. */
  int n_derived;
  const char* const* derived_names;
  const char* const* derived_units;
  void (*calc_derived)(const double* params, double* out);
} kneesim_contact_law;

/* A triangle mesh handed to a distance provider (vertices in metres, 3 per vertex). */
typedef struct kneesim_mesh_view {
  int n_vertices;
  const double* vertices;
  int n_triangles;
  const int* triangles;
} kneesim_mesh_view;

/* Signed distance from query points to a closed target surface. */
typedef struct kneesim_distance_provider {
  int struct_size;
  const char* name;           /* e.g. "fcl" */
  const char* description;
  /* Prepares queries of points (given in frame Q) against the target mesh (frame T). */
  void* (*create)(const kneesim_mesh_view* target, int n_points, const double* points_Q, char* err, int err_len);
  /* X_TQ: pose of Q in T as a row-major 3x4 matrix [R | p]. Writes for every point its signed
   * distance to the target surface (negative inside the target). Points farther than max_distance
   * from the surface may get any value beyond max_distance on their side: > max_distance outside,
   * < -max_distance inside (e.g. +-infinity). closest_T (3 per point, may be NULL) receives the
   * closest target point for points within max_distance. A context may keep state between calls
   * (to exploit the coherence of successive poses): one thread at a time per context. */
  int (*compute)(void* ctx, const double* X_TQ, double max_distance, double* distance, double* closest_T,
                 char* err, int err_len);
  void (*destroy)(void* ctx);
} kneesim_distance_provider;

/* A gap-diagnosis effect (ABI version 2): a candidate explanation for the difference between a
 * contact law's force and the measured force, written as a NESTED extension of whatever baseline
 * law the user chose. With every parameter at its default_value the extended law must give the
 * baseline's force back exactly (default_value is "no effect": an exponent change of 0, a delay of
 * 0 s, a gain of 0 N), so the diagnosis can test the effect against the baseline.
 *
 * An effect acts in one or both of two places of the extended law
 *
 *     F = map_force_k( ... map_force_1( F_base( rewrite_inputs_k( ... rewrite_inputs_1(channels))))),
 *
 *  1. rewrite_inputs (optional): replaces the values of input channels before the baseline law
 *     sees them (a flexion offset changes S by dS_dflexion * offset; a proximity threshold moves S
 *     between the "S@3mm" and "S@5mm" channels). Laws give derivatives only with respect to their
 *     parameters, so the engine differentiates everything downstream of a rewrite with respect to
 *     the rewriting effect's parameters by central differences (about 1e-9 relative); a rewrite
 *     must therefore be a smooth function of its parameters (clamping an area at 0 is fine).
 *  2. map_force (optional): maps the baseline force of the whole trial to the effect's force
 *     (F_base * (S/S_ref)^dm, F_base(t - delay), F_base + gain * GRF). The map sees the whole
 *     series, so it may shift or filter it in time.
 *
 * Effects compose: the engine applies every rewrite in order, then the baseline law, then every
 * map in order. Parameters keep their own names in the table; the engine reports them as
 * "<effect>.<param>". Units are SI, like the laws'. */
typedef struct kneesim_effect {
  int struct_size;            /* sizeof(kneesim_effect), for forward compatibility */
  const char* name;           /* unique among effects, e.g. "time_delay" */
  const char* description;    /* one line: the formula */
  int n_params;
  const kneesim_param* params;  /* default_value gives the baseline back; bounds as for laws */
  int n_inputs;
  const char* const* inputs;  /* channels the effect reads; checked before the effect is used */

  /* Stage 1. n_rewrites channel names in rewrites[] (each must also be in inputs[]).
   * rewrite_inputs writes values[c * n_frames + i], the new value of channel rewrites[c] at frame
   * i (in sees the channels as rewritten by the effects before this one). NULL (and n_rewrites = 0)
   * for effects acting on the force only. */
  int n_rewrites;
  const char* const* rewrites;
  int (*rewrite_inputs)(const double* params, const kneesim_inputs* in, double* values, char* err, int err_len);

  /* Stage 2. base[i] is the force before this map (the baseline law's after all rewrites and the
   * earlier maps); write force[i]. When n_tangents > 0, tangent_in holds n_tangents series
   * (tangent_in[k * n_frames + i]: derivatives of base with respect to the other parameters); write
   * their images tangent_out[k * n_frames + i] = sum_j d force_i / d base_j * tangent_in[k * n_frames + j]
   * (for a pointwise map just d force_i / d base_i * tangent_in[...]). When dforce is not NULL write
   * dforce[p * n_frames + i] = d force_i / d param_p with base held fixed. NULL for effects acting on
   * the inputs only. */
  int (*map_force)(const double* params, const kneesim_inputs* in, const double* base, int n_tangents,
                   const double* tangent_in, double* force, double* tangent_out, double* dforce, char* err,
                   int err_len);

  /* Plain-language text for reports (may be NULL): the physics the effect stands for, and what
   * data would tell it apart from the effects it resembles. */
  const char* physics;
  const char* separated_by;
} kneesim_effect;

/* Handed to kneesim_plugin_register. Returns 0 if accepted, non-zero if the name is taken or the
 * table is invalid. */
typedef struct kneesim_registrar {
  int abi_version;
  void* host;
  int (*add_contact_law)(void* host, const kneesim_contact_law* law);
  int (*add_distance_provider)(void* host, const kneesim_distance_provider* provider);
  /* ABI version 2: gap-diagnosis effects (see kneesim_effect; plugins/README.md). Check
   * abi_version >= 2 before calling it. */
  int (*add_effect)(void* host, const kneesim_effect* effect);
} kneesim_registrar;

typedef int (*kneesim_plugin_register_fn)(const kneesim_registrar* r);

#ifdef __cplusplus
}
#endif

#endif /* KNEESIM_PLUGIN_H */
