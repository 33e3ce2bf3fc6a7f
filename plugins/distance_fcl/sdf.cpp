// The "fcl_sdf" provider: a narrow-band signed distance grid of the target, filled lazily with
// exact values and cached in the context across calls; approximate, within a stated tolerance.
//
//  - Nodes. A regular grid (spacing h = 0.5 mm) over the target's box, padded by the band. A
//    node is computed only when a query point first lands in one of its cells, and then exactly
//    (the "fcl" packet search and pseudonormal sign), with its closest triangle and its exact
//    gradient (node - closest point) / distance. Nodes live in blocks of 8 x 8 x 8 allocated on
//    first use: the cache grows while a trial visits new places and then stops allocating.
//  - Band. Nodes farther than the band from the surface keep only their side. The band is
//    max_distance + the cell diagonal (+5%): a cell with a node beyond it lies entirely beyond
//    max_distance (the distance is 1-Lipschitz), on that node's side, and its points are reported
//    as +-infinity without interpolation. A call with a larger max_distance rebuilds the grid.
//  - Cells. A cell whose eight nodes are in the band is interpolated trilinearly if its error
//    estimate is within the tolerance (20 um), else its points get exact queries. Along a line,
//    linear interpolation between two nodes h apart errs by at most h/4 times the change of the
//    derivative between them when the derivative is monotone on the way (one kink, or a convex
//    or concave stretch; h/8 for a parabola); the estimate adds these over the three axes, with
//    each axis's largest change of the gradient component along the cell's four edges in that
//    direction. Where the closest point jumps (the medial axis, a sharp edge, two condyles
//    equally near) the gradients differ by O(1) and the cell goes exact.
//
// The estimate is not a proof (a kink can hide between nodes whose gradients agree); the
// tolerance is what the tests check against the exact MeshDistance (a sphere, JW's implant over
// seated and penetrating poses). It is of the order of the faceting of the target itself: JW's
// femoral component (median edge 0.44 mm, 10% of edges over 1.4 mm, condyle radii 20-37 mm)
// departs from a smooth surface by l^2 / 8R = 1-13 um.
//
// The first frames of a trial pay for the nodes they touch (one exact query each, about as many
// nodes as point queries for a 1-degree-per-frame motion); frames that stay in known cells cost a
// lookup and an interpolation per point.

#include "sdf.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>

namespace kneesim_distance_fcl {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr float kUnset = std::numeric_limits<float>::quiet_NaN();
inline int local(int i, int j, int k) { return (i & 7) + 8 * ((j & 7) + 8 * (k & 7)); }
}  // namespace

std::string SdfMap::init(const kneesim_mesh_view& view, int n_points, const double* points) {
  const std::string problem = exact.init(view, n_points, points, Mode::fast);
  if (!problem.empty()) return problem;
  // Keep the grid within about 1000 nodes per axis on large meshes.
  h = std::max(h, exact.target.getBox().sizes().maxCoeff() / 1000);
  const size_t n = size_t(n_points);
  hint_.assign(n, -1);
  p_T_.resize(n);
  cell_.resize(n);
  fallback_.reserve(n);
  fallback_p_.reserve(n);
  fallback_hint_.reserve(n);
  fallback_found_.reserve(n);
  return "";
}

void SdfMap::reset(double band) {
  if (band_ > 0) ++sdf.resets;
  band_ = band;
  const Eigen::AlignedBox3d& box = exact.target.getBox();
  const double pad = band + 2 * h;
  origin_ = box.min() - Vec3::Constant(pad);
  for (int a = 0; a < 3; ++a) {
    n_[a] = int(std::ceil((box.max()[a] - box.min()[a] + 2 * pad) / h)) + 2;
    nb_[a] = (n_[a] + kB - 1) / kB;
  }
  block_index_.assign(size_t(nb_[0]) * size_t(nb_[1]) * size_t(nb_[2]), -1);
  blocks_.clear();
}

SdfMap::Block& SdfMap::getBlock(int i, int j, int k) {
  const int bx = i >> 3, by = j >> 3, bz = k >> 3;
  int32_t& slot = block_index_[size_t(bx) + size_t(nb_[0]) * (size_t(by) + size_t(nb_[1]) * size_t(bz))];
  if (slot < 0) {
    slot = int32_t(blocks_.size());
    Block& b = blocks_.emplace_back();
    std::fill(std::begin(b.d), std::end(b.d), kUnset);
    std::fill(std::begin(b.tri), std::end(b.tri), kNoNode);
    std::memset(b.cell, kUnknown, sizeof b.cell);
    ++sdf.blocks;
  }
  return blocks_[size_t(slot)];
}

