#include "model/urdf.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <locale>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#include <console_bridge/console.h>
#include <urdf_parser/urdf_parser.h>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "model/urdf_check.hpp"

namespace kneesim::model {

namespace {

using xml::Node;

// ============================================================================== reading

/// Collects urdfdom's console messages so a rejected file gives a one-line InputError instead
/// of text on stderr. console_bridge's handler is process-global, hence the mutex.
class CapturingHandler final : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level < console_bridge::CONSOLE_BRIDGE_LOG_WARN) return;
    if (!text_.empty()) text_ += "; ";
    text_ += text;
  }
  const std::string& text() const { return text_; }

 private:
  std::string text_;
};

std::mutex& urdfdomMutex() {
  static std::mutex m;
  return m;
}

urdf::ModelInterfaceSharedPtr parseWithUrdfdom(const std::string& text, std::string& messages) {
  std::lock_guard<std::mutex> lock(urdfdomMutex());
  CapturingHandler handler;
  console_bridge::useOutputHandler(&handler);
  struct Restore {
    ~Restore() { console_bridge::restorePreviousOutputHandler(); }
  } restore;
  urdf::ModelInterfaceSharedPtr model;
  try {
    model = urdf::parseURDF(text);
  } catch (const std::exception& e) {
    messages = e.what();
    return nullptr;
  }
  messages = handler.text();
  return model;
}

/// What urdfdom built must be what the checks read (urdf_check::sameReadingAsUrdfdom saw to it before
/// urdfdom ran; this is the invariant behind the reader's lookups below).
void checkSameReading(const urdf::ModelInterface& u, const std::vector<Node>& links, const std::vector<Node>& joints) {
  for (const Node& l : links)
    if (!u.getLink(l.nameAttr())) urdf_check::differs(l, l.nameAttr());
  for (const Node& j : joints) {
    const urdf::JointConstSharedPtr uj = u.getJoint(j.nameAttr());
    if (!uj) urdf_check::differs(j, j.nameAttr());
    for (const auto& [role, link] : {std::pair{"parent", uj->parent_link_name}, std::pair{"child", uj->child_link_name}})
      if (const std::string mine = *j.child(role).attr("link"); mine != link) urdf_check::differs(j.child(role), mine);
    if (Node mm = j.child("mimic"); mm && (!uj->mimic || uj->mimic->joint_name != *mm.attr("joint")))
      urdf_check::differs(mm, *mm.attr("joint"));
  }
}

Pose toPose(const urdf::Pose& p) {
  Pose X = Pose::Identity();
  double x, y, z, w;
  p.rotation.getQuaternion(x, y, z, w);
  X.linear() = Eigen::Quaterniond(w, x, y, z).normalized().toRotationMatrix();
  X.translation() = Vec3(p.position.x, p.position.y, p.position.z);
  return X;
}

/// A rotation taking @p from onto the unit vector along @p to.
Mat3 alignAxis(const Vec3& from, const Vec3& to) {
  return Eigen::Quaterniond::FromTwoVectors(from, to.normalized()).toRotationMatrix();
}

class UrdfReader {
 public:
  UrdfReader(const xml::Document& doc, const std::string& label) : doc_(doc), label_(label) {
    folder_ = std::filesystem::path(label).parent_path().string();
  }

