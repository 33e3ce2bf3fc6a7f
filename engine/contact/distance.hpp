#pragma once
// C++ side of a distance provider (kneesim_distance_provider, see plugin/kneesim_plugin.h).

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "io/stl.hpp"
#include "plugin/kneesim_plugin.h"

namespace kneesim::contact {

/// Signed distances from a fixed set of query points (given in frame Q) to a closed target mesh
/// (frame T), computed by a distance provider. Owns the provider's context. A provider may keep
/// state between calls (the "fcl" provider remembers each point's last result to save work on the
/// next, nearby pose), so calcDistances is not safe to call from several threads at once: create
/// one DistanceField per thread.
class DistanceField {
 public:
  /// Prepares the provider for @p target and @p points_Q. Throws InputError naming the target
  /// mesh's file if the provider refuses it.
  DistanceField(const kneesim_distance_provider& provider, const io::TriangleMesh& target,
                const std::vector<Eigen::Vector3d>& points_Q);
  ~DistanceField();
  DistanceField(const DistanceField&) = delete;
  DistanceField& operator=(const DistanceField&) = delete;

  /// Fills @p distance (resized to getNumPoints()) with each point's signed distance to the
  /// target, negative inside. A point farther than @p max_distance from the surface may get any
  /// value beyond max_distance on its own side: above +max_distance outside, below -max_distance
  /// inside (the "fcl" provider gives the exact value when it has it, else +-infinity).
  /// @p closest_T, if not null, receives the closest target point of points within max_distance
  /// (NaN for the others with the "fcl" provider). Does not allocate when the vectors already have
  /// the right size. An approximate provider ("fcl_sdf": 20 um) meets all of this to within its
  /// stated tolerance, and may allocate while it fills its cache. Throws InputError naming the
  /// target mesh if the provider fails (a bad pose).
  void calcDistances(const Eigen::Isometry3d& X_TQ, double max_distance, std::vector<double>& distance,
                     std::vector<Eigen::Vector3d>* closest_T = nullptr) const;

  /// Number of query points.
  int getNumPoints() const { return n_points_; }
  /// The provider computing the distances.
  const kneesim_distance_provider& getProvider() const { return provider_; }
  /// The provider's context, for a provider's own diagnostic functions (benchmarks).
  void* getProviderContext() const { return ctx_; }

 private:
  const kneesim_distance_provider& provider_;
  void* ctx_ = nullptr;
  int n_points_ = 0;
  std::string target_file_;
};

}  // namespace kneesim::contact
