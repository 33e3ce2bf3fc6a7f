#pragma once
// Wrapping of one straight path segment over one wrap object, computed in the object's own frame
// W, as OpenSim computes it (opensim-core OpenSim/Simulation/Wrap/Wrap{Sphere,Cylinder,
// Ellipsoid,Torus}.cpp, Peter Loan's algorithms from SIMM): the same candidate tangent points,
// quadrant rules, iterations and tolerances, so that path lengths agree with OpenSim's.
//
// None of these functions allocates: surface points are generated and summed on the fly.

#include <limits>

#include <Eigen/Core>

#include "model/forces.hpp"

namespace kneesim::muscle {

using Vec3 = Eigen::Vector3d;

/// What wrapping a segment found (OpenSim's WrapObject::WrapAction).
enum class WrapStatus {
  NoWrap,        ///< The segment misses the object (or its active half).
  InsideRadius,  ///< An end point lies inside the object: no wrap.
  Wrapped,       ///< The segment could wrap; the caller keeps the shortest such wrap.
  Mandatory      ///< The segment passes through the object: it must wrap here.
};

/// The outcome of wrapping one segment, in the wrap frame W.
struct WrapResult {
  Vec3 r1 = Vec3::Constant(-std::numeric_limits<double>::infinity());  ///< Tangent point nearer the first point.
  Vec3 r2 = Vec3::Constant(-std::numeric_limits<double>::infinity());  ///< Tangent point nearer the second point.
  double length = 0.0;  ///< Length of the path on the surface from r1 to r2.
  /// Sphere only: OpenSim reuses the previous tangent points when the segment passes (almost)
  /// through the centre; the caller passes them in here.
  bool has_previous = false;
};

/// Wraps the segment @p p1 -> @p p2 (in W) over @p object using @p method (ellipsoids only).
/// @p result holds the previous wrap's tangent points on entry (see WrapResult::has_previous).
WrapStatus wrapSegment(const model::WrapObject& object, model::WrapMethod method, const Vec3& p1, const Vec3& p2,
                       WrapResult& result);

/// Cylinder of @p radius and @p length along W's z axis, centred on W's origin, restricted to
/// the half-space sign(x[axis]) = @p sign when @p sign != 0.
WrapStatus wrapCylinder(double radius, double length, int axis, int sign, const Vec3& p1, const Vec3& p2,
                        WrapResult& result);

/// Sphere of @p radius centred on W's origin, quadrant as for wrapCylinder().
WrapStatus wrapSphere(double radius, int axis, int sign, const Vec3& p1, const Vec3& p2, WrapResult& result);

/// Ellipsoid with semi-axes @p radii along W's axes, quadrant as for wrapCylinder().
WrapStatus wrapEllipsoid(const Vec3& radii, model::WrapMethod method, int axis, int sign, const Vec3& p1,
                         const Vec3& p2, WrapResult& result);

/// Torus in W's xy plane: tube of @p inner_radius around the circle of @p outer_radius,
/// quadrant as for wrapCylinder().
WrapStatus wrapTorus(double inner_radius, double outer_radius, int axis, int sign, const Vec3& p1, const Vec3& p2,
                     WrapResult& result);

}  // namespace kneesim::muscle