  std::shared_ptr<Model> read(const std::string& text) {
    std::vector<Node> link_nodes, joint_nodes;
    urdf_check::validate(doc_, link_nodes, joint_nodes);
    urdf_check::sameReadingAsUrdfdom(text, link_nodes, joint_nodes);
    std::string messages;
    urdf::ModelInterfaceSharedPtr u = parseWithUrdfdom(text, messages);
    if (!u) throw InputError({label_, 0, "robot"}, "urdfdom rejected the file: " + (messages.empty() ? "no reason given" : messages));
    checkSameReading(*u, link_nodes, joint_nodes);
    m_->name = u->getName();
    m_->source_file = label_;
    m_->format_version = 0;

    urdf::LinkConstSharedPtr root = u->getRoot();
    if (!root) throw InputError({label_, 0, "robot"}, "expected a single root link, got none");
    const bool root_is_ground = root->name == "world" || root->name == "ground";
    m_->bodies.emplace_back();
    m_->bodies[0].name = "ground";
    if (root_is_ground) link_body_[root->name] = 0;
    for (const Node& ln : link_nodes) {
      const std::string name = ln.nameAttr();
      if (root_is_ground && name == root->name) {
        readLink(*u->getLink(name), 0, ln);
        continue;
      }
      if (name == "ground") ln.fail("a link named 'ground' must be the root link");
      link_body_[name] = int(m_->bodies.size());
      m_->bodies.emplace_back();
      readLink(*u->getLink(name), int(m_->bodies.size()) - 1, ln);
    }
    if (!root_is_ground) {
      Joint weld;
      weld.name = "ground_" + root->name;
      weld.type = JointType::Weld;
      weld.parent_body = 0;
      weld.child_body = link_body_.at(root->name);
      m_->joints.push_back(weld);
    }
    for (const Node& jn : joint_nodes) readJoint(*u->getJoint(jn.nameAttr()), jn);
    for (const Node& jn : joint_nodes) readMimic(*u->getJoint(jn.nameAttr()), jn);
    m_->finalize();
    return m_;
  }

 private:
  void readLink(const urdf::Link& l, int index, const Node& where) {
    Body& b = m_->bodies[index];
    if (index > 0) b.name = l.name;
    if (l.inertial && index > 0) {
      const urdf::Inertial& in = *l.inertial;
      b.mass = in.mass;
      if (b.mass < 0) where.fail("expected a non-negative mass, got " + std::to_string(b.mass));
      const Pose X_BI = toPose(in.origin);
      b.mass_center = X_BI.translation();
      Mat3 I;
      I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
      b.inertia = X_BI.linear() * I * X_BI.linear().transpose();
    }
    for (const auto& v : l.visual_array) {
      if (!v || !v->geometry) continue;
      if (v->geometry->type != urdf::Geometry::MESH) {
        static const char* const shapes[] = {"sphere", "box", "cylinder", "mesh"};
        m_->ignored.push_back({std::string("visual ") + shapes[v->geometry->type], l.name});
        continue;
      }
      const auto* mesh = static_cast<const urdf::Mesh*>(v->geometry.get());
      MeshRef ref;
      ref.file = mesh->filename;
      ref.scale = Vec3(mesh->scale.x, mesh->scale.y, mesh->scale.z);
      ref.X_BG = toPose(v->origin);
      ref.resolved_path = startsWith(ref.file, "package://") ? "" : findMeshFile(ref.file, folder_);
      if (ref.resolved_path.empty())
        m_->warnings.push_back(formatLocated(where.where(), "mesh file '" + ref.file + "' of link '" + l.name +
                                                                "' not found next to the URDF or in Geometry/"));
      b.meshes.push_back(std::move(ref));
    }
    for (const auto& c : l.collision_array)
      if (c) m_->ignored.push_back({"collision", l.name});
  }

  int addCoordinate(const std::string& name, MotionType mt, int joint) {
    Coordinate c;
    c.name = name;
    c.motion_type = mt;
    c.joint = joint;
    coord_of_joint_[name] = int(m_->coordinates.size());
    m_->coordinates.push_back(c);
    return int(m_->coordinates.size()) - 1;
  }

