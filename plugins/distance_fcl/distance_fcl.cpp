// The distance_fcl providers: signed distances from a fixed set of query points to a closed
// triangle mesh, over FCL 0.7's bounding-volume tree of the mesh.
//
// FCL's own point (radius-0 sphere) to mesh distance is unsigned, and on a knee implant it costs
// 10-15 us per point whether or not DistanceResult::min_distance is preset to a bound: it turns the
// point into an RSS and runs ~75 rectangle-to-rectangle RSS tests (~150 ns each) per query even
// when the bound is the exact answer (measured on JW's femoral component, 80,774 triangles). A map
// of a few thousand points a frame needs less, so the "fcl" provider:
//
//  - Tree. FCL builds and fits its OBBRSS hierarchy over the mesh (median split). The provider
//    copies each node's RSS (rectangle swept sphere) into a compact single-precision array in
//    depth-first order and walks it with a point-to-rectangle test (target.cpp).
//  - Packets. Points are searched eight at a time, one AVX2 lane each (packet.cpp): a node is
//    opened if any lane needs it, and neighbouring points mostly need the same nodes. Each lane
//    still gets the exact answer of its own search. Without AVX2 the points go one at a time.
//  - Sign. The closest point on the closest triangle and its Voronoi feature (vertex, edge or face)
//    are computed exactly in double precision, and the distance is signed by that feature's
//    angle-weighted pseudonormal (Baerentzen & Aanaes 2005): negative inside. Exact for a closed,
//    consistently oriented mesh, which create() checks.
//  - Pruning. A query searches only within a bound: the search band (max_distance plus a margin)
//    or, tighter, the distance to the point's closest triangle of the previous call.
//  - Culling. Query points are grouped into small spatial clusters. A cluster whose centre is
//    farther than max_distance + its radius + margin from the surface (one bounded query) is
//    skipped whole; its points are all on the side of the centre, since the ball around the centre
//    contains no surface.
//  - Temporal coherence. Each point keeps a lower bound on |distance| at the position where it was
//    last computed. The distance is 1-Lipschitz, so while the point has moved less than
//    (bound - max_distance) it is still beyond max_distance, on the same side: no query at all.
//  - Inside test. A point beyond the search radius whose side is not known from the above gets
//    one unbounded query: the pseudonormal of the true closest feature gives its side.
//
// Every distance within max_distance is exact (to rounding); coherence only saves work. A context
// holds the per-point state, so it is used by one thread at a time.
//
// Two more providers share this code for comparison (tools/benchmarks/contact_area_bench.cpp):
//  - "fcl_pruned": the same culling, coherence and sign, but every query is FCL's own
//    fcl::distance with DistanceResult preset to the bound;
//  - "fcl_naive": one unbounded fcl::distance per point, no culling, bound or coherence.
// and "fcl_sdf" (sdf.cpp) trades exactness for speed with a cached grid.

#include "distance_fcl.hpp"
#include "sdf.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <memory>
#include <new>
#include <numeric>

namespace kneesim_distance_fcl {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Largest number of points per culling cluster, and fewest pending points worth a cluster query.
constexpr int kClusterSize = 24;
constexpr int kMinClusterQuery = 6;
// The search band is max_distance plus this fraction of it (at least kMinMargin metres): wider
// bands let far points stay culled longer but make every point in the band cost a query.
constexpr double kMarginFraction = 0.25;
constexpr double kMinMargin = 0.5e-3;

// The closest triangle to p nearer than bound, or -1, by FCL's own query, seeded by a hint.
int findClosestPruned(const Target& tg, const Vec3& p, double bound, int hint) {
  if (hint >= 0) {
    const double u = tg.unsignedDistance(p, hint);
    if (u < bound) {
      // FCL keeps a triangle only if strictly closer than the preset bound: allow for rounding.
      const int t = tg.findClosestFcl(p, u * (1 + 1e-9) + 1e-15);
      return t >= 0 ? t : hint;
    }
  }
  return tg.findClosestFcl(p, bound);
}

}  // namespace

void writeError(char* err, int err_len, const std::string& msg) {
  if (!err || err_len <= 0) return;
  std::snprintf(err, size_t(err_len), "%s", msg.c_str());
}

