#include "dynamics/joint_loads.hpp"

#include <stdexcept>

#include "core/strings.hpp"

namespace kneesim::dynamics {

JointLoad expressJointLoad(const sim::System& system, const sim::Workspace& ws, int joint,
                           const sim::SpatialColumns& F_joint, LoadOnBody on, LoadFrame frame) {
  const model::Model& m = system.getModel();
  const model::Joint& jt = m.joints[joint];
  const Eigen::Isometry3d X_GB = system.getBodyPose(ws, jt.child_body);
  const Eigen::Isometry3d X_GP = system.getBodyPose(ws, jt.parent_body);
  Eigen::Vector3d force = F_joint.col(jt.child_body).tail<3>();
  Eigen::Vector3d moment_o = F_joint.col(jt.child_body).head<3>();  // about the child's origin
  Eigen::Vector3d point_G;
  if (on == LoadOnBody::Child) {
    point_G = X_GB * jt.X_BM.translation();
  } else {
    point_G = X_GP * jt.X_PF.translation();
    force = -force;
    moment_o = -moment_o;
  }
  // Shift from the child's origin to the joint centre: M_P = M_o + (p_o - p_P) x F.
  const Eigen::Vector3d moment_G = moment_o + (X_GB.translation() - point_G).cross(force);
  JointLoad out;
  if (frame == LoadFrame::Ground) {
    out.force = force;
    out.moment = moment_G;
    out.point = point_G;
    return out;
  }
  const Eigen::Isometry3d& X_GF = frame == LoadFrame::Child ? X_GB : X_GP;
  const Eigen::Matrix3d R_FG = X_GF.linear().transpose();
  out.force = R_FG * force;
  out.moment = R_FG * moment_G;
  out.point = R_FG * (point_G - X_GF.translation());
  return out;
}

LoadOnBody parseLoadOnBody(const std::string& s) {
  const std::string t = toLower(trim(s));
  if (t == "child") return LoadOnBody::Child;
  if (t == "parent") return LoadOnBody::Parent;
  throw std::invalid_argument("expected child or parent, got '" + s + "'");
}

LoadFrame parseLoadFrame(const std::string& s) {
  const std::string t = toLower(trim(s));
  if (t == "ground") return LoadFrame::Ground;
  if (t == "child") return LoadFrame::Child;
  if (t == "parent") return LoadFrame::Parent;
  throw std::invalid_argument("expected ground, parent or child, got '" + s + "'");
}

std::string getLoadBodyName(const model::Model& model, int joint, LoadOnBody on) {
  const model::Joint& jt = model.joints[joint];
  return model.bodies[on == LoadOnBody::Child ? jt.child_body : jt.parent_body].name;
}

std::string getLoadFrameName(const model::Model& model, int joint, LoadFrame frame) {
  if (frame == LoadFrame::Ground) return "ground";
  const model::Joint& jt = model.joints[joint];
  return model.bodies[frame == LoadFrame::Child ? jt.child_body : jt.parent_body].name;
}

}  // namespace kneesim::dynamics