  void readJoint(const urdf::Joint& uj, const Node& where) {
    Joint jt;
    jt.name = uj.name;
    jt.parent_body = link_body_.at(uj.parent_link_name);
    auto child = link_body_.find(uj.child_link_name);
    if (child == link_body_.end() || child->second == 0)
      where.child("child").fail("expected a child link other than the root, got '" + uj.child_link_name + "'");
    jt.child_body = child->second;
    const Pose origin = toPose(uj.parent_to_joint_origin_transform);
    const Vec3 axis(uj.axis.x, uj.axis.y, uj.axis.z);
    const int ji = int(m_->joints.size());
    switch (uj.type) {
      case urdf::Joint::REVOLUTE:
      case urdf::Joint::CONTINUOUS:
      case urdf::Joint::PRISMATIC: {
        const bool slide = uj.type == urdf::Joint::PRISMATIC;
        jt.type = slide ? JointType::Slider : JointType::Pin;
        // Rotate the joint frames so the mobilizer's own axis (pin z, slider x) is the URDF
        // axis; at q = 0 the child frame still coincides with the URDF joint frame.
        const Mat3 A = alignAxis(slide ? Vec3::UnitX() : Vec3::UnitZ(), axis);
        jt.X_PF = origin;
        jt.X_PF.linear() = origin.linear() * A;
        jt.X_BM = Pose::Identity();
        jt.X_BM.linear() = A;
        const int ci = addCoordinate(uj.name, slide ? MotionType::Translational : MotionType::Rotational, ji);
        if (uj.type != urdf::Joint::CONTINUOUS && uj.limits) {
          m_->coordinates[ci].range_min = uj.limits->lower;
          m_->coordinates[ci].range_max = uj.limits->upper;
          m_->coordinates[ci].clamped = true;
        }
        jt.coordinates = {ci};
        break;
      }
      case urdf::Joint::FIXED:
        jt.type = JointType::Weld;
        jt.X_PF = origin;
        break;
      case urdf::Joint::FLOATING: {
        jt.type = JointType::Free;
        jt.X_PF = origin;
        const char* suffix[6] = {"_rx", "_ry", "_rz", "_tx", "_ty", "_tz"};
        for (int k = 0; k < 6; ++k)
          jt.coordinates.push_back(
              addCoordinate(uj.name + suffix[k], k < 3 ? MotionType::Rotational : MotionType::Translational, ji));
        break;
      }
      default:
        where.fail("unsupported joint type (expected " + std::string(urdf_check::kJointTypes) + ")");
    }
    m_->joints.push_back(jt);
  }

  void readMimic(const urdf::Joint& uj, const Node& where) {
    if (!uj.mimic) return;
    auto dep = coord_of_joint_.find(uj.name), ind = coord_of_joint_.find(uj.mimic->joint_name);
    if (dep == coord_of_joint_.end() || ind == coord_of_joint_.end())
      where.child("mimic").fail("expected a mimic between two one-coordinate joints (revolute, continuous or prismatic)");
    CoordinateCoupler cc;
    cc.name = uj.name + "_mimic";
    cc.dependent = dep->second;
    cc.independents = {ind->second};
    cc.function = makeLinear(uj.mimic->multiplier, uj.mimic->offset);
    m_->couplers.push_back(cc);
  }

  const xml::Document& doc_;
  std::string label_, folder_;
  std::shared_ptr<Model> m_ = std::make_shared<Model>();
  std::map<std::string, int> link_body_;
  std::map<std::string, int> coord_of_joint_;
};

// ============================================================================== writing