int ExactMap::findClosest(const Vec3& p, double bound, int hint) const {
  return mode == Mode::fast ? target.findClosestTree(p, bound, hint) : findClosestPruned(target, p, bound, hint);
}

// Orders order[begin, end) as a k-d tree (median split on the longest axis of the points'
// bounding box, down to single points), so that consecutive points are neighbours, and makes the
// subtrees of at most kClusterSize points the clusters.
void ExactMap::buildClusters(int begin, int end) {
  if (end - begin > 1) {
    Eigen::AlignedBox3d box;
    for (int i = begin; i < end; ++i) box.extend(points_Q[size_t(order[size_t(i)])]);
    int axis;
    box.sizes().maxCoeff(&axis);
    const int mid = (begin + end) / 2;
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                     [&](int a, int b) { return points_Q[size_t(a)][axis] < points_Q[size_t(b)][axis]; });
    const size_t first = clusters.size();
    buildClusters(begin, mid);
    buildClusters(mid, end);
    if (end - begin > kClusterSize) return;
    clusters.resize(first);  // this subtree is small enough to be one cluster
  }
  Cluster k;
  k.begin = begin;
  k.end = end;
  for (int i = begin; i < end; ++i) k.centre_Q += points_Q[size_t(order[size_t(i)])];
  k.centre_Q /= double(end - begin);
  clusters.push_back(k);
}

std::string ExactMap::init(const kneesim_mesh_view& view, int n_points, const double* points, Mode m) {
  mode = m;
  const std::string problem = target.build(view, mode == Mode::fast);
  if (!problem.empty()) return problem;
  // A diagnostic switch (tests compare both searches): the scalar search even on an AVX2 CPU.
  if (mode == Mode::fast && std::getenv("KNEESIM_DISTANCE_FCL_SCALAR")) target.setUsePackets(false);
  points_Q.resize(size_t(n_points));
  for (int i = 0; i < n_points; ++i) {
    points_Q[size_t(i)] = Vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
    if (!points_Q[size_t(i)].allFinite())
      return "expected finite query points, got a non-finite one at point " + std::to_string(i);
  }
  order.resize(size_t(n_points));
  std::iota(order.begin(), order.end(), 0);
  if (n_points > 0) buildClusters(0, n_points);
  cluster_T.resize(clusters.size());
  state.resize(size_t(n_points));
  p_T.resize(size_t(n_points));
  pending.reserve(size_t(n_points));
  pending_cluster.reserve(size_t(n_points));
  pending_p.reserve(size_t(n_points));
  pending_hint.reserve(size_t(n_points));
  found.reserve(size_t(n_points));
  return "";
}

// Records a computed distance d (closest point q on triangle t) for point i.
void ExactMap::store(int i, const Vec3& p, double d, int t, const Vec3& q, double max_distance, double* distance,
                     double* closest_T) {
  distance[i] = d;
  if (closest_T) {
    const bool near = std::abs(d) <= max_distance;
    for (int k = 0; k < 3; ++k) closest_T[3 * i + k] = near ? q[k] : kNaN;
  }
  PointState& s = state[size_t(i)];
  s.p_ref = p;
  s.lower = std::abs(d);
  s.triangle = t;
  s.side = d < 0 ? -1 : 1;
}

// Records a point known to be farther than `lower` from the surface, on side `side`.
void ExactMap::storeFar(int i, const Vec3& p, double lower, signed char side, double* distance, double* closest_T) {
  distance[i] = side < 0 ? -kInf : kInf;
  if (closest_T)
    for (int k = 0; k < 3; ++k) closest_T[3 * i + k] = kNaN;
  PointState& s = state[size_t(i)];
  s.p_ref = p;
  s.lower = lower;
  s.side = side;
}

double ExactMap::unboundedDistance(const Vec3& p, int& t, Vec3& q) {
  ++stats.unbounded_queries;
  t = findClosest(p, kInf, -1);
  if (t < 0) return kInf;  // cannot happen for a non-empty mesh
  return target.signedDistance(p, t, q);
}

void ExactMap::computeNaive(const Eigen::Matrix3d& R, const Vec3& t, double max_distance, double* distance,
                            double* closest_T) {
  const int n = int(points_Q.size());
  for (int i = 0; i < n; ++i) {
    const Vec3 p = R * points_Q[size_t(i)] + t;
    int tri;
    Vec3 q;
    const double d = unboundedDistance(p, tri, q);
    distance[i] = d;
    if (closest_T) {
      const bool near = std::abs(d) <= max_distance;
      for (int k = 0; k < 3; ++k) closest_T[3 * i + k] = near ? q[k] : kNaN;
    }
  }
}

