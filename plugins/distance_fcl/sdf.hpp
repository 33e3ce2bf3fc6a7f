#pragma once
// The "fcl_sdf" provider's context: a narrow-band signed distance grid of the target, filled
// lazily with exact values, interpolated where that is accurate, exact queries elsewhere.

#include <array>
#include <cstdint>
#include <deque>
#include <vector>

#include "distance_fcl.hpp"

namespace kneesim_distance_fcl {

// Counters of an SdfMap (kneesim_distance_fcl_get_sdf_stats).
struct SdfStats {
  long long nodes = 0;           // grid nodes evaluated (exact queries)
  long long side_queries = 0;    // unbounded queries for the side of a node beyond the band
  long long cells = 0;           // cells classified
  long long cells_exact = 0;     // of which answered by exact queries (interpolation error too large)
  long long cells_far = 0;       // of which entirely beyond the band
  long long interpolated = 0;    // point values interpolated
  long long exact_points = 0;    // point values computed exactly
  long long far_points = 0;      // points reported beyond max_distance without any query
  long long resets = 0;          // grid rebuilt for a wider band
  long long blocks = 0;          // blocks allocated
};

struct SdfMap : ProviderContext {
  // Grid spacing (m), and the largest interpolation error estimate of a cell that is
  // interpolated (m); see sdf.cpp.
  double h = 0.5e-3;
  double tolerance = 20e-6;

  ExactMap exact;  // the target, its tree, the points, and the exact path
  SdfStats sdf;

  std::string init(const kneesim_mesh_view& view, int n_points, const double* points);
  int compute(const Eigen::Matrix3d& R, const Vec3& t, double max_distance, double* distance, double* closest_T);
  // Drops the grid; the next call rebuilds it.
  void invalidate() { band_ = 0; }

 private:
  static constexpr int kB = 8;  // nodes (and cells) per block edge
  static constexpr double kGradScale = 32767;
  // A block of nodes: the signed distance (float), the closest triangle or a state below, the
  // exact gradient; and the state of the cells whose lowest corner is the node.
  struct Block {
    float d[kB * kB * kB];
    int32_t tri[kB * kB * kB];
    int16_t g[3][kB * kB * kB];  // in units of 1 / kGradScale
    uint8_t cell[kB * kB * kB];
  };
  // Node states in Block::tri besides a triangle: not evaluated, queued this call, beyond the
  // band with d = +-infinity giving its side, beyond the band with its side not yet known.
  static constexpr int32_t kNoNode = -1, kQueuedNode = -2, kFar = -3, kFarUnknown = -4;
  enum CellState : uint8_t { kUnknown = 0, kQueued, kInterpolate, kExact, kFarOut, kFarIn };

  void reset(double band);
  Block& getBlock(int i, int j, int k);  // the block holding node (i, j, k), allocated on first use
  uint8_t classify(int i, int j, int k);  // a cell whose nodes are all evaluated
  // The passes of compute(), in order (sdf.cpp says what each does).
  void queueCells(const Eigen::Matrix3d& R, const Vec3& t);
  void evaluateQueuedNodes();
  void interpolatePoints(double max_distance, double* distance, double* closest_T);
  void calcFallbacks(double max_distance, double diag, double* distance, double* closest_T);

  double band_ = 0;  // nodes within band_ of the surface hold exact values; 0: no grid yet
  Vec3 origin_ = Vec3::Zero();
  int n_[3] = {0, 0, 0};   // nodes per axis
  int nb_[3] = {0, 0, 0};  // blocks per axis
  std::vector<int32_t> block_index_;  // per block slot, index into blocks_ or -1
  std::deque<Block> blocks_;

  std::vector<int> hint_;  // per point, a triangle near its last closest one
  // Buffers for one call.
  std::vector<Vec3> p_T_;
  std::vector<std::array<int, 3>> cell_, queued_cells_, node_ijk_;
  std::vector<Vec3> node_p_;
  std::vector<int> node_hint_, node_found_;
  std::vector<int> fallback_;
  std::vector<Vec3> fallback_p_;
  std::vector<int> fallback_hint_, fallback_found_;
};

// The "fcl_sdf" provider table.
const kneesim_distance_provider& getSdfProvider();
// The counters of an SdfMap context, or null for another context of this plugin.
const SdfStats* findSdfStats(void* ctx);

}  // namespace kneesim_distance_fcl