std::string num(double v) {
  if (v == 0.0) return "0";  // no "-0"
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string vec(const Vec3& v) { return num(v.x()) + " " + num(v.y()) + " " + num(v.z()); }

/// URDF's rpy (R = Rz(yaw) Ry(pitch) Rx(roll)) of a rotation matrix.
Vec3 rpyOf(const Mat3& R) {
  const double sp = std::max(-1.0, std::min(1.0, -R(2, 0)));
  const double pitch = std::asin(sp);
  double roll, yaw;
  if (std::abs(sp) < 1.0 - 1e-12) {
    roll = std::atan2(R(2, 1), R(2, 2));
    yaw = std::atan2(R(1, 0), R(0, 0));
  } else {  // gimbal lock: put everything in yaw
    roll = 0.0;
    yaw = std::atan2(-R(0, 1), R(1, 1));
  }
  return Vec3(roll, pitch, yaw);
}

std::string origin(const Pose& X) {
  return "<origin xyz=\"" + vec(X.translation()) + "\" rpy=\"" + vec(rpyOf(X.linear())) + "\"/>";
}

bool isIdentity(const Pose& X) { return X.matrix().isApprox(Eigen::Matrix4d::Identity(), 1e-14) ||
                                        (X.matrix() - Eigen::Matrix4d::Identity()).cwiseAbs().maxCoeff() < 1e-14; }

/// One elementary motion of a joint: a fixed transform or a motion along one axis.
struct Step {
  enum Kind { Fixed, Revolute, Prismatic } kind = Fixed;
  Pose X = Pose::Identity();  // Fixed
  Vec3 axis = Vec3::UnitZ();  // unit, in the frame reached so far
  int coordinate = -1;        // Revolute/Prismatic: the model coordinate
  double multiplier = 1.0;    // motion = multiplier * q + offset (mimic when not the main axis)
  double offset = 0.0;
};

Pose rotation(const Vec3& axis, double angle) {
  Pose X = Pose::Identity();
  X.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  return X;
}

Pose translation(const Vec3& p) {
  Pose X = Pose::Identity();
  X.translation() = p;
  return X;
}

class UrdfWriter {
 public:
  UrdfWriter(const Model& m, std::vector<std::string>* lost) : m_(m), lost_(lost) {}

  std::string write() {
    main_joint_.assign(m_.coordinates.size(), "");
    link_names_.insert("ground");
    for (size_t b = 1; b < m_.bodies.size(); ++b) link_names_.insert(m_.bodies[b].name);
    for (const Coordinate& c : m_.coordinates) joint_names_.insert(c.name);

    std::ostringstream body;
    // Links first (URDF does not care about order; readers keep file order).
    for (size_t b = 0; b < m_.bodies.size(); ++b) writeLink(body, int(b));
    for (const Joint& jt : m_.joints) writeJoint(jt);
    applyCouplers();
    for (const std::string& l : dummy_links_) body << "  <link name=\"" << xml::escape(l) << "\"/>\n";
    for (const UrdfJoint& uj : urdf_joints_) writeUrdfJoint(body, uj);

    if (!m_.markers.empty())
      note(std::to_string(m_.markers.size()) + " marker(s) dropped: URDF has no markers");
    std::string unclamped, locked, defaults;
    for (size_t k = 0; k < m_.coordinates.size(); ++k) {
      const Coordinate& c = m_.coordinates[k];
      if (main_joint_[k].empty()) continue;
      const bool bounded = std::abs(c.range_min) < 1e29 && std::abs(c.range_max) < 1e29;
      if (bounded && !c.clamped) unclamped += (unclamped.empty() ? "" : ", ") + c.name;
      if (c.locked) locked += (locked.empty() ? "" : ", ") + c.name;
      if (c.default_value != 0.0) defaults += (defaults.empty() ? "" : ", ") + c.name + " = " + num(c.default_value);
    }
    if (!unclamped.empty()) note("coordinate ranges not clamped in the model written as URDF joint limits: " + unclamped);
    if (!locked.empty()) note("locked flags dropped: " + locked);
    if (!defaults.empty()) note("default values dropped (URDF's zero pose has every joint at 0): " + defaults);
    std::ostringstream out;
    out << "<?xml version=\"1.0\"?>\n";
    out << "<!-- Written by kneesim from " << xml::escape(m_.source_file.empty() ? "a model built in code" : m_.source_file)
        << ". Lengths in metres, angles in radians. -->\n";
    out << "<robot name=\"" << xml::escape(m_.name.empty() ? "kneesim" : m_.name) << "\">\n";
    out << body.str();
    out << "</robot>\n";
    return out.str();
  }

 private:
  struct UrdfJoint {
    std::string name, type, parent, child;
    Pose origin = Pose::Identity();
    Vec3 axis = Vec3::UnitZ();
    int coordinate = -1;
    std::string mimic_joint;
    double multiplier = 1.0, offset = 0.0;  // mimic: value = multiplier * other + offset
    double value_scale = 1.0;               // joint value = value_scale * coordinate (for limits)
  };

  void note(const std::string& s) {
    if (lost_) lost_->push_back(s);
  }

  std::string linkName(int body) const { return body == 0 ? "ground" : m_.bodies[body].name; }

  std::string uniqueName(std::set<std::string>& used, const std::string& base) {
    std::string n = base;
    for (int k = 2; used.count(n); ++k) n = base + "_" + std::to_string(k);
    used.insert(n);
    return n;
  }

  void writeLink(std::ostream& o, int b) {
    const Body& body = m_.bodies[b];
    o << "  <link name=\"" << xml::escape(linkName(b)) << "\">\n";
    if (b > 0 && body.mass > 0.0) {
      const Mat3& I = body.inertia;
      o << "    <inertial>\n      " << origin(translation(body.mass_center)) << "\n      <mass value=\""
        << num(body.mass) << "\"/>\n      <inertia ixx=\"" << num(I(0, 0)) << "\" ixy=\"" << num(I(0, 1))
        << "\" ixz=\"" << num(I(0, 2)) << "\" iyy=\"" << num(I(1, 1)) << "\" iyz=\"" << num(I(1, 2))
        << "\" izz=\"" << num(I(2, 2)) << "\"/>\n    </inertial>\n";
    }
    for (const MeshRef& mesh : body.meshes) {
      const std::string file = mesh.resolved_path.empty() ? mesh.file : mesh.resolved_path;
      o << "    <visual>\n      " << origin(mesh.X_BG) << "\n      <geometry><mesh filename=\"" << xml::escape(file)
        << "\" scale=\"" << vec(mesh.scale) << "\"/></geometry>\n    </visual>\n";
    }
    o << "  </link>\n";
  }

  /// The joint's motion as elementary steps from F to M, before reversal.
  std::vector<Step> stepsOf(const Joint& jt) {
    std::vector<Step> steps;
    auto moving = [&](Step::Kind k, const Vec3& axis, int coord) {
      Step s;
      s.kind = k;
      s.axis = axis;
      s.coordinate = coord;
      steps.push_back(s);
    };
    const auto& q = jt.coordinates;
    switch (jt.type) {
      case JointType::Weld: break;
      case JointType::Pin: moving(Step::Revolute, Vec3::UnitZ(), q[0]); break;
      case JointType::Slider: moving(Step::Prismatic, Vec3::UnitX(), q[0]); break;
      case JointType::Universal:
        moving(Step::Revolute, Vec3::UnitX(), q[0]);
        moving(Step::Revolute, Vec3::UnitY(), q[1]);
        break;
      case JointType::Ball:
      case JointType::Gimbal:  // Simbody's Ball in Euler-angle mode is body-fixed XYZ too
        moving(Step::Revolute, Vec3::UnitX(), q[0]);
        moving(Step::Revolute, Vec3::UnitY(), q[1]);
        moving(Step::Revolute, Vec3::UnitZ(), q[2]);
        break;
      case JointType::Free:  // translation in F, then body-fixed XYZ
        moving(Step::Prismatic, Vec3::UnitX(), q[3]);
        moving(Step::Prismatic, Vec3::UnitY(), q[4]);
        moving(Step::Prismatic, Vec3::UnitZ(), q[5]);
        moving(Step::Revolute, Vec3::UnitX(), q[0]);
        moving(Step::Revolute, Vec3::UnitY(), q[1]);
        moving(Step::Revolute, Vec3::UnitZ(), q[2]);
        break;
      case JointType::Ellipsoid:
      case JointType::Scapulothoracic:
        throw InputError({m_.source_file, 0, "joint[" + jt.name + "]"},
                         std::string("expected a joint URDF can express, got a ") + getJointTypeName(jt.type) +
                             " (a point sliding on an ellipsoid)");
      case JointType::Custom: {
        // X_FM = translation(sum f_i a_i, in F) then R1 R2 R3; translations commute.
        static const char* const names[6] = {"rotation1",    "rotation2",    "rotation3",
                                             "translation1", "translation2", "translation3"};
        for (int a : {3, 4, 5, 0, 1, 2}) {
          const TransformAxis& ax = jt.spatial[a];
          const Vec3 u = ax.axis.normalized();
          const bool rot = a < 3;
          double slope = 0, icpt = 0;
          const bool linear = ax.function && ax.coordinates.size() <= 1 && findLinearForm(*ax.function, slope, icpt);
          if (ax.coordinates.empty() || (linear && slope == 0.0)) {
            double zeros[6] = {0, 0, 0, 0, 0, 0};
            const double v = ax.coordinates.empty() ? ax.function->calcValue(zeros) : icpt;
            if (v != 0.0) steps.push_back(fixedStep(rot ? rotation(u, v) : translation(v * u)));
            continue;
          }
          const int c = ax.coordinates[0];
          if (linear && ax.coordinates.size() == 1) {
            if (icpt != 0.0) steps.push_back(fixedStep(rot ? rotation(u, icpt) : translation(icpt * u)));
            Step s;
            s.kind = rot ? Step::Revolute : Step::Prismatic;
            s.axis = u;
            s.coordinate = c;
            s.multiplier = slope;
            steps.push_back(s);
            continue;
          }
          // Not expressible: freeze the axis at the coordinates' default values.
          double x[6] = {0, 0, 0, 0, 0, 0};
          std::string cn;
          for (size_t k = 0; k < ax.coordinates.size() && k < 6; ++k) {
            x[k] = m_.coordinates[ax.coordinates[k]].default_value;
            cn += (k ? ", " : "") + m_.coordinates[ax.coordinates[k]].name;
          }
          const double v = ax.function->calcValue(x);
          note("joint '" + jt.name + "' " + names[a] + ": " + ax.function->getTypeName() + " of " + cn +
               " frozen at " + num(v) + (rot ? " rad" : " m") + " (the coordinates' default values)");
          if (v != 0.0) steps.push_back(fixedStep(rot ? rotation(u, v) : translation(v * u)));
        }
        break;
      }
    }
    return steps;
  }

  static Step fixedStep(const Pose& X) {
    Step s;
    s.kind = Step::Fixed;
    s.X = X;
    return s;
  }

  void writeJoint(const Joint& jt) {
    std::vector<Step> steps = stepsOf(jt);
    // OpenSim 3.x reverse joints: the transform maps child to parent (see sim/system.cpp), so the
    // chain is the inverse: steps in reverse order, each inverted.
    const bool reversed = (jt.reverse && m_.format_version > 0 && m_.format_version < 40000) || jt.reversed_in_tree;
    if (reversed) {
      std::reverse(steps.begin(), steps.end());
      for (Step& s : steps) {
        if (s.kind == Step::Fixed)
          s.X = s.X.inverse();
        else {
          s.axis = -s.axis;
        }
      }
    }
    // Offsets inside the chain: motion = multiplier * q + offset is written as a motion about
    // axis * sign(multiplier) when |multiplier| = 1, else as a mimic of the main joint.
    int last_moving = -1;
    for (size_t k = 0; k < steps.size(); ++k)
      if (steps[k].kind != Step::Fixed) last_moving = int(k);
    Pose tail = jt.X_BM.inverse();
    for (size_t k = steps.size(); k-- > size_t(last_moving + 1);) tail = steps[k].X * tail;

    Pose pending = jt.X_PF;
    std::string prev = linkName(jt.parent_body);
    const std::string child = linkName(jt.child_body);
    int dummy = 0;
    for (int k = 0; k <= last_moving; ++k) {
      const Step& s = steps[k];
      if (s.kind == Step::Fixed) {
        pending = pending * s.X;
        continue;
      }
      UrdfJoint uj;
      uj.type = s.kind == Step::Revolute ? "revolute" : "prismatic";
      uj.parent = prev;
      uj.origin = pending;
      uj.coordinate = s.coordinate;
      const Coordinate& c = m_.coordinates[s.coordinate];
      const bool pure = std::abs(s.multiplier) == 1.0;
      uj.axis = pure ? Vec3(s.axis * s.multiplier) : s.axis;
      const std::string& main = main_joint_[s.coordinate];
      if (pure && main.empty()) {
        uj.name = c.name;
        main_joint_[s.coordinate] = c.name;
      } else {
        // A further axis of an exported coordinate (or one with a slope other than +-1): a
        // mimic of the coordinate's main joint, resolved once every joint is known.
        uj.name = uniqueName(joint_names_, c.name + "_" + jt.name + "_" + std::to_string(k));
        uj.mimic_joint = "#" + std::to_string(s.coordinate);
        uj.multiplier = s.multiplier;
        uj.value_scale = s.multiplier;
        uj.axis = s.axis;
      }
      if (uj.type == "revolute" && !(std::abs(c.range_min) < 1e29 && std::abs(c.range_max) < 1e29) &&
          uj.mimic_joint.empty())
        uj.type = "continuous";
      const bool last = k == last_moving && isIdentity(tail);
      uj.child = last ? child : uniqueName(link_names_, jt.name + "_" + std::to_string(dummy++));
      if (!last) dummy_links_.push_back(uj.child);
      urdf_joints_.push_back(uj);
      prev = uj.child;
      pending = Pose::Identity();
    }
    if (prev != child) {
      UrdfJoint fixed;
      fixed.type = "fixed";
      fixed.name = uniqueName(joint_names_, last_moving < 0 ? jt.name : jt.name + "_offset");
      fixed.parent = prev;
      fixed.child = child;
      fixed.origin = last_moving < 0 ? pending * tail : tail;
      urdf_joints_.push_back(fixed);
    }
  }

  void applyCouplers() {
    // Mimic joints of axes: point them at their coordinate's main joint.
    for (UrdfJoint& uj : urdf_joints_) {
      if (uj.mimic_joint.empty() || uj.mimic_joint[0] != '#') continue;
      const int c = std::stoi(uj.mimic_joint.substr(1));
      if (main_joint_[c].empty()) {
        // The coordinate moves no pure axis anywhere: this axis becomes its main joint when the
        // slope is +-1 (never here), else it cannot be expressed.
        // The coordinate moves no axis with slope +-1: this joint's value is slope * q, which a
        // reader sees as a coordinate of its own.
        note("coordinate '" + m_.coordinates[c].name + "' moves '" + uj.name + "' with slope " + num(uj.multiplier) +
             " and no axis with slope +-1; the URDF joint's value is the slope times the coordinate");
        main_joint_[c] = uj.name;
        uj.mimic_joint.clear();
        uj.multiplier = 1.0;
        continue;
      }
      uj.mimic_joint = main_joint_[c];
    }
    for (const Constraint& k : m_.constraints)
      note(std::string(getConstraintTypeName(k.type)) + " '" + k.name + "' dropped: URDF has no closed loops");
    for (const CoordinateCoupler& cc : m_.couplers) {
      double slope, icpt;
      const bool linear = cc.independents.size() == 1 && findLinearForm(*cc.function, slope, icpt);
      const std::string& dep = main_joint_[cc.dependent];
      const std::string ind = cc.independents.empty() ? "" : main_joint_[cc.independents[0]];
      if (!linear || dep.empty() || ind.empty()) {
        note("coupler '" + cc.name + "' (" + cc.function->getTypeName() + ") dropped: URDF mimic is linear in one joint");
        continue;
      }
      for (UrdfJoint& uj : urdf_joints_)
        if (uj.name == dep) {
          uj.mimic_joint = ind;
          uj.multiplier = cc.scale_factor * slope;
          uj.offset = cc.scale_factor * icpt;
        }
    }
  }

  void writeUrdfJoint(std::ostream& o, const UrdfJoint& uj) {
    o << "  <joint name=\"" << xml::escape(uj.name) << "\" type=\"" << uj.type << "\">\n";
    o << "    <parent link=\"" << xml::escape(uj.parent) << "\"/>\n    <child link=\"" << xml::escape(uj.child)
      << "\"/>\n    " << origin(uj.origin) << "\n";
    if (uj.type != "fixed") {
      o << "    <axis xyz=\"" << vec(uj.axis) << "\"/>\n";
      if (uj.type != "continuous") {
        const Coordinate& c = m_.coordinates[uj.coordinate];
        double lo = uj.value_scale * c.range_min, hi = uj.value_scale * c.range_max;
        if (lo > hi) std::swap(lo, hi);
        o << "    <limit lower=\"" << num(lo) << "\" upper=\"" << num(hi) << "\" effort=\"0\" velocity=\"0\"/>\n";
      }
      if (!uj.mimic_joint.empty())
        o << "    <mimic joint=\"" << xml::escape(uj.mimic_joint) << "\" multiplier=\"" << num(uj.multiplier)
          << "\" offset=\"" << num(uj.offset) << "\"/>\n";
    }
    o << "  </joint>\n";
  }

  const Model& m_;
  std::vector<std::string>* lost_;
  std::vector<std::string> main_joint_;  // per coordinate: the URDF joint it drives directly
  std::set<std::string> link_names_, joint_names_;
  std::vector<std::string> dummy_links_;
  std::vector<UrdfJoint> urdf_joints_;
};

}  // namespace

ModelPtr parseUrdf(const std::string& text, const std::string& label) {
  const auto doc = xml::Document::parse(text, label);
  UrdfReader reader(*doc, label);
  return reader.read(text);
}

ModelPtr readUrdf(const std::string& path) { return parseUrdf(readFileText(path), path); }

std::string formatUrdf(const Model& model, std::vector<std::string>* lost) {
  UrdfWriter writer(model, lost);
  return writer.write();
}

void writeUrdf(const Model& model, const std::string& path, std::vector<std::string>* lost) {
  const std::string text = formatUrdf(model, lost);
  writeFileAtomically(path, [&](std::ostream& o) { o << text; });
}

}  // namespace kneesim::model
