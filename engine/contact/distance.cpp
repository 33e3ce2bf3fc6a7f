#include "contact/distance.hpp"

#include <cmath>

#include "core/error.hpp"

namespace kneesim::contact {

DistanceField::DistanceField(const kneesim_distance_provider& provider, const io::TriangleMesh& target,
                             const std::vector<Eigen::Vector3d>& points_Q)
    : provider_(provider), n_points_(int(points_Q.size())), target_file_(target.source_file) {
  KNEESIM_CHECK(provider.create && provider.compute && provider.destroy,
                std::string("distance provider '") + (provider.name ? provider.name : "?") + "' has a null function");
  // The ABI takes flat arrays; Eigen::Vector3d is three packed doubles, Vector3i three ints, but
  // copying keeps that assumption out of the interface.
  std::vector<double> vertices(3 * target.vertices.size());
  for (size_t i = 0; i < target.vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) vertices[3 * i + size_t(k)] = target.vertices[i][k];
  std::vector<int> triangles(3 * target.triangles.size());
  for (size_t i = 0; i < target.triangles.size(); ++i)
    for (int k = 0; k < 3; ++k) triangles[3 * i + size_t(k)] = target.triangles[i][k];
  std::vector<double> points(3 * points_Q.size());
  for (size_t i = 0; i < points_Q.size(); ++i)
    for (int k = 0; k < 3; ++k) points[3 * i + size_t(k)] = points_Q[i][k];
  const kneesim_mesh_view view{target.getNumVertices(), vertices.data(), target.getNumTriangles(), triangles.data()};
  char err[512] = "";
  ctx_ = provider.create(&view, n_points_, points.data(), err, int(sizeof err));
  if (!ctx_)
    throw InputError({target_file_, 0, ""}, std::string("distance provider '") + provider.name +
                                                "' refused the mesh: " + (err[0] ? err : "no reason given"));
}

DistanceField::~DistanceField() {
  if (ctx_) provider_.destroy(ctx_);
}

void DistanceField::calcDistances(const Eigen::Isometry3d& X_TQ, double max_distance, std::vector<double>& distance,
                                  std::vector<Eigen::Vector3d>* closest_T) const {
  distance.resize(size_t(n_points_));
  double X[12];
  const Eigen::Matrix3d R = X_TQ.linear();
  const Eigen::Vector3d p = X_TQ.translation();
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) X[4 * r + k] = R(r, k);
    X[4 * r + 3] = p[r];
  }
  double* closest = nullptr;
  if (closest_T) {
    closest_T->resize(size_t(n_points_));
    static_assert(sizeof(Eigen::Vector3d) == 3 * sizeof(double), "Vector3d must be three packed doubles");
    closest = closest_T->empty() ? nullptr : closest_T->front().data();
  }
  char err[512] = "";
  if (provider_.compute(ctx_, X, max_distance, distance.data(), closest, err, int(sizeof err)) != 0)
    throw InputError({target_file_, 0, ""}, std::string("distance provider '") + provider_.name +
                                                "' failed: " + (err[0] ? err : "no reason given"));
}

}  // namespace kneesim::contact