void ExactMap::computeFast(const Eigen::Matrix3d& R, const Vec3& t, double max_distance, double* distance,
                           double* closest_T) {
  // The margin widens the band a query searches so that a point or cluster found beyond it stays
  // provably far for the next few frames of a slow motion without any query.
  const double margin = std::isfinite(max_distance) ? std::max(kMarginFraction * max_distance, kMinMargin) : 0.0;
  const double search = max_distance + margin;
  pending.clear();
  pending_cluster.clear();
  for (size_t kc = 0; kc < clusters.size(); ++kc) {
    const Cluster& k = clusters[kc];
    const size_t first = pending.size();
    for (int j = k.begin; j < k.end; ++j) {
      const int i = order[size_t(j)];
      const Vec3 p = R * points_Q[size_t(i)] + t;
      p_T[size_t(i)] = p;
      const PointState& s = state[size_t(i)];
      if (s.side != 0 && s.lower - (p - s.p_ref).norm() > max_distance) {
        // Still beyond max_distance, on the same side (the distance is 1-Lipschitz).
        ++stats.coherent_skips;
        distance[i] = s.side < 0 ? -kInf : kInf;
        if (closest_T)
          for (int m = 0; m < 3; ++m) closest_T[3 * i + m] = kNaN;
        continue;
      }
      pending.push_back(i);
      pending_cluster.push_back(int(kc));
    }
    if (pending.size() == first) continue;

    // Cluster test: one query at the centre bounds every pending point's distance from below.
    ClusterPose& kt = cluster_T[kc];
    kt.centre = R * k.centre_Q + t;
    kt.lower = 0;
    kt.side = 0;
    // Worth it only when no pending point was near last time (a cold start, or a cluster that
    // has just come back into reach): in contact, a cluster query would be wasted.
    bool maybe_far = int(pending.size() - first) >= kMinClusterQuery && std::isfinite(max_distance);
    for (size_t j = first; maybe_far && j < pending.size(); ++j) {
      const PointState& s = state[size_t(pending[j])];
      if (s.side != 0 && s.lower <= search) maybe_far = false;
    }
    if (!maybe_far) continue;
    double reach = 0;
    for (size_t j = first; j < pending.size(); ++j) reach = std::max(reach, (p_T[size_t(pending[j])] - kt.centre).norm());
    const double bound = search + reach;
    ++stats.cluster_queries;
    const int tri = findClosest(kt.centre, bound, -1);
    Vec3 q;
    if (tri >= 0) {
      const double dc = target.signedDistance(kt.centre, tri, q);
      kt.lower = std::abs(dc);
      kt.side = dc < 0 ? -1 : 1;
    } else {
      kt.lower = bound;
    }
    if (kt.lower - reach <= max_distance) continue;
    // No surface within kt.lower of the centre: every pending point is far and on the centre's
    // side. Find the side from a point that kept its own, else by an inside test.
    if (kt.side == 0)
      for (size_t j = first; j < pending.size(); ++j) {
        const PointState& s = state[size_t(pending[j])];
        if (s.side != 0 && (p_T[size_t(pending[j])] - s.p_ref).norm() < s.lower) {
          kt.side = s.side;
          break;
        }
      }
    if (kt.side == 0) {
      int t2;
      const double dc = unboundedDistance(kt.centre, t2, q);
      kt.side = dc < 0 ? -1 : 1;
    }
    ++stats.cluster_culled;
    for (size_t j = first; j < pending.size(); ++j) {
      const int i = pending[j];
      const Vec3& p = p_T[size_t(i)];
      storeFar(i, p, kt.lower - (p - kt.centre).norm(), kt.side, distance, closest_T);
    }
    pending.resize(first);
    pending_cluster.resize(first);
  }

  queryPendingPoints(max_distance, search, distance, closest_T);
}

