#pragma once
// Least-squares cylinder and circle fits (geometric distance, Levenberg-Marquardt).
//
// Dao & Pouletaut (2015, section 3.1) fit one cylinder to the femoral component's condyles and use
// its radius as the Hertz radius R and its axis as the knee's flexion hinge. fitCylinder does
// that fit; fitCircle is the planar version used for the sagittal radius of curvature R(theta).

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace kneesim::contact {

/// An infinite right circular cylinder.
struct Cylinder {
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< Unit direction of the axis.
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< A point on the axis.
  double radius = 0;                                ///< Radius (m).

  /// Distance of @p p from the axis minus the radius: positive outside the cylinder.
  double calcSignedDistance(const Eigen::Vector3d& p) const;
  /// Coordinate of @p p along the axis, measured from point.
  double calcAxialCoordinate(const Eigen::Vector3d& p) const { return axis.dot(p - point); }
};

/// Residual statistics of a fit: absolute geometric distances of the points from the fitted shape.
struct FitErrors {
  int num_points = 0;   ///< Number of points fitted.
  double mean_abs = 0;  ///< Mean absolute distance (m): the paper's "mean error".
  double max_abs = 0;   ///< Largest absolute distance (m).
  double rms = 0;       ///< Root mean square distance (m).
};

/// Settings of fitCylinder.
struct CylinderFitOptions {
  /// Initial axis direction. Without it the axis is started from the normals (when given: the
  /// direction most nearly perpendicular to all of them) or else from each of the points'
  /// three principal axes in turn, keeping the best fit.
  std::optional<Eigen::Vector3d> axis_guess;
  int max_iterations = 200;  ///< Levenberg-Marquardt iterations per start.
  /// A fit whose radius exceeds this multiple of the points' largest extent is rejected as
  /// "nearly flat" (planar points have no finite cylinder).
  double max_radius_ratio = 1e3;
  /// Names the data in error messages (e.g. the mesh file the points came from).
  std::string source;
};

/// Result of fitCylinder.
struct CylinderFit {
  /// The fitted cylinder. Its point is the axis point nearest the points' centroid; its axis
  /// points along axis_guess when one was given, else its largest component is positive.
  Cylinder cylinder;
  FitErrors errors;    ///< Distances of the points from the fitted cylinder.
  int iterations = 0;  ///< Levenberg-Marquardt iterations of the accepted start.
};

/// Fits a cylinder to @p points by minimising the sum of squared geometric distances
/// (distance from the axis minus the radius) over axis direction, axis position and radius,
/// with Levenberg-Marquardt. Exact (to rounding) for points on a cylinder. Throws InputError
/// naming options.source for fewer than 6 points, non-finite coordinates, coincident or
/// collinear points, or points that lie on no finite cylinder (nearly planar sets).
CylinderFit fitCylinder(const std::vector<Eigen::Vector3d>& points, const CylinderFitOptions& options = {});

/// As above, starting the axis from the surface normals at the points (unit or not): on a
/// cylinder every normal is perpendicular to the axis. @p normals must match @p points.
CylinderFit fitCylinder(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                        const CylinderFitOptions& options = {});

/// A circle in a plane.
struct Circle {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  ///< Centre (m).
  double radius = 0;                                  ///< Radius (m).
};

/// Result of fitCircle.
struct CircleFit {
  Circle circle;       ///< The fitted circle.
  FitErrors errors;    ///< Distances of the points from it.
  int iterations = 0;  ///< Levenberg-Marquardt iterations.
};

/// Fits a circle to planar @p points (geometric least squares, started from the algebraic
/// Kasa fit). Exact for points on a circle arc. Throws InputError naming @p source for fewer than
/// 3 points, non-finite coordinates or (nearly) collinear points.
CircleFit fitCircle(const std::vector<Eigen::Vector2d>& points, const std::string& source = "");

/// Distances of @p points from @p cylinder, summarised.
FitErrors calcFitErrors(const Cylinder& cylinder, const std::vector<Eigen::Vector3d>& points);

}  // namespace kneesim::contact
