#pragma once
// Femoral condyle geometry: anatomical directions of implant components, selection of the
// articular surface points, and the sagittal radius of curvature as a function of flexion.
//
// Facing angle. A point of the femoral surface whose outward normal n has, in the sagittal plane
// (perpendicular to the flexion axis), the direction cos(theta) * distal + sin(theta) * posterior
// "faces the tibia at flexion theta": rotating the femur by theta about the flexion axis turns that
// normal straight down onto the tibial plateau. theta = 0 is the distal surface (full extension),
// theta = 90 deg the posterior surface of the condyle.

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "contact/cylinder_fit.hpp"
#include "io/stl.hpp"

namespace kneesim::contact {

/// One degree in radians.
inline constexpr double kDegree = 3.14159265358979323846 / 180.0;

/// Anatomical directions of an implant component as unit vectors in the component's own frame.
/// The defaults are those of the kgc4-jw implant STL files (a right knee): x posterior,
/// y superior, z medial (the medial halves have z >= 0; the tibial insert's PCL notch is at +x).
struct ComponentDirections {
  Eigen::Vector3d posterior = Eigen::Vector3d::UnitX();  ///< Toward the back of the knee.
  Eigen::Vector3d superior = Eigen::Vector3d::UnitY();   ///< Toward the hip.
  Eigen::Vector3d medial = Eigen::Vector3d::UnitZ();     ///< Toward the other knee.

  /// The flexion axis superior x posterior (unit): a positive rotation about it turns the femur's
  /// superior direction toward posterior, i.e. flexes the knee, for a left or a right knee.
  Eigen::Vector3d calcFlexionAxis() const { return superior.cross(posterior).normalized(); }
  /// The columns posterior, superior, medial made orthonormal: superior kept, posterior
  /// orthogonalised, medial the rest on its own side (so a left knee's basis is left-handed).
  Eigen::Matrix3d calcOrthonormalBasis() const;
  /// The rotation taking these directions onto @p other's (R_OC for C = this, O = other), after
  /// making both sets orthonormal (superior kept, posterior orthogonalised, medial = the rest).
  /// Throws InputError if one set belongs to a left knee and the other to a right knee.
  Eigen::Matrix3d calcRotationTo(const ComponentDirections& other) const;
  /// Throws InputError naming @p source unless the three directions are finite, non-zero and
  /// within 10 degrees of mutually perpendicular.
  void validate(const std::string& source) const;
};

/// Which condyle (or tibial compartment) a set of points belongs to.
enum class CondyleSide { both, medial, lateral };
/// "medial", "lateral" or "both".
const char* toString(CondyleSide side);

/// A surface point with its unit outward normal.
struct SurfacePoint {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();  ///< Position (m).
  Eigen::Vector3d n = Eigen::Vector3d::Zero();  ///< Unit outward normal.
};

/// The sagittal plane of a flexion hinge: an origin on the axis, the unit flexion axis and the
/// unit distal and posterior directions perpendicular to it (posterior = distal x axis).
struct SagittalFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();      ///< A point on the flexion axis.
  Eigen::Vector3d axis = -Eigen::Vector3d::UnitZ();      ///< Unit flexion axis.
  Eigen::Vector3d distal = -Eigen::Vector3d::UnitY();    ///< Unit distal direction, perpendicular to axis.
  Eigen::Vector3d posterior = Eigen::Vector3d::UnitX();  ///< Unit posterior direction, distal x axis.

  /// The frame of the hinge @p hinge (its axis oriented in the flexion sense of @p directions),
  /// with distal = -superior made perpendicular to the axis.
  static SagittalFrame fromHinge(const Cylinder& hinge, const ComponentDirections& directions);
  /// The frame with the flexion axis of @p directions through @p origin.
  static SagittalFrame fromDirections(const ComponentDirections& directions, const Eigen::Vector3d& origin);

  /// Facing angle (rad, in (-pi, pi]) of the normal @p n: atan2(n . posterior, n . distal).
  double calcFacingAngle(const Eigen::Vector3d& n) const;
  /// Angle (rad) between @p n and the sagittal plane, asin(|n . axis| / |n|).
  double calcNormalTilt(const Eigen::Vector3d& n) const;
  /// Angle (rad, 0..pi) between the sagittal projections of @p n and of the direction from the
  /// axis to @p p (pi/2 when either projection vanishes).
  double calcRadialAngle(const Eigen::Vector3d& p, const Eigen::Vector3d& n) const;
  /// (posterior, distal) coordinates of @p p relative to origin, in the sagittal plane.
  Eigen::Vector2d calcProfileCoordinates(const Eigen::Vector3d& p) const;
  /// Coordinate of @p p along the axis, relative to origin.
  double calcAxialCoordinate(const Eigen::Vector3d& p) const { return axis.dot(p - origin); }
};