uint8_t SdfMap::classify(int i, int j, int k) {
  ++sdf.cells;
  Block* blk[8];
  int at[8];
  for (int m = 0; m < 8; ++m) {
    const int ii = i + (m & 1), jj = j + ((m >> 1) & 1), kk = k + ((m >> 2) & 1);
    blk[m] = &getBlock(ii, jj, kk);
    at[m] = local(ii, jj, kk);
  }
  const double diag = h * std::sqrt(3.0);
  int far_unknown = -1;
  float side = 0;
  for (int m = 0; m < 8; ++m) {
    const int t = blk[m]->tri[at[m]];
    const float d = blk[m]->d[at[m]];
    if (t == kFarUnknown) far_unknown = m;
    // A node farther than the diagonal from the surface has the side of every point of the cell.
    if (side == 0 && (t >= 0 || t == kFar) && std::abs(d) > diag) side = d > 0 ? 1.0f : -1.0f;
  }
  bool far = far_unknown >= 0;
  for (int m = 0; m < 8 && !far; ++m) far = blk[m]->tri[at[m]] == kFar;
  if (far) {
    // The cell lies beyond band - diagonal >= max_distance, on one side.
    ++sdf.cells_far;
    if (side == 0) {
      // No known side in the cell: an unbounded query at a far node.
      ++sdf.side_queries;
      const int m = far_unknown;
      const Vec3 c = origin_ + h * Vec3(i + (m & 1), j + ((m >> 1) & 1), k + ((m >> 2) & 1));
      Vec3 q;
      const int t = exact.target.findClosestTree(c, kInf, -1);
      side = exact.target.signedDistance(c, t, q) < 0 ? -1.0f : 1.0f;
    }
    for (int m = 0; m < 8; ++m)
      if (blk[m]->tri[at[m]] == kFarUnknown) {
        blk[m]->tri[at[m]] = kFar;
        blk[m]->d[at[m]] = side * std::numeric_limits<float>::infinity();
      }
    return side > 0 ? kFarOut : kFarIn;
  }
  // Error estimate from the exact gradients at the nodes: h/4 sum_a max_edges |change of g_a|.
  double estimate = 0;
  for (int a = 0; a < 3; ++a) {
    double worst = 0;
    for (int m = 0; m < 8; ++m)
      if (!(m & (1 << a))) {
        const int e = m | (1 << a);
        worst = std::max(worst, std::abs(int(blk[e]->g[a][at[e]]) - int(blk[m]->g[a][at[m]])) / kGradScale);
      }
    estimate += worst;
  }
  estimate *= h / 4;
  if (estimate > tolerance) {
    ++sdf.cells_exact;
    return kExact;
  }

  return kInterpolate;
}

int SdfMap::compute(const Eigen::Matrix3d& R, const Vec3& t, double max_distance, double* distance,
                    double* closest_T) {
  ++stats.calls;
  stats.points += long(hint_.size());
  if (!std::isfinite(max_distance)) {
    // No band can hold every distance: the exact path.
    sdf.exact_points += long(hint_.size());
    return exact.compute(R, t, max_distance, distance, closest_T);
  }
  const double diag = h * std::sqrt(3.0);
  if (band_ < max_distance + diag) reset(1.05 * max_distance + diag);  // a little room for a wider call

  // 1. Each point's cell; cells seen for the first time and their missing nodes are queued.
  //    Points go in the clusters' spatial order, so the queued nodes form coherent packets.
  queueCells(R, t);
  // 2. The queued nodes, exactly, within the band.
  evaluateQueuedNodes();
  // 3. The queued cells.
  for (const std::array<int, 3>& c : queued_cells_)
    getBlock(c[0], c[1], c[2]).cell[local(c[0], c[1], c[2])] = classify(c[0], c[1], c[2]);

  // 4. Each point: far, interpolated, or queued for an exact query.
  interpolatePoints(max_distance, distance, closest_T);
  // 5. Exact queries for the points in cells that are not smooth enough. Such a cell's nodes are
  //    within the band, so its points are within band + diagonal of the surface.
  calcFallbacks(max_distance, diag, distance, closest_T);
  return 0;
}

