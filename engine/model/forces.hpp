#pragma once
// The force elements of a model description: wrap objects fixed on bodies, muscles with their
// geometry paths (path points, conditional and moving points, path wraps), and coordinate
// actuators, as an OpenSim ForceSet describes them. Plain data, part of the immutable Model; the
// muscle module evaluates them.

#include <array>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/error.hpp"
#include "model/function.hpp"

namespace kneesim::model {

/// The shape of a wrap object. Dimensions live in WrapObject::dimensions (see there).
enum class WrapShape { Sphere, Cylinder, Ellipsoid, Torus };

/// A smooth surface fixed on a body that muscle paths wrap over (OpenSim WrapSphere,
/// WrapCylinder, WrapEllipsoid, WrapTorus). The wrap frame W is centred on the shape: a
/// cylinder's axis is W's z axis, a torus lies in W's xy plane.
struct WrapObject {
  std::string name;
  WrapShape shape = WrapShape::Sphere;
  int body = -1;                               ///< Body the object is fixed on.
  Eigen::Isometry3d X_BW = Eigen::Isometry3d::Identity();  ///< Wrap frame in the body frame.
  /// Sphere: (radius, 0, 0); Cylinder: (radius, length, 0); Ellipsoid: the three radii;
  /// Torus: (inner_radius, outer_radius, 0).
  Eigen::Vector3d dimensions = Eigen::Vector3d::Zero();
  /// OpenSim's quadrant: wrapping restricted to the half-space where coordinate
  /// quadrant_axis of W has the sign quadrant_sign (0: unrestricted, "all").
  int quadrant_axis = 0;
  int quadrant_sign = 0;
  bool active = true;
};

/// How a path wraps over an ellipsoid (OpenSim PathWrap method; ignored by other shapes).
enum class WrapMethod { Hybrid, Midpoint, Axial };

/// One wrap object applied to a path, over a range of its points.
struct PathWrap {
  int wrap_object = -1;  ///< Index into Model::wrap_objects.
  WrapMethod method = WrapMethod::Hybrid;
  /// OpenSim's range, 1-based indices into GeometryPath::points; -1 means the first (last) one.
  int range_begin = -1;
  int range_end = -1;
};

enum class PathPointType { Fixed, Conditional, Moving };

/// A point of a geometry path.
struct PathPoint {
  std::string name;
  PathPointType type = PathPointType::Fixed;
  int body = -1;
  Eigen::Vector3d p_BP = Eigen::Vector3d::Zero();  ///< Location in the body (Fixed, Conditional).
  /// Conditional: the point is in the path while range_min - 1e-5 <= q <= range_max + 1e-5.
  int coordinate = -1;
  double range_min = 0.0;
  double range_max = 0.0;
  /// Moving: component k of the location is location_functions[k](q[location_coordinates[k]]);
  /// a component without a function or coordinate keeps p_BP's value.
  std::array<FunctionPtr, 3> location_functions;
  std::array<int, 3> location_coordinates{{-1, -1, -1}};
};

/// A muscle's path: its points in order, then the wrap objects it may wrap over, in the order
/// they are tried.
struct GeometryPath {
  std::vector<PathPoint> points;
  std::vector<PathWrap> wraps;
};

/// A muscle of one of the types kneesim evaluates (see Muscle::type).
struct Muscle {
  std::string name;
  /// The model file's class name: Schutte1993Muscle_Deprecated, Thelen2003Muscle,
  /// Thelen2003Muscle_Deprecated or Millard2012EquilibriumMuscle.
  std::string type;
  /// False for OpenSim's isDisabled = true or appliesForce = false.
  bool enabled = true;
  GeometryPath path;
  double max_isometric_force = 0.0;  ///< N
  double optimal_fiber_length = 0.0;  ///< m
  double tendon_slack_length = 0.0;   ///< m
  double pennation_angle_at_optimal = 0.0;  ///< rad
  double max_contraction_velocity = 10.0;   ///< optimal fibre lengths per second
  double min_control = 0.0;
  double max_control = 1.0;
  /// Every other numeric property as written, nested objects joined with '.', e.g.
  /// "FmaxTendonStrain" or "ActiveForceLengthCurve.min_norm_active_fiber_length".
  std::map<std::string, double> parameters;
  /// Function-valued properties by name, e.g. "active_force_length_curve".
  std::map<std::string, FunctionPtr> functions;
  SourceLocation where;  ///< The muscle's element, for messages about its parameters.
};

/// OpenSim CoordinateActuator: a generalised force optimal_force * control on one coordinate.
struct CoordinateActuator {
  std::string name;
  int coordinate = -1;
  double optimal_force = 1.0;
  double min_control = -1e30;
  double max_control = 1e30;
  bool enabled = true;
};

}  // namespace kneesim::model