void ExactMap::queryPendingPoints(double max_distance, double search, double* distance, double* closest_T) {
  // Point queries, pruned by the previous closest triangle or the search band; in packets of
  // neighbouring points (the pending list follows the clusters' spatial order).
  const int n = int(pending.size());
  stats.point_queries += n;
  pending_p.resize(size_t(n));
  pending_hint.resize(size_t(n));
  found.resize(size_t(n));
  for (int j = 0; j < n; ++j) {
    pending_p[size_t(j)] = p_T[size_t(pending[size_t(j)])];
    pending_hint[size_t(j)] = state[size_t(pending[size_t(j)])].triangle;
  }
  if (mode == Mode::fast) {
    target.findClosestBatch(pending_p.data(), n, pending_hint.data(), search, found.data());
  } else {
    for (int j = 0; j < n; ++j)
      found[size_t(j)] = findClosestPruned(target, pending_p[size_t(j)], search, pending_hint[size_t(j)]);
  }
  for (int j = 0; j < n; ++j) {
    const int i = pending[size_t(j)];
    const Vec3& p = pending_p[size_t(j)];
    const PointState& s = state[size_t(i)];
    int tri = found[size_t(j)];
    Vec3 q;
    if (tri >= 0) {
      store(i, p, target.signedDistance(p, tri, q), tri, q, max_distance, distance, closest_T);
      continue;
    }
    // Beyond the search band: which side?
    const ClusterPose& kt = cluster_T[size_t(pending_cluster[size_t(j)])];
    signed char side = 0;
    if (s.side != 0 && (p - s.p_ref).norm() < s.lower) side = s.side;
    if (side == 0 && kt.side != 0 && (p - kt.centre).norm() < kt.lower) side = kt.side;
    if (side == 0) {
      const double d = unboundedDistance(p, tri, q);
      store(i, p, d, tri, q, max_distance, distance, closest_T);
      continue;
    }
    storeFar(i, p, search, side, distance, closest_T);
  }
}

int ExactMap::compute(const Eigen::Matrix3d& R, const Vec3& t, double max_distance, double* distance,
                      double* closest_T) {
  ++stats.calls;
  stats.points += long(points_Q.size());
  if (mode == Mode::fcl_naive)
    computeNaive(R, t, max_distance, distance, closest_T);
  else
    computeFast(R, t, max_distance, distance, closest_T);
  return 0;
}

bool readPose(const double* X_TQ, double max_distance, Eigen::Matrix3d& R, Vec3& t, char* err, int err_len) {
  if (!(max_distance > 0)) {  // also rejects NaN
    writeError(err, err_len, "expected a positive max_distance, got " + std::to_string(max_distance));
    return false;
  }
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) R(r, k) = X_TQ[4 * r + k];
    t[r] = X_TQ[4 * r + 3];
  }
  if (!R.allFinite() || !t.allFinite()) {
    writeError(err, err_len, "expected a finite pose X_TQ, got a non-finite entry");
    return false;
  }
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6 || R.determinant() < 0) {
    writeError(err, err_len, "expected a rotation in X_TQ, got a matrix that is not orthonormal");
    return false;
  }
  return true;
}

bool readCall(bool have_context, size_t n_points, const double* X_TQ, double max_distance, const double* distance,
              Eigen::Matrix3d& R, Vec3& t, char* err, int err_len) {
  if (!have_context || !X_TQ || (!distance && n_points > 0)) {
    writeError(err, err_len, "expected a context, a pose and an output array, got a null pointer");
    return false;
  }
  return readPose(X_TQ, max_distance, R, t, err, err_len);
}