void SdfMap::queueCells(const Eigen::Matrix3d& R, const Vec3& t) {
  queued_cells_.clear();
  node_ijk_.clear();
  node_p_.clear();
  node_hint_.clear();
  for (const int pi : exact.order) {
    const Vec3 p = R * exact.points_Q[size_t(pi)] + t;
    p_T_[size_t(pi)] = p;
    const Vec3 g = (p - origin_) / h;
    if (!(g[0] >= 0 && g[1] >= 0 && g[2] >= 0 && g[0] < n_[0] - 1 && g[1] < n_[1] - 1 && g[2] < n_[2] - 1)) {
      cell_[size_t(pi)] = {-1, -1, -1};  // outside the grid
      continue;
    }
    const int i = int(g[0]), j = int(g[1]), k = int(g[2]);
    cell_[size_t(pi)] = {i, j, k};
    uint8_t& state = getBlock(i, j, k).cell[local(i, j, k)];
    if (state != kUnknown) continue;
    state = kQueued;
    queued_cells_.push_back({i, j, k});

    for (int m = 0; m < 8; ++m) {
      const int ii = i + (m & 1), jj = j + ((m >> 1) & 1), kk = k + ((m >> 2) & 1);
      Block& b = getBlock(ii, jj, kk);
      const int l = local(ii, jj, kk);
      if (b.tri[l] != kNoNode) continue;  // evaluated or queued
      b.tri[l] = kQueuedNode;
      node_ijk_.push_back({ii, jj, kk});
      node_p_.push_back(origin_ + h * Vec3(ii, jj, kk));
      node_hint_.push_back(hint_[size_t(pi)]);
    }
  }
}

void SdfMap::evaluateQueuedNodes() {
  const int nn = int(node_p_.size());
  if (nn > 0) {
    node_found_.resize(size_t(nn));
    exact.target.findClosestBatch(node_p_.data(), nn, node_hint_.data(), band_, node_found_.data());
    sdf.nodes += nn;
    for (int s = 0; s < nn; ++s) {
      const std::array<int, 3>& ijk = node_ijk_[size_t(s)];
      Block& b = getBlock(ijk[0], ijk[1], ijk[2]);
      const int l = local(ijk[0], ijk[1], ijk[2]);
      const int tri = node_found_[size_t(s)];
      if (tri < 0) {
        b.tri[l] = kFarUnknown;  // beyond the band: its side is settled with its cells
        continue;
      }
      Vec3 q;
      const Vec3& c = node_p_[size_t(s)];
      const double d = exact.target.signedDistance(c, tri, q);
      // The exact gradient: from the closest point, or the face normal on the surface.
      const Vec3 g = std::abs(d) > 1e-12 ? Vec3((c - q) / d) : exact.target.getFaceNormal(tri);
      b.d[l] = float(d);
      b.tri[l] = tri;
      for (int a = 0; a < 3; ++a) b.g[a][l] = int16_t(std::lround(std::clamp(g[a], -1.0, 1.0) * kGradScale));
    }
  }
}

void SdfMap::interpolatePoints(double max_distance, double* distance, double* closest_T) {
  fallback_.clear();
  fallback_p_.clear();
  fallback_hint_.clear();
  const int n = int(hint_.size());
  for (int pi = 0; pi < n; ++pi) {
    const std::array<int, 3>& ijk = cell_[size_t(pi)];
    const int i = ijk[0], j = ijk[1], k = ijk[2];
    const uint8_t state = i < 0 ? uint8_t(kFarOut) : getBlock(i, j, k).cell[local(i, j, k)];
    if (state == kFarOut || state == kFarIn) {
      // Outside the grid (farther than the band from the target's box), or in a far cell.
      ++sdf.far_points;
      distance[pi] = state == kFarOut ? kInf : -kInf;
      if (closest_T)
        for (int m = 0; m < 3; ++m) closest_T[3 * pi + m] = kNaN;
      continue;
    }
    const Vec3& p = p_T_[size_t(pi)];
    if (state == kExact) {
      fallback_.push_back(pi);
      fallback_p_.push_back(p);
      fallback_hint_.push_back(hint_[size_t(pi)]);
      continue;
    }
    ++sdf.interpolated;
    double D[8];
    for (int m = 0; m < 8; ++m) {
      const int ii = i + (m & 1), jj = j + ((m >> 1) & 1), kk = k + ((m >> 2) & 1);
      const Block& b = getBlock(ii, jj, kk);
      D[m] = b.d[local(ii, jj, kk)];
      if (m == 0) hint_[size_t(pi)] = b.tri[local(ii, jj, kk)];
    }
    const double x = (p[0] - origin_[0]) / h - i, y = (p[1] - origin_[1]) / h - j, z = (p[2] - origin_[2]) / h - k;
    const double c00 = D[0] + x * (D[1] - D[0]), c10 = D[2] + x * (D[3] - D[2]);
    const double c01 = D[4] + x * (D[5] - D[4]), c11 = D[6] + x * (D[7] - D[6]);
    const double c0 = c00 + y * (c10 - c00), c1 = c01 + y * (c11 - c01);
    const double v = c0 + z * (c1 - c0);
    distance[pi] = v;
    if (closest_T) {
      // The closest point along the interpolant's gradient.
      const Vec3 grad((1 - z) * ((1 - y) * (D[1] - D[0]) + y * (D[3] - D[2])) +
                          z * ((1 - y) * (D[5] - D[4]) + y * (D[7] - D[6])),
                      (1 - z) * (c10 - c00) + z * (c11 - c01), c1 - c0);
      const double len = grad.norm();
      const bool ok = std::abs(v) <= max_distance && len > 0;
      const Vec3 q = p - v * grad / len;
      for (int m = 0; m < 3; ++m) closest_T[3 * pi + m] = ok ? q[m] : kNaN;
    }
  }
}