/// The rule selecting a femoral component's articular condylar surface (see selectArticularPoints).
struct ArticularSelection {
  ComponentDirections directions;  ///< Anatomical directions in the mesh's frame.
  /// Window of facing angles (rad) kept; the default is the flexion range 0..120 deg.
  double min_facing_angle = 0.0;
  double max_facing_angle = 120.0 * kDegree;
  /// Largest angle (rad) between a normal and the sagittal plane: keeps the crest of each condyle
  /// and drops its medial and lateral flanks.
  double max_normal_tilt = 20.0 * kDegree;
  /// Largest angle (rad), in the sagittal plane, between a normal and the radial direction from
  /// the flexion axis to the point: the articular surface faces away from the axis, bone-facing
  /// inner surfaces and box corners do not.
  double max_radial_angle = 45.0 * kDegree;
  /// Largest recess (m) of a point behind the condyle's outermost surface in its own facing
  /// direction u: (p - o) . u must be within max_recess of the largest such value among the
  /// candidates of the same condyle facing the same way (1 deg bins). Drops recessed surfaces
  /// that face the tibia too, such as the roof of the intercondylar notch.
  double max_recess = 3e-3;
  CondyleSide side = CondyleSide::both;  ///< Condyle(s) to select from.
  /// Origin of the medial/lateral split plane (normal = directions.medial) and of the sagittal
  /// frame; defaults to the centre of the mesh's bounding box.
  std::optional<Eigen::Vector3d> reference_point;
  /// Flexion axis used for facing angles and tilts; defaults to directions.calcFlexionAxis()
  /// (give the fitted cylinder's frame to select relative to the fitted hinge).
  std::optional<SagittalFrame> frame;
  /// Number of points returned, spread evenly over the selected surface by farthest-point
  /// sampling; 0 returns every selected vertex.
  int max_points = 1024;
};

/// Selects articular surface points of a femoral component mesh: the vertices (which lie on the
/// true surface, unlike triangle interiors) whose area-weighted vertex normal
///  1. has a facing angle within [min_facing_angle, max_facing_angle] (the distal-posterior arc
///     that meets the tibia between those flexion angles),
///  2. is within max_normal_tilt of the sagittal plane (the condyle's crest, not its flanks),
///  3. points away from the flexion axis: in the sagittal plane, within max_radial_angle of the
///     direction from the axis to the vertex (drops bone-facing inner surfaces and box corners),
///  4. is exposed: the ray from the vertex along its normal leaves the component without meeting
///     it again (drops the fixation pegs and surfaces hidden behind others),
///  5. lies on the requested side of the medial/lateral split plane,
///  6. is not recessed: it lies within max_recess of its condyle's outermost surface in its
///     facing direction (the sagittal support function, binned by 1 deg of facing angle),
/// then spreads max_points of them evenly by farthest-point sampling (deterministic).
/// Throws InputError naming the mesh's file if the mesh is empty or no vertex qualifies.
std::vector<SurfacePoint> selectArticularPoints(const io::TriangleMesh& mesh, const ArticularSelection& selection);

/// The articular surface of a tibial insert, as vertices split into compartments.
struct InsertArticularVertices {
  std::vector<int> medial, lateral;  ///< Insert vertex indices on each side, increasing.
  /// A point of the medial/lateral split plane (its normal is the directions' medial direction).
  Eigen::Vector3d split_point = Eigen::Vector3d::Zero();
  Eigen::Vector3d medial_direction = Eigen::Vector3d::UnitZ();  ///< Unit normal of the split plane.
};

