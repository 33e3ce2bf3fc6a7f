#pragma once
// The parts of the .osim reader shared by its files (not a public header): the reader's state
// and the helpers that read OpenSim's property forms. Each osim_*.cpp implements one job:
//   osim_reader.cpp       the document: format versions, the order things are read, ignored sets
//   osim_properties.cpp   property forms shared by every component: functions, transforms, paths
//   osim_bodies.cpp       bodies, inertia, display meshes
//   osim_frames.cpp       OpenSim 4.x frames: PhysicalOffsetFrames and socket paths
//   osim_joints.cpp       joints and their coordinates
//   osim_constraints.cpp  constraints
//   osim_markers.cpp      markers
//   osim_forces.cpp       wrap objects, muscles with their paths, coordinate actuators

#include <array>
#include <initializer_list>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/xml.hpp"
#include "model/model.hpp"

namespace kneesim::model::osim {

using xml::Node;

// ----------------------------------------------------------------------------- properties
/// Up to @p max_names of @p names joined by commas, with the total when more; "none" if empty.
std::string listNames(const std::vector<std::string>& names, size_t max_names = 12);

/// The element holding an object-valued property: either a wrapper <property><Type/></property>
/// (OpenSim 3.x) or a child <Type name="property"/> (OpenSim 4.x). Children whose tags are in
/// @p others are other properties of the owner. Returns a null Node when the property is absent
/// or empty.
Node findObjectProperty(const Node& owner, const char* property, std::initializer_list<const char*> others);

/// An OpenSim function element (Constant, LinearFunction, SimmSpline, ...). Throws InputError
/// at @p el for an unknown type or bad knots.
FunctionPtr parseFunction(const Node& el);

/// Whether @p tag names one of the function types parseFunction() reads.
bool isFunctionTag(const std::string& tag);

/// OpenSim's "rX rY rZ tx ty tz" transform (body-fixed XYZ angles, then a translation).
Pose parseSixTransform(const Node& n);

/// Splits a component path into its names, resolving "." and "..".
std::vector<std::string> splitPath(const std::string& path);

/// "/a/b" from {"a", "b"}; "/" from none.
std::string joinPath(const std::vector<std::string>& parts);

/// The element holding the path a socket of @p owner names, in any of the forms OpenSim has
/// written: <socket_NAME> (4.0 on), <connector_NAME_connectee_name> (30505 to 30516) and
/// <connectors><Connector_T_ name="NAME"><connectee_name> (30500 to 30504). Each name in
/// @p names is tried in turn (joints of 30501 call their parent "parent_body"). Returns a null
/// Node when the owner has none of them.
Node findSocket(const Node& owner, std::initializer_list<const char*> names);

/// An IgnoredComponent for element @p el found in set @p set_tag ("ForceSet", "ConstraintSet",
/// "components", ...): its type, name, category and whether it affects kinematics.
IgnoredComponent classifyIgnored(const Node& el, const std::string& set_tag);

// ----------------------------------------------------------------------------- reader state
/// A coordinate as read, before its joint is known to accept it.
struct ParsedCoordinate {
  Coordinate coord;
  Node node;
  bool has_file_motion = false;
  MotionType file_motion = MotionType::Rotational;
};

/// One TransformAxis of a CustomJoint as read.
struct AxisInfo {
  Node node;
  std::vector<std::string> coordinate_names;
  Vec3 axis = Vec3::UnitX();
  FunctionPtr function;  // null when the file gives none
};

/// A frame or a station (OpenSim 4.x), resolved lazily to a body and a pose in that body: a
/// PhysicalOffsetFrame (parent frame and offset), a StationDefinedFrame (four stations) or a
/// Station (parent frame and location; its pose is a translation).
struct OffsetFrame {
  enum class Kind { Offset, StationDefined, Station } kind = Kind::Offset;
  Node node;
  std::string path;        // absolute component path
  std::string parent_ref;  // socket_parent (socket_parent_frame of a Station) as written
  Node parent_node;        // the element holding parent_ref, for errors
  Pose X_PF = Pose::Identity();
  std::array<std::string, 4> station_refs;  // StationDefined: point_a, point_b, point_c, origin_point
  std::array<Node, 4> station_nodes;
  std::string ab_axis = "+x", ab_x_ac_axis = "+y";  // StationDefined axis mapping
  int state = 0;  // 0 unresolved, 1 being resolved, 2 resolved
  int body = -1;
  Pose X_BF = Pose::Identity();
};

/// What a frame path names: a body (or ground), or an offset frame still to be resolved.
struct FrameEntry {
  int body = -1;            // >= 0 for ground and bodies
  std::string offset_path;  // non-empty for offset frames
};

/// A joint element of a 4.x layout and its component path.
struct JointElement {
  Node node;
  std::string path;
};

/// Reads one OpenSim document into a Model. Each member is implemented in the file of its job
/// (see the list at the top of this header).
class OsimReader {
 public:
  OsimReader(const xml::Document& doc, const std::string& label);

