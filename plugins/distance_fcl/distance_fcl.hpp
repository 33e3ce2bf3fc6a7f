#pragma once
// Contexts of the distance_fcl providers (see distance_fcl.cpp and sdf.cpp).

#include <exception>
#include <limits>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "target.hpp"

namespace kneesim_distance_fcl {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Diagnostic counters (kneesim_distance_fcl_get_stats, kneesim_distance_fcl_get_sdf_stats).
struct ExactStats {
  long long calls = 0, points = 0, coherent_skips = 0, cluster_queries = 0, cluster_culled = 0, point_queries = 0,
            unbounded_queries = 0;
};

// Base of every context this plugin hands out (create() returns a ProviderContext*).
struct ProviderContext {
  virtual ~ProviderContext() = default;
  ExactStats stats;
};

inline const ExactStats& getExactStats(void* ctx) { return static_cast<ProviderContext*>(ctx)->stats; }

void writeError(char* err, int err_len, const std::string& msg);

// Reads a row-major 3x4 pose and checks it and max_distance; false (with err) if invalid.
bool readPose(const double* X_TQ, double max_distance, Eigen::Matrix3d& R, Vec3& t, char* err, int err_len);
// The checks every provider's compute() starts with: a context, a pose and, for any points, an
// output array; then readPose. False (with err) if one fails.
bool readCall(bool have_context, size_t n_points, const double* X_TQ, double max_distance, const double* distance,
              Eigen::Matrix3d& R, Vec3& t, char* err, int err_len);

// Every provider's create(): checks the arguments, builds a Map whose init(view, n, points,
// extra...) returns an empty string or the reason for refusing, and turns exceptions into err.
template <class Map, class... Extra>
void* createProvider(const kneesim_mesh_view* target, int n_points, const double* points_Q, char* err, int err_len,
                     Extra... extra) {
  try {
    if (!target) {
      writeError(err, err_len, "expected a target mesh, got none");
      return nullptr;
    }
    if (n_points < 0 || (n_points > 0 && !points_Q)) {
      writeError(err, err_len, "expected query points, got " + std::to_string(n_points));
      return nullptr;
    }
    auto c = std::make_unique<Map>();
    const std::string problem = c->init(*target, n_points, points_Q, extra...);
    if (!problem.empty()) {
      writeError(err, err_len, problem);
      return nullptr;
    }
    return static_cast<ProviderContext*>(c.release());
  } catch (const std::bad_alloc&) {
    writeError(err, err_len, "out of memory preparing the distance queries");
  } catch (const std::exception& e) {
    writeError(err, err_len, std::string("FCL failed preparing the distance queries: ") + e.what());
  }
  return nullptr;
}

// How an exact map computes: the fast path over the compact tree, the same with FCL's own
// queries, or one unbounded FCL query per point.
enum class Mode { fast, fcl_pruned, fcl_naive };

// Per-point memory across calls (temporal coherence).
struct PointState {
  Vec3 p_ref = Vec3::Zero();  // position (T) where `lower` was established
  double lower = 0;           // |distance| at p_ref is at least this
  int triangle = -1;          // closest triangle when last computed (a hint, any triangle is valid)
  signed char side = 0;       // +1 outside, -1 inside, 0 unknown
};

struct Cluster {
  int begin = 0, end = 0;  // range in ExactMap::order
  Vec3 centre_Q = Vec3::Zero();
};

// A cluster's centre this call and what its query found.
struct ClusterPose {
  Vec3 centre = Vec3::Zero();
  double lower = 0;      // |distance| of the centre is at least this
  signed char side = 0;  // 0: unknown
};

// The exact providers' context: signed distances of fixed points (Q) to the target (T).
struct ExactMap : ProviderContext {
  Target target;
  Mode mode = Mode::fast;
  std::vector<Vec3> points_Q;  // as given
  std::vector<int> order;      // point indices grouped by cluster
  std::vector<Cluster> clusters;
  std::vector<ClusterPose> cluster_T;
  std::vector<PointState> state;
  std::vector<Vec3> p_T;  // buffers for one call: points in T, pending points, their data
  std::vector<int> pending, pending_cluster, pending_hint, found;
  std::vector<Vec3> pending_p;

  // Builds the target and the clusters; returns an empty string or the reason for refusing.
  std::string init(const kneesim_mesh_view& view, int n_points, const double* points, Mode mode);
  // Distances for the pose (R, t) = X_TQ; see kneesim_distance_provider::compute.
  int compute(const Eigen::Matrix3d& R, const Vec3& t, double max_distance, double* distance, double* closest_T);
  // The closest triangle to p nearer than bound, or -1, by this map's engine; hint may be -1.
  int findClosest(const Vec3& p, double bound, int hint) const;
  // Exact signed distance of p by an unbounded query (the inside test of last resort).
  double unboundedDistance(const Vec3& p, int& t, Vec3& q);

 private:
  void buildClusters(int begin, int end);
  void computeNaive(const Eigen::Matrix3d& R, const Vec3& t, double max_distance, double* distance, double* closest_T);
  void computeFast(const Eigen::Matrix3d& R, const Vec3& t, double max_distance, double* distance, double* closest_T);
  // computeFast's last pass: the points no cluster test settled (pending), each by a query pruned by
  // its previous closest triangle or the search band, in packets of neighbouring points.
  void queryPendingPoints(double max_distance, double search, double* distance, double* closest_T);
  void store(int i, const Vec3& p, double d, int t, const Vec3& q, double max_distance, double* distance,
             double* closest_T);
  void storeFar(int i, const Vec3& p, double lower, signed char side, double* distance, double* closest_T);
};

}  // namespace kneesim_distance_fcl