/// Selects a tibial insert's articular vertices: every vertex whose area-weighted normal is within
/// @p max_normal_angle of @p directions' superior direction and that is exposed (the ray along its
/// normal leaves the insert without meeting it again), split by the plane through
/// @p split_point (default: the centre of the mesh's bounding box) with normal
/// @p directions.medial (medial: the positive side, plane included). Throws InputError naming the
/// mesh file if either side has no such vertex ("are the component directions right?").
InsertArticularVertices selectInsertArticularVertices(const io::TriangleMesh& insert,
                                                      const ComponentDirections& directions = {},
                                                      double max_normal_angle = 75.0 * kDegree,
                                                      const std::optional<Eigen::Vector3d>& split_point = std::nullopt);

/// Positions of @p points (drops the normals).
std::vector<Eigen::Vector3d> getPositions(const std::vector<SurfacePoint>& points);
/// Normals of @p points.
std::vector<Eigen::Vector3d> getNormals(const std::vector<SurfacePoint>& points);

/// Cylinder fits of a femoral component: both condyles together (the paper's hinge and Hertz
/// radius) and each condyle alone.
struct CondyleFits {
  CylinderFit both, medial, lateral;
  /// Points used by each fit (both = medial + lateral).
  std::vector<SurfacePoint> medial_points, lateral_points;
};

/// Selects selection.max_points / 2 points on each condyle (side is ignored; max_points = 0
/// keeps every qualifying vertex) and fits cylinders to each condyle and to their union (axis
/// started from the normals), so the union fit uses max_points points like the paper's 1024. The fitted axes are oriented
/// in the flexion sense of selection.directions. Throws InputError naming the mesh file.
CondyleFits fitCondyles(const io::TriangleMesh& mesh, const ArticularSelection& selection);

/// Settings of calcSagittalRadii.
struct SagittalRadiusOptions {
  double first = 0.0;                    ///< First flexion angle of the table (rad).
  double last = 120.0 * kDegree;    ///< Last flexion angle (rad).
  double step = 5.0 * kDegree;      ///< Table step (rad).
  double window = 20.0 * kDegree;   ///< Width of the facing-angle window of each local circle fit (rad).
  /// Vertices within this distance of the profile plane are projected onto it (m).
  double slab_half_width = 1.5e-3;
  /// Axial coordinate (along frame.axis, from frame.origin) of the profile plane. Default: the
  /// mean axial coordinate of the condyle's exposed crest vertices (normal tilt <= 20 deg).
  std::optional<double> profile_axial;
  /// Fewer points than this in a window leave that table row empty (radius NaN).
  int min_points = 8;
};

/// One row of a sagittal radius table.
struct SagittalRadiusSample {
  double flexion = 0;  ///< Centre of the facing-angle window (rad).
  double radius = std::numeric_limits<double>::quiet_NaN();  ///< Local radius of curvature (m).
  /// Centre of the local circle in (posterior, distal) profile coordinates (m).
  Eigen::Vector2d center = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  FitErrors errors;  ///< Residuals of the local circle fit (num_points = points in the window).
};

/// Sagittal radius of curvature of one condyle as a function of flexion.
struct SagittalRadiusTable {
  CondyleSide side = CondyleSide::both;  ///< The condyle the table describes.
  double profile_axial = 0;  ///< Axial coordinate of the profile plane used (m).
  std::vector<SagittalRadiusSample> samples;  ///< One row per flexion angle, first..last.
};

/// Radius of curvature of a condyle's sagittal profile as a function of the flexion angle at
/// which that part of the profile faces the tibia. The profile is the exposed vertices of
/// @p mesh (vertex normals within 45 deg of the sagittal plane and, in it, within 60 deg of the
/// direction from frame.origin) within slab_half_width of the sagittal plane (perpendicular to
/// frame.axis) at profile_axial, on @p side of the plane through frame.origin with normal
/// @p medial_direction (medial: positive side). For each flexion angle theta in first..last, a
/// circle is fitted to the profile points whose facing angle lies within theta +- window/2.
/// Throws InputError naming the mesh file if no profile point is found.
SagittalRadiusTable calcSagittalRadii(const io::TriangleMesh& mesh, const SagittalFrame& frame,
                                      const Eigen::Vector3d& medial_direction, CondyleSide side,
                                      const SagittalRadiusOptions& options = {});

/// Writes sagittal radius tables side by side as CSV (atomic): flexion_deg, then per table
/// R_<side>_m, cx_<side>_m, cy_<side>_m, rms_<side>_m, n_<side>. Lengths in metres.
void writeSagittalRadiusTable(const std::string& path, const std::vector<SagittalRadiusTable>& tables);

}  // namespace kneesim::contact