  /// Reads the whole model and finalises it; throws InputError on bad input.
  std::shared_ptr<Model> read();

 private:
  // osim_reader.cpp
  void readIgnoredSets(const Node& model_el);

  /// Adds @p item to Model::ignored (classified by classifyIgnored).
  void ignore(const Node& item, const std::string& set_tag);

  // osim_bodies.cpp
  void readBodies(const Node& model_el, bool v4);
  int addBody(const Node& b, const std::string& path);
  Mat3 readInertia(const Node& b);
  void readWrapObjects(const Node& b, int body);
  /// OpenSim 4.x: the WrapObjectSets of PhysicalOffsetFrames, fixed on the frames' bodies.
  void readFrameWrapObjects();
  void addMesh(int body, const Node& where, const std::string& file, const Vec3& scale, const Pose& X_BG);
  void readMeshes3(const Node& b, int body);
  void readMeshes4(const Node& frame, const std::string& owner_path, int body, const Pose& X_BF);
  void attachMeshes4();

  // osim_frames.cpp
  /// A new entry of frames_ at @p path (an error if taken) of OffsetFrame::Kind @p kind, its
  /// parent read from socket @p parent_socket unless null.
  OffsetFrame& addFrameEntry(const Node& n, const std::string& path, int kind, const char* parent_socket);
  void registerFrame(const Node& f, const std::string& path);
  void registerComponents(const Node& owner, const std::string& owner_path);
  void registerFrames(const Node& model_el);
  void registerStation(const Node& st, const std::string& path);
  void registerStationDefinedFrame(const Node& f, const std::string& path);
  /// Resolves a StationDefinedFrame: its four stations must share a body.
  void resolveStationDefined(OffsetFrame& f);
  /// Resolves the frame named by @p ref (absolute, or relative to the component at
  /// @p owner_path) to a body and the frame's pose in it.
  std::pair<int, Pose> resolveFrame(const std::string& ref, const std::string& owner_path, const Node& where);
  std::optional<FrameEntry> lookupFrame(const std::string& path);
  std::pair<int, Pose> resolveEntry(const FrameEntry& e, const Node& where);

  // osim_joints.cpp
  void readJointSet(const Node& model_el);
  /// A name for a joint the file leaves unnamed (OpenSim accepts them), unique among joints.
  std::string nameUnnamedJoint(const Node& j, int child);
  /// The name joint @p j goes by: its own, or one given to it when it has none or another joint
  /// has it (as OpenSim renames duplicates); recorded as taken.
  std::string claimJointName(const Node& j, int child);
  void readCustomJointAxes(const Node& j, std::array<AxisInfo, 6>& axes);
  void readTransformAxisSet(const Node& set, std::array<AxisInfo, 6>& axes);
  void readEllipsoidProperties(const Node& j, Joint& jt);
  std::vector<ParsedCoordinate> readJointCoordinates(const Node& j);
  /// Adds a coordinate of joint @p joint; one whose name another joint's coordinate already has
  /// is called "<joint_name>/<name>" (OpenSim tells them apart by path), with a warning.
  int addCoordinate(const ParsedCoordinate& pc, int joint, const std::string& joint_name);
  /// Reads one joint element whose child body is @p child; returns its index in Model::joints.
  int readJoint(const Node& j, int child, bool v4);
  void readCustomJoint(const Node& j, Joint& jt, int ji, std::vector<ParsedCoordinate>& coords);
  /// Every body but ground must be the child of exactly one joint; say where, with a line.
  void checkTree();

  // osim_constraints.cpp
  int requireCoordinate(const Node& where, const std::string& n);
  void readConstraints(const Node& model_el);
  void readCoupler(const Node& c);
  /// PointConstraint, PointOnLineConstraint, ConstantDistanceConstraint or WeldConstraint at
  /// component path @p path (relative socket paths start there).
  void readBodyConstraint(const Node& c, const std::string& path);

  // osim_markers.cpp
  void readMarkers(const Node& model_el, bool v4);

  // osim_forces.cpp
  void readForces(const Node& model_el, bool v4);

  const xml::Document& doc_;
  std::string label_;
  std::string folder_;
  std::shared_ptr<Model> m_ = std::make_shared<Model>();
  std::vector<Node> body_nodes_;
  std::unordered_map<std::string, int> body_index_;
  std::unordered_map<std::string, int> coord_index_;
  std::set<std::string> joint_names_;
  std::vector<Node> joint_nodes_;  // parallel to Model::joints until finalize()
  std::vector<std::pair<Node, int>> pending_joints_;
  std::map<std::string, OffsetFrame> frames_;
  std::map<std::string, int> body_paths_;  // component path of each body ("/bodyset/b", "/b")
  std::vector<JointElement> joint_elements_;  // 4.x joints: JointSet and <components>
};

}  // namespace kneesim::model::osim
