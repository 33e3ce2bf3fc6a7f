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
/// (frame T), computed by a distance provider. Owns the provider's context.
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
  /// target, negative inside. Points farther than @p max_distance may get any value above it.
  /// @p closest_T, if not null, receives the closest target point of points within max_distance.
  /// Does not allocate when the vectors already have the right size.
  void calcDistances(const Eigen::Isometry3d& X_TQ, double max_distance, std::vector<double>& distance,
                     std::vector<Eigen::Vector3d>* closest_T = nullptr) const;

  int getNumPoints() const { return n_points_; }
  const kneesim_distance_provider& getProvider() const { return provider_; }

 private:
  const kneesim_distance_provider& provider_;
  void* ctx_ = nullptr;
  int n_points_ = 0;
  std::string target_file_;
};

}  // namespace kneesim::contact