void SdfMap::calcFallbacks(double max_distance, double diag, double* distance, double* closest_T) {
  const int nf = int(fallback_.size());
  if (nf > 0) {
    sdf.exact_points += nf;
    fallback_found_.resize(size_t(nf));
    exact.target.findClosestBatch(fallback_p_.data(), nf, fallback_hint_.data(), band_ + 2 * diag,
                                  fallback_found_.data());
    for (int s = 0; s < nf; ++s) {
      const int pi = fallback_[size_t(s)];
      const Vec3& p = fallback_p_[size_t(s)];
      int tri = fallback_found_[size_t(s)];
      if (tri < 0) tri = exact.target.findClosestTree(p, kInf, fallback_hint_[size_t(s)]);  // cannot happen
      Vec3 q;
      const double d = exact.target.signedDistance(p, tri, q);
      distance[pi] = d;
      hint_[size_t(pi)] = tri;
      if (closest_T)
        for (int m = 0; m < 3; ++m) closest_T[3 * pi + m] = std::abs(d) <= max_distance ? q[m] : kNaN;
    }
  }
}

namespace {

void* createSdf(const kneesim_mesh_view* target, int n_points, const double* points_Q, char* err, int err_len) {
  return createProvider<SdfMap>(target, n_points, points_Q, err, err_len);
}

int computeSdf(void* ctx, const double* X_TQ, double max_distance, double* distance, double* closest_T, char* err,
               int err_len) {
  SdfMap* c = static_cast<SdfMap*>(static_cast<ProviderContext*>(ctx));
  Eigen::Matrix3d R;
  Vec3 t;
  if (!readCall(c, c ? c->exact.points_Q.size() : 0, X_TQ, max_distance, distance, R, t, err, err_len)) return 1;
  try {
    return c->compute(R, t, max_distance, distance, closest_T);
  } catch (const std::bad_alloc&) {
    writeError(err, err_len, "out of memory growing the distance grid");
  } catch (const std::exception& e) {
    writeError(err, err_len, std::string("distance query failed: ") + e.what());
  }
  c->invalidate();  // a call cut short may leave cells queued: start the grid afresh next time
  return 1;
}

void destroySdf(void* ctx) { delete static_cast<ProviderContext*>(ctx); }

const kneesim_distance_provider kFclSdf = {
    int(sizeof(kneesim_distance_provider)),
    "fcl_sdf",
    "narrow-band signed distance grid (0.5 mm) filled lazily with exact fcl values and cached across calls; "
    "trilinear where the cell's error estimate is within 20 um, exact queries elsewhere; approximate (20 um)",
    createSdf,
    computeSdf,
    destroySdf};

}  // namespace

const kneesim_distance_provider& getSdfProvider() { return kFclSdf; }

const SdfStats* findSdfStats(void* ctx) {
  const SdfMap* m = dynamic_cast<const SdfMap*>(static_cast<ProviderContext*>(ctx));
  return m ? &m->sdf : nullptr;
}

}  // namespace kneesim_distance_fcl
