// The packet search: eight query points walk the compact tree together, one AVX2 lane each.
//
// A node is opened when its lower bound is below the best distance found so far for any lane, so
// every lane gets exactly the answer of its own search (findClosestTree); the neighbouring points
// of a packet mostly need the same nodes, and one 8-wide test costs about what one scalar test
// does. Node bounds are in float (conservative, see Target::buildCompactTree), triangle distances
// in double. The functions carry target attributes and are chosen at run time
// (cpuHasPacketSearch), so the plugin itself needs no -mavx2 and runs on any x86-64.

#include <cmath>
#include <limits>

#include "target.hpp"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define KNEESIM_PACKET_SEARCH 1
#endif

namespace kneesim_distance_fcl {

#ifdef KNEESIM_PACKET_SEARCH

bool cpuHasPacketSearch() { return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"); }

// Helpers are always inlined into searchPacket: GCC inlines intrinsics only into functions that
// carry the same target.
#define KNEESIM_AVX2 __attribute__((target("avx2,fma"), always_inline)) inline

namespace {

KNEESIM_AVX2 __m256 toFloat8(const double* v, double origin) {
  const __m256d o = _mm256_set1_pd(origin);
  return _mm256_set_m128(_mm256_cvtpd_ps(_mm256_sub_pd(_mm256_load_pd(v + 4), o)),
                         _mm256_cvtpd_ps(_mm256_sub_pd(_mm256_load_pd(v), o)));
}

// Per lane, the best distance so far rounded up to float (culling stays conservative).
KNEESIM_AVX2 __m256 boundOf8(const double* best2) {
  const __m256d up = _mm256_set1_pd(1 + 1e-6), tiny = _mm256_set1_pd(1e-30);
  const __m256d b0 = _mm256_load_pd(best2), b1 = _mm256_load_pd(best2 + 4);
  // sqrt of a negative (unused) lane is NaN, which never compares below: such lanes need nothing.
  const __m128 f0 = _mm256_cvtpd_ps(_mm256_fmadd_pd(_mm256_sqrt_pd(b0), up, tiny));
  const __m128 f1 = _mm256_cvtpd_ps(_mm256_fmadd_pd(_mm256_sqrt_pd(b1), up, tiny));
  return _mm256_set_m128(f1, f0);
}

// Row r of the node's axes times each lane's point, minus the rectangle's offset.
KNEESIM_AVX2 __m256 rowDot8(const Target::Node& nd, int r, __m256 px, __m256 py, __m256 pz) {
  return _mm256_fmadd_ps(_mm256_set1_ps(nd.ax[3 * r + 2]), pz,
                         _mm256_fmadd_ps(_mm256_set1_ps(nd.ax[3 * r + 1]), py,
                                         _mm256_fmsub_ps(_mm256_set1_ps(nd.ax[3 * r]), px, _mm256_set1_ps(nd.c[r]))));
}

// Lower bound on the distance from each lane's point to anything inside the node.
KNEESIM_AVX2 __m256 lowerBound8(const Target::Node& nd, __m256 px, __m256 py, __m256 pz) {
  const __m256 q0 = rowDot8(nd, 0, px, py, pz), q1 = rowDot8(nd, 1, px, py, pz), q2 = rowDot8(nd, 2, px, py, pz);
  const __m256 zero = _mm256_setzero_ps();
  const __m256 a = _mm256_add_ps(_mm256_min_ps(q0, zero), _mm256_max_ps(_mm256_sub_ps(q0, _mm256_set1_ps(nd.l0)), zero));
  const __m256 b = _mm256_add_ps(_mm256_min_ps(q1, zero), _mm256_max_ps(_mm256_sub_ps(q1, _mm256_set1_ps(nd.l1)), zero));
  const __m256 s = _mm256_fmadd_ps(q2, q2, _mm256_fmadd_ps(b, b, _mm256_mul_ps(a, a)));
  return _mm256_sub_ps(_mm256_sqrt_ps(s), _mm256_set1_ps(nd.r));
}

KNEESIM_AVX2 __m256d dot4(__m256d x, __m256d y, __m256d z, const Vec3& v) {
  return _mm256_fmadd_pd(z, _mm256_set1_pd(v[2]), _mm256_fmadd_pd(y, _mm256_set1_pd(v[1]), _mm256_mul_pd(x, _mm256_set1_pd(v[0]))));
}

KNEESIM_AVX2 bool anyBelow(__m256 lb, __m256 bound) {
  return _mm256_movemask_ps(_mm256_cmp_ps(lb, bound, _CMP_LT_OQ)) != 0;
}

// Distance of the points of the lanes set in `lanes` (and their half-packet's) to triangle t, in
// double; lanes it beats take it. The distance
// is the plane's where the point projects inside the triangle, else the nearest edge segment's:
// the value calcClosestOnTriangle gives, without branches. Returns whether a lane improved.
KNEESIM_AVX2 bool leafTest8(const Target& tg, int t, int lanes, Packet& pk) {
  const Eigen::Vector3i& tri = tg.getTriangle(t);
  const Vec3* o[3] = {&tg.getVertex(tri[0]), &tg.getVertex(tri[1]), &tg.getVertex(tri[2])};
  const Vec3& n = tg.getFaceNormal(t);
  const Vec3 e[3] = {*o[1] - *o[0], *o[2] - *o[1], *o[0] - *o[2]};
  const Vec3 m[3] = {n.cross(e[0]), n.cross(e[1]), n.cross(e[2])};  // in-plane edge normals, pointing in
  double inv[3];
  for (int k = 0; k < 3; ++k) {
    const double l2 = e[k].squaredNorm();
    inv[k] = l2 > 0 ? 1 / l2 : 0;
  }
  const bool flat = n.squaredNorm() == 0;  // a degenerate triangle has no face region
  const __m256d inf = _mm256_set1_pd(std::numeric_limits<double>::infinity());
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
  bool improved = false;
  for (int h = 0; h < 8; h += 4) {
    if (!((lanes >> h) & 15)) continue;  // no lane of this half needs the triangle
    const __m256d x = _mm256_load_pd(pk.x + h), y = _mm256_load_pd(pk.y + h), z = _mm256_load_pd(pk.z + h);
    __m256d rx[3], ry[3], rz[3];
    for (int k = 0; k < 3; ++k) {
      rx[k] = _mm256_sub_pd(x, _mm256_set1_pd((*o[k])[0]));
      ry[k] = _mm256_sub_pd(y, _mm256_set1_pd((*o[k])[1]));
      rz[k] = _mm256_sub_pd(z, _mm256_set1_pd((*o[k])[2]));
    }
    __m256d d2 = inf;
    if (!flat) {
      __m256d in = _mm256_cmp_pd(dot4(rx[0], ry[0], rz[0], m[0]), zero, _CMP_GE_OQ);
      in = _mm256_and_pd(in, _mm256_cmp_pd(dot4(rx[1], ry[1], rz[1], m[1]), zero, _CMP_GE_OQ));
      in = _mm256_and_pd(in, _mm256_cmp_pd(dot4(rx[2], ry[2], rz[2], m[2]), zero, _CMP_GE_OQ));
      const __m256d sd = dot4(rx[0], ry[0], rz[0], n);
      d2 = _mm256_blendv_pd(inf, _mm256_mul_pd(sd, sd), in);
    }
    for (int k = 0; k < 3; ++k) {
      __m256d u = _mm256_mul_pd(dot4(rx[k], ry[k], rz[k], e[k]), _mm256_set1_pd(inv[k]));
      u = _mm256_min_pd(_mm256_max_pd(u, zero), one);
      const __m256d vx = _mm256_fnmadd_pd(u, _mm256_set1_pd(e[k][0]), rx[k]);
      const __m256d vy = _mm256_fnmadd_pd(u, _mm256_set1_pd(e[k][1]), ry[k]);
      const __m256d vz = _mm256_fnmadd_pd(u, _mm256_set1_pd(e[k][2]), rz[k]);
      d2 = _mm256_min_pd(d2, _mm256_fmadd_pd(vz, vz, _mm256_fmadd_pd(vy, vy, _mm256_mul_pd(vx, vx))));
    }
    const __m256d best = _mm256_load_pd(pk.best2 + h);
    const int better = _mm256_movemask_pd(_mm256_cmp_pd(d2, best, _CMP_LT_OQ));
    if (better) {
      _mm256_store_pd(pk.best2 + h, _mm256_min_pd(d2, best));
      for (int k = 0; k < 4; ++k)
        if (better & (1 << k)) pk.tri[h + k] = t;
      improved = true;
    }
  }
  return improved;
}

__attribute__((target("avx2,fma"))) void searchPacketAvx2(const Target& tg, Packet& pk) {
  const std::vector<Target::Node>& nodes = tg.getNodes();
  const Vec3& origin = tg.getOrigin();
  const __m256 px = toFloat8(pk.x, origin[0]), py = toFloat8(pk.y, origin[1]), pz = toFloat8(pk.z, origin[2]);
  __m256 bound = boundOf8(pk.best2);
  // Depth-first; each entry keeps the bounds it was pushed with, re-checked when popped. The stack
  // holds at most depth + 1 entries, and FCL's median split keeps the depth near log2(triangles).
  int stack_node[128];
  __m256 stack_lb[128];
  int top = 0;
  const __m256 root = lowerBound8(nodes[0], px, py, pz);
  if (!anyBelow(root, bound)) return;
  stack_node[top] = 0;
  stack_lb[top++] = root;
  while (top > 0) {
    --top;
    const int lanes = _mm256_movemask_ps(_mm256_cmp_ps(stack_lb[top], bound, _CMP_LT_OQ));
    if (!lanes) continue;
    const int k = stack_node[top];
    const Target::Node& nd = nodes[size_t(k)];
    if (nd.child < 0) {
      if (leafTest8(tg, -nd.child - 1, lanes, pk)) bound = boundOf8(pk.best2);
      continue;
    }
    const int a = nd.child, b = nd.child + 1;
    const __m256 la = lowerBound8(nodes[size_t(a)], px, py, pz);
    const __m256 lb = lowerBound8(nodes[size_t(b)], px, py, pz);
    const bool na = anyBelow(la, bound), nb = anyBelow(lb, bound);
    // The child nearer for most lanes is visited first (pushed last).
    const bool left_first = __builtin_popcount(unsigned(_mm256_movemask_ps(_mm256_cmp_ps(la, lb, _CMP_LE_OQ)))) >= 4;
    if (left_first) {
      if (nb) stack_node[top] = b, stack_lb[top++] = lb;
      if (na) stack_node[top] = a, stack_lb[top++] = la;
    } else {
      if (na) stack_node[top] = a, stack_lb[top++] = la;
      if (nb) stack_node[top] = b, stack_lb[top++] = lb;
    }
  }
}

}  // namespace

void Target::searchPacket(Packet& pk) const { searchPacketAvx2(*this, pk); }

#else

bool cpuHasPacketSearch() { return false; }
void Target::searchPacket(Packet&) const {}

#endif

}  // namespace kneesim_distance_fcl
