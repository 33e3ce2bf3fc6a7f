#pragma once
// The immutable description of a musculoskeletal model: bodies, joints, coordinates,
// couplers, constraints, markers and force elements, as read from an OpenSim .osim or a URDF file.
//
// Frame notation (Drake): X_PF is the pose of frame F measured in frame P; p_BM is the
// position of point M from B's origin expressed in B. All lengths are in metres, angles in
// radians, whatever the source file used.

#include <array>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "model/forces.hpp"
#include "model/function.hpp"

namespace kneesim::model {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Pose = Eigen::Isometry3d;

/// A mesh attached to a body for display or contact.
struct MeshRef {
  std::string file;           ///< As written in the model file.
  std::string resolved_path;  ///< Absolute path if the file was found next to the model, else "".
  Vec3 scale = Vec3::Ones();  ///< Per-axis scale factors.
  Pose X_BG = Pose::Identity();  ///< Pose of the geometry frame G in the body frame B.
};

/// A rigid body. Index 0 of Model::bodies is always ground.
struct Body {
  std::string name;
  double mass = 0.0;
  Vec3 mass_center = Vec3::Zero();   ///< p_BCm: centre of mass from the body origin.
  Mat3 inertia = Mat3::Zero();       ///< Central inertia (about the COM), expressed in B.
  std::vector<MeshRef> meshes;
};

/// Joint types. Ellipsoid is OpenSim's EllipsoidJoint (Simbody's Ellipsoid mobilizer: body-fixed
/// X-Y-Z angles, the M origin sliding on an ellipsoid fixed in F). Scapulothoracic is OpenSim's
/// ScapulothoracicJoint (an Ellipsoid mobilizer then a winging Pin, 4 coordinates).
enum class JointType { Weld, Pin, Slider, Ball, Free, Universal, Gimbal, Custom, Ellipsoid, Scapulothoracic };

/// The name OpenSim gives a joint type in a model file ("PinJoint", "CustomJoint", ...).
const char* getJointTypeName(JointType type);
enum class MotionType { Rotational, Translational, Coupled };

/// One of the six axes of a CustomJoint's SpatialTransform.
/// Axes 0-2 rotate about `axis` by f(q), applied in order; axes 3-5 translate along `axis`.
struct TransformAxis {
  Vec3 axis = Vec3::UnitX();
  std::vector<int> coordinates;  ///< Model coordinate indices that are the function's arguments.
  FunctionPtr function;          ///< Never null once the model is finalised (Constant 0 if unused).
};

/// A joint connecting a parent body (F frame) to a child body (M frame).
struct Joint {
  std::string name;
  JointType type = JointType::Weld;
  int parent_body = -1;
  int child_body = -1;
  Pose X_PF = Pose::Identity();  ///< Joint frame F on the parent body P.
  Pose X_BM = Pose::Identity();  ///< Joint frame M on the child body B.
  /// OpenSim's `reverse`: the joint's transform describes the parent relative to the child.
  bool reverse = false;
  /// The file names this joint's bodies the other way round: its child body was already another
  /// joint's child, so OpenSim's multibody graph uses the joint from that body (Simbody's Reverse
  /// mobilizer) and the coordinates keep the file's parent-to-child sense. parent_body and X_PF
  /// here are the file's child body and child frame; child_body and X_BM the file's parent ones.
  bool reversed_in_tree = false;
  std::vector<int> coordinates;      ///< Model coordinate indices, in the joint's own order.
  std::array<TransformAxis, 6> spatial;  ///< Used by JointType::Custom only.
  /// Ellipsoid: the semi-axes along F's x, y, z. Scapulothoracic: OpenSim's
  /// thoracic_ellipsoid_radii_x_y_z, along the parent frame's axes (m).
  Vec3 radii = Vec3::Zero();
  /// Scapulothoracic only: scapula_winging_axis_origin (m) and scapula_winging_axis_direction (rad).
  Eigen::Vector2d winging_origin = Eigen::Vector2d::Zero();
  double winging_direction = 0.0;
};

/// A generalised coordinate.
struct Coordinate {
  std::string name;
  MotionType motion_type = MotionType::Rotational;
  double default_value = 0.0;
  double range_min = -1e30;
  double range_max = 1e30;
  bool clamped = false;
  bool locked = false;
  int joint = -1;           ///< Owning joint.
  int index_in_joint = 0;   ///< Position in Joint::coordinates.
};

/// OpenSim CoordinateCouplerConstraint: q_dep = scale_factor * f(q_indep...).
struct CoordinateCoupler {
  std::string name;
  int dependent = -1;
  std::vector<int> independents;
  FunctionPtr function;
  double scale_factor = 1.0;
};

/// The kinds of OpenSim constraint kneesim enforces besides couplers.
enum class ConstraintType {
  Point,             ///< PointConstraint: a point of body 1 and a point of body 2 coincide (3 equations).
  PointOnLine,       ///< PointOnLineConstraint: a point of body 2 (follower) stays on a line of body 1 (2).
  ConstantDistance,  ///< ConstantDistanceConstraint: two points stay `distance` apart (1).
  Weld               ///< WeldConstraint: frame F1 on body 1 and frame F2 on body 2 coincide (6).
};

/// An OpenSim constraint between two bodies (couplers are CoordinateCoupler). Frames F1 and F2 are
/// fixed on body1 and body2: the constrained points are their origins; a PointOnLine's line runs
/// through F1's origin along F1's x axis; a Weld makes F2 coincide with F1.
struct Constraint {
  std::string name;
  ConstraintType type = ConstraintType::Point;
  int body1 = -1, body2 = -1;
  Pose X_B1F1 = Pose::Identity();
  Pose X_B2F2 = Pose::Identity();
  double distance = 0.0;  ///< ConstantDistance only (m).
};

/// Name of a constraint type as OpenSim writes it ("PointConstraint", ...).
const char* getConstraintTypeName(ConstraintType type);

/// A marker fixed on a body.
struct Marker {
  std::string name;
  int body = -1;
  Vec3 p_BM = Vec3::Zero();  ///< Location in the body frame.
  bool fixed = false;        ///< OpenSim's `fixed`: the marker placer must not move it.
};

/// A component of the source file that kneesim reads past without simulating it.
struct IgnoredComponent {
  std::string type;  ///< XML tag, e.g. "Thelen2003Muscle".
  std::string name;
  /// What it is, for messages: "muscle", "ligament", "contact" (contact forces), "contact
  /// geometry", "force", "constraint", "wrap object", "controller", "probe", "other".
  std::string category = "other";
  /// True when leaving it out changes where the bodies go where OpenSim would (kinematic
  /// constraints), or where the model is meant to be posed by forces (ligaments, contact).
  bool affects_kinematics = false;
};

/// The model. Built by a reader, then finalize()d; treat as immutable afterwards and share it
/// as std::shared_ptr<const Model>.
class Model {
 public:
  std::string name;
  std::string source_file;  ///< Path the model was read from ("" if built in code).
  int format_version = 0;   ///< OpenSimDocument Version, 0 for URDF or code.
  Vec3 gravity = Vec3(0, -9.80665, 0);
  std::vector<Body> bodies;  ///< bodies[0] is ground.
  std::vector<Joint> joints;
  std::vector<Coordinate> coordinates;
  std::vector<CoordinateCoupler> couplers;
  std::vector<Constraint> constraints;
  std::vector<Marker> markers;
  std::vector<WrapObject> wrap_objects;
  std::vector<Muscle> muscles;
  std::vector<CoordinateActuator> actuators;
  std::vector<IgnoredComponent> ignored;
  /// Problems a reader tolerated (a mesh file not found, unusual length units, ...), one line each.
  std::vector<std::string> warnings;

