#include "model/model.hpp"

#include <deque>
#include <filesystem>

#include "core/error.hpp"

namespace kneesim::model {

namespace {
template <class T>
void indexNames(const std::vector<T>& items, std::unordered_map<std::string, int>& index, const char* what,
                const std::string& file) {
  index.clear();
  for (size_t i = 0; i < items.size(); ++i) {
    if (!index.emplace(items[i].name, int(i)).second)
      throw InputError({file, 0, ""}, std::string("duplicate ") + what + " name '" + items[i].name + "'");
  }
}
}  // namespace

void Model::finalize() {
  const SourceLocation here{source_file, 0, ""};
  if (bodies.empty() || bodies[0].name != "ground")
    throw InputError(here, "model has no ground body at index 0");

  // Order joints so each parent body is placed before its children (Simbody needs it).
  std::vector<int> child_of(bodies.size(), -1);
  for (size_t j = 0; j < joints.size(); ++j) {
    const Joint& jt = joints[j];
    if (jt.parent_body < 0 || jt.parent_body >= int(bodies.size()) || jt.child_body <= 0 ||
        jt.child_body >= int(bodies.size()))
      throw InputError({source_file, 0, "joint[" + jt.name + "]"}, "joint does not connect two known bodies");
    if (child_of[jt.child_body] >= 0)
      throw InputError({source_file, 0, "joint[" + jt.name + "]"},
                       "body '" + bodies[jt.child_body].name + "' is the child of two joints ('" +
                           joints[child_of[jt.child_body]].name + "' and '" + jt.name + "'); closed loops are not supported");
    child_of[jt.child_body] = int(j);
  }
  for (size_t b = 1; b < bodies.size(); ++b)
    if (child_of[b] < 0)
      throw InputError({source_file, 0, "body[" + bodies[b].name + "]"}, "body has no joint connecting it to the tree");

  std::vector<int> order;
  std::vector<char> placed(bodies.size(), 0);
  placed[0] = 1;
  std::deque<int> queue{0};
  while (!queue.empty()) {
    const int b = queue.front();
    queue.pop_front();
    for (size_t j = 0; j < joints.size(); ++j)
      if (joints[j].parent_body == b && !placed[joints[j].child_body]) {
        placed[joints[j].child_body] = 1;
        order.push_back(int(j));
        queue.push_back(joints[j].child_body);
      }
  }
  if (order.size() != joints.size())
    throw InputError(here, "the joints do not form a tree rooted at ground (a cycle or a detached body)");
  std::vector<int> new_index(joints.size());
  std::vector<Joint> sorted;
  sorted.reserve(joints.size());
  for (size_t k = 0; k < order.size(); ++k) {
    new_index[order[k]] = int(k);
    sorted.push_back(std::move(joints[order[k]]));
  }
  joints = std::move(sorted);
  for (Coordinate& c : coordinates)
    if (c.joint >= 0) c.joint = new_index[c.joint];

  // Coordinates: owners and positions must agree with the joints' lists.
  for (size_t j = 0; j < joints.size(); ++j) {
    Joint& jt = joints[j];
    for (size_t k = 0; k < jt.coordinates.size(); ++k) {
      const int ci = jt.coordinates[k];
      KNEESIM_CHECK(ci >= 0 && ci < int(coordinates.size()), "joint coordinate index out of range");
      coordinates[ci].joint = int(j);
      coordinates[ci].index_in_joint = int(k);
    }
    if (jt.type == JointType::Custom) {
      for (int a = 0; a < 6; ++a) {
        TransformAxis& ax = jt.spatial[a];
        if (!ax.function) ax.function = ax.coordinates.empty() ? makeConstant(0.0) : makeLinear(1.0, 0.0);
        if (ax.axis.norm() < 1e-12)
          throw InputError({source_file, 0, "joint[" + jt.name + "]"},
                           "transform axis " + std::to_string(a) + " has zero length");
        ax.axis.normalize();
      }
    }
  }
  for (const Coordinate& c : coordinates) {
    if (c.joint < 0) throw InputError({source_file, 0, "coordinate[" + c.name + "]"}, "coordinate belongs to no joint");
    if (c.range_min > c.range_max)
      throw InputError({source_file, 0, "coordinate[" + c.name + "]"},
                       "range minimum " + std::to_string(c.range_min) + " exceeds maximum " + std::to_string(c.range_max));
  }
  for (const CoordinateCoupler& cc : couplers) {
    if (cc.dependent < 0 || !cc.function)
      throw InputError({source_file, 0, "constraint[" + cc.name + "]"}, "coupler has no dependent coordinate or function");
    if (int(cc.independents.size()) != cc.function->getArgumentSize())
      throw InputError({source_file, 0, "constraint[" + cc.name + "]"},
                       "expected " + std::to_string(cc.function->getArgumentSize()) + " independent coordinates, got " +
                           std::to_string(cc.independents.size()));
  }
  for (const Constraint& c : constraints)
    if (c.body1 < 0 || c.body1 >= int(bodies.size()) || c.body2 < 0 || c.body2 >= int(bodies.size()))
      throw InputError({source_file, 0, "constraint[" + c.name + "]"}, "constraint connects no known bodies");
  for (const Marker& m : markers)
    if (m.body < 0 || m.body >= int(bodies.size()))
      throw InputError({source_file, 0, "marker[" + m.name + "]"}, "marker is attached to no known body");

  indexNames(bodies, body_index_, "body", source_file);
  indexNames(joints, joint_index_, "joint", source_file);
  indexNames(coordinates, coordinate_index_, "coordinate", source_file);
  indexNames(markers, marker_index_, "marker", source_file);
  indexNames(muscles, muscle_index_, "muscle", source_file);
  parent_joint_.assign(bodies.size(), -1);
  for (size_t j = 0; j < joints.size(); ++j) parent_joint_[joints[j].child_body] = int(j);
}

namespace {
int lookup(const std::unordered_map<std::string, int>& m, const std::string& n) {
  auto it = m.find(n);
  return it == m.end() ? -1 : it->second;
}
}  // namespace

int Model::findBody(const std::string& n) const { return lookup(body_index_, n); }
int Model::findJoint(const std::string& n) const { return lookup(joint_index_, n); }
int Model::findCoordinate(const std::string& n) const { return lookup(coordinate_index_, n); }
int Model::findMarker(const std::string& n) const { return lookup(marker_index_, n); }
int Model::findMuscle(const std::string& n) const { return lookup(muscle_index_, n); }
int Model::findParentJoint(int body) const {
  return (body >= 0 && body < int(parent_joint_.size())) ? parent_joint_[body] : -1;
}

const char* getJointTypeName(JointType type) {
  switch (type) {
    case JointType::Weld: return "WeldJoint";
    case JointType::Pin: return "PinJoint";
    case JointType::Slider: return "SliderJoint";
    case JointType::Ball: return "BallJoint";
    case JointType::Free: return "FreeJoint";
    case JointType::Universal: return "UniversalJoint";
    case JointType::Gimbal: return "GimbalJoint";
    case JointType::Custom: return "CustomJoint";
    case JointType::Ellipsoid: return "EllipsoidJoint";
    case JointType::Scapulothoracic: return "ScapulothoracicJoint";
  }
  return "Joint";
}

const char* getConstraintTypeName(ConstraintType type) {
  switch (type) {
    case ConstraintType::Point: return "PointConstraint";
    case ConstraintType::PointOnLine: return "PointOnLineConstraint";
    case ConstraintType::ConstantDistance: return "ConstantDistanceConstraint";
    case ConstraintType::Weld: return "WeldConstraint";
  }
  return "Constraint";
}

Pose poseFromXYZ(const Vec3& r, const Vec3& p) {
  Pose X = Pose::Identity();
  X.linear() = (Eigen::AngleAxisd(r.x(), Vec3::UnitX()) * Eigen::AngleAxisd(r.y(), Vec3::UnitY()) *
                Eigen::AngleAxisd(r.z(), Vec3::UnitZ()))
                   .toRotationMatrix();
  X.translation() = p;
  return X;
}

std::string findMeshFile(const std::string& file, const std::string& model_folder) {
  namespace fs = std::filesystem;
  std::string f = file;
  if (f.rfind("file://", 0) == 0) f = f.substr(7);
  if (f.empty()) return "";
  std::vector<fs::path> candidates;
  const fs::path p(f);
  if (p.is_absolute()) {
    candidates.push_back(p);
  } else {
    const fs::path folder = model_folder.empty() ? fs::path(".") : fs::path(model_folder);
    candidates.push_back(folder / p);
    candidates.push_back(folder / "Geometry" / p);
  }
  for (const fs::path& c : candidates) {
    std::error_code ec;
    if (fs::is_regular_file(c, ec)) return fs::absolute(c, ec).lexically_normal().string();
  }
  return "";
}

}  // namespace kneesim::model