namespace {

void* createExact(const kneesim_mesh_view* target, int n_points, const double* points_Q, char* err, int err_len,
                  Mode mode) {
  return createProvider<ExactMap>(target, n_points, points_Q, err, err_len, mode);
}

void* createFast(const kneesim_mesh_view* target, int n_points, const double* points_Q, char* err, int err_len) {
  return createExact(target, n_points, points_Q, err, err_len, Mode::fast);
}
void* createPruned(const kneesim_mesh_view* target, int n_points, const double* points_Q, char* err, int err_len) {
  return createExact(target, n_points, points_Q, err, err_len, Mode::fcl_pruned);
}
void* createNaive(const kneesim_mesh_view* target, int n_points, const double* points_Q, char* err, int err_len) {
  return createExact(target, n_points, points_Q, err, err_len, Mode::fcl_naive);
}

int computeExact(void* ctx, const double* X_TQ, double max_distance, double* distance, double* closest_T, char* err,
                 int err_len) {
  ExactMap* c = static_cast<ExactMap*>(static_cast<ProviderContext*>(ctx));
  Eigen::Matrix3d R;
  Vec3 t;
  if (!readCall(c, c ? c->points_Q.size() : 0, X_TQ, max_distance, distance, R, t, err, err_len)) return 1;
  try {
    return c->compute(R, t, max_distance, distance, closest_T);
  } catch (const std::exception& e) {
    writeError(err, err_len, std::string("FCL distance query failed: ") + e.what());
    return 1;
  }
}

void destroyExact(void* ctx) { delete static_cast<ProviderContext*>(ctx); }

const kneesim_distance_provider kFcl = {
    int(sizeof(kneesim_distance_provider)),
    "fcl",
    "signed point-to-mesh distance over FCL 0.7's OBBRSS tree with point-specialised traversal (AVX2 packets of "
    "8 points where available); pruned, culled and coherent across calls; sign from the closest feature's "
    "pseudonormal; exact",
    createFast,
    computeExact,
    destroyExact};

const kneesim_distance_provider kFclPruned = {
    int(sizeof(kneesim_distance_provider)),
    "fcl_pruned",
    "as fcl, but every query is FCL's own fcl::distance with DistanceResult preset to the bound",
    createPruned,
    computeExact,
    destroyExact};

const kneesim_distance_provider kFclNaive = {
    int(sizeof(kneesim_distance_provider)),
    "fcl_naive",
    "one unbounded FCL query per point (no pruning, culling or coherence): the benchmark's reference",
    createNaive,
    computeExact,
    destroyExact};

}  // namespace
}  // namespace kneesim_distance_fcl

extern "C" {

/// Diagnostic counters of a context created by this plugin's exact providers (not part of the
/// plugin ABI; the benchmark finds it with dlsym): calls, points, coherent skips, cluster queries,
/// clusters culled, point queries, unbounded queries. Writes at most n values; returns how many it
/// has.
KNEESIM_PLUGIN_EXPORT int kneesim_distance_fcl_get_stats(void* ctx, long long* out, int n) {
  const kneesim_distance_fcl::ExactStats& s = kneesim_distance_fcl::getExactStats(ctx);
  const long long v[] = {s.calls,          s.points,        s.coherent_skips,   s.cluster_queries,
                         s.cluster_culled, s.point_queries, s.unbounded_queries};
  const int m = int(sizeof(v) / sizeof(v[0]));
  for (int i = 0; i < std::min(n, m); ++i) out[i] = v[i];
  return m;
}

/// Counters of an "fcl_sdf" context (not part of the plugin ABI): grid nodes evaluated, unbounded
/// queries for the side of a node beyond the band, cells classified, of them exact, of them beyond the band, points
/// interpolated, points computed exactly, points far without a query, grid resets, blocks.
/// Writes at most n values; returns how many it has, or 0 for another provider's context.
KNEESIM_PLUGIN_EXPORT int kneesim_distance_fcl_get_sdf_stats(void* ctx, long long* out, int n) {
  const kneesim_distance_fcl::SdfStats* s = kneesim_distance_fcl::findSdfStats(ctx);
  if (!s) return 0;
  const long long v[] = {s->nodes,        s->side_queries,    s->cells,      s->cells_exact, s->cells_far,
                         s->interpolated, s->exact_points, s->far_points, s->resets,      s->blocks};
  const int m = int(sizeof(v) / sizeof(v[0]));
  for (int i = 0; i < std::min(n, m); ++i) out[i] = v[i];
  return m;
}

KNEESIM_PLUGIN_EXPORT int kneesim_plugin_register(const kneesim_registrar* r) {
  using namespace kneesim_distance_fcl;
  if (!r || r->abi_version != KNEESIM_PLUGIN_ABI_VERSION) return 1;
  if (r->add_distance_provider(r->host, &kFcl) != 0) return 1;
  if (r->add_distance_provider(r->host, &kFclPruned) != 0) return 1;
  if (r->add_distance_provider(r->host, &kFclNaive) != 0) return 1;
  if (r->add_distance_provider(r->host, &getSdfProvider()) != 0) return 1;
  return 0;
}

}  // extern "C"