  /// Builds name indexes, checks the tree (each non-ground body is the child of exactly one
  /// joint, no cycles), fills unused transform axes, and orders joints parent-before-child.
  /// Throws InputError naming source_file on an inconsistent model.
  void finalize();

  /// Index of the named item or -1 (cheap).
  int findBody(const std::string& n) const;
  int findJoint(const std::string& n) const;
  int findCoordinate(const std::string& n) const;
  int findMarker(const std::string& n) const;
  int findMuscle(const std::string& n) const;
  /// Joint whose child is @p body, or -1 for ground.
  int findParentJoint(int body) const;

 private:
  std::unordered_map<std::string, int> body_index_, joint_index_, coordinate_index_, marker_index_, muscle_index_;
  std::vector<int> parent_joint_;
};

using ModelPtr = std::shared_ptr<const Model>;

/// Pose from OpenSim's body-fixed X-Y-Z Euler angles and a translation.
Pose poseFromXYZ(const Vec3& xyz_body_fixed, const Vec3& p);

/// Finds the mesh file @p file named by a model in folder @p model_folder: @p file itself when
/// absolute, else model_folder/file, then model_folder/Geometry/file. A "file://" prefix is
/// dropped. Returns the absolute normalised path of the first regular file found, or "".
std::string findMeshFile(const std::string& file, const std::string& model_folder);

}  // namespace kneesim::model
