// Joint reactions: OpenSim's request lists resolved, forward accelerations, loads in frames.
#include "muscle/joint_reaction.hpp"

#include <stdexcept>

#include "core/strings.hpp"
#include "muscle/path.hpp"

namespace kneesim::muscle {

namespace {

/// The entry of an OpenSim per-joint list for joint @p k: a one-entry list applies to all.
const std::string& entryFor(const std::vector<std::string>& list, size_t k, const SourceLocation& where,
                            const char* what) {
  if (list.size() == 1) return list[0];
  if (k >= list.size())
    throw InputError(where, std::string("expected one ") + what + " or one per joint, got " + std::to_string(list.size()));
  return list[k];
}

}  // namespace

std::vector<ReactionRequest> resolveReactions(const model::Model& model, const std::vector<std::string>& joints,
                                              const std::vector<std::string>& on,
                                              const std::vector<std::string>& frames, const SourceLocation& where) {
  std::vector<int> ids;
  for (const std::string& name : joints) {
    if (equalsIgnoreCase(name, "all")) {
      ids.clear();
      for (size_t j = 0; j < model.joints.size(); ++j) ids.push_back(int(j));
      break;
    }
    const int j = model.findJoint(name);
    if (j < 0) throw InputError(where, "expected a joint of the model in joint_names, got '" + name + "'");
    ids.push_back(j);
  }
  std::vector<ReactionRequest> out;
  for (size_t k = 0; k < ids.size(); ++k) {
    ReactionRequest r;
    r.joint = ids[k];
    const model::Joint& jt = model.joints[r.joint];
    try {
      r.on = on.empty() ? dynamics::LoadOnBody::Child : dynamics::parseLoadOnBody(entryFor(on, k, where, "apply_on_bodies"));
    } catch (const std::invalid_argument& e) {
      throw InputError(where, std::string("apply_on_bodies: ") + e.what());
    }
    const std::string frame = frames.empty() ? std::string("ground") : entryFor(frames, k, where, "express_in_frame");
    const std::string child = model.bodies[jt.child_body].name, parent = model.bodies[jt.parent_body].name;
    r.frame_label = frame.substr(frame.rfind('/') + 1);
    if (equalsIgnoreCase(frame, "ground")) {
      r.frame = ReactionFrame::Ground;
      r.frame_label = "ground";
    } else if (frame == jt.name + "/" + child + "_offset") {
      r.frame = ReactionFrame::ChildJointFrame;
    } else if (frame == jt.name + "/" + parent + "_offset") {
      r.frame = ReactionFrame::ParentJointFrame;
    } else if ((r.body = model.findBody(frame)) >= 0) {
      r.frame = ReactionFrame::Body;
    } else {
      throw InputError(where, "expected ground, a body or a joint frame '" + jt.name + "/<body>_offset' in express_in_frame, got '" +
                                  frame + "'");
    }
    out.push_back(r);
  }
  return out;
}

std::vector<std::string> reactionLabels(const model::Model& model, const std::vector<ReactionRequest>& requests) {
  static const char* suffix[9] = {"fx", "fy", "fz", "mx", "my", "mz", "px", "py", "pz"};
  std::vector<std::string> labels;
  for (const ReactionRequest& r : requests) {
    const model::Joint& jt = model.joints[r.joint];
    const std::string body = model.bodies[r.on == dynamics::LoadOnBody::Child ? jt.child_body : jt.parent_body].name;
    for (const char* s : suffix) labels.push_back(jt.name + "_on_" + body + "_in_" + r.frame_label + "_" + s);
  }
  return labels;
}

ForwardAccelerations::ForwardAccelerations(const dynamics::InverseDynamics& id) : id_(id) {
  const model::Model& m = id.getModel();
  const int n = id.getNumCoordinates();
  std::vector<bool> dependent(size_t(n), false);
  for (const model::CoordinateCoupler& cc : m.couplers) dependent[cc.dependent] = true;
  for (int c = 0; c < n; ++c)
    if (!dependent[c] && !m.coordinates[c].locked) free_.push_back(c);
  const int nf = int(free_.size());
  C_ = M_ = Eigen::MatrixXd::Zero(n, n);
  K_ = Eigen::MatrixXd::Zero(nf, nf);
  d_ = tau_ = e_ = Eigen::VectorXd::Zero(n);
  rhs_ = a_ = Eigen::VectorXd::Zero(nf);
  ldlt_ = Eigen::LDLT<Eigen::MatrixXd>(nf);
}

void ForwardAccelerations::calc(dynamics::IdWorkspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
                                const Eigen::VectorXd& mobility, Eigen::VectorXd& qddot) {
  const model::Model& m = id_.getModel();
  const int nf = int(free_.size());
  calcCouplingMatrix(m, q, C_);
  calcCouplingAcceleration(m, q, qdot, d_);
  // Inverse dynamics is affine in the accelerations: tau(qddot) = M qddot + tau(0).
  id_.calcGeneralizedForces(ws, d_, tau_);  // tau(d)
  for (int k = 0; k < nf; ++k) {
    // M C e_k = tau(d + C e_k) - tau(d)
    e_ = d_ + C_.col(free_[k]);
    id_.calcGeneralizedForces(ws, e_, M_.col(k));
    M_.col(k) -= tau_;
  }
  for (int i = 0; i < nf; ++i) {
    for (int k = 0; k < nf; ++k) K_(i, k) = C_.col(free_[i]).dot(M_.col(k));
    rhs_[i] = C_.col(free_[i]).dot(mobility) - C_.col(free_[i]).dot(tau_);
  }
  ldlt_.compute(K_);
  a_ = ldlt_.solve(rhs_);
  qddot = d_;
  for (int k = 0; k < nf; ++k) qddot += a_[k] * C_.col(free_[k]);
}

void calcReaction(const sim::System& system, const sim::Workspace& ws, const sim::SpatialColumns& F_joint,
                  const ReactionRequest& r, double* out) {
  const model::Joint& jt = system.getModel().joints[r.joint];
  const dynamics::JointLoad g = dynamics::expressJointLoad(system, ws, r.joint, F_joint, r.on, dynamics::LoadFrame::Ground);
  Eigen::Isometry3d X_GA = Eigen::Isometry3d::Identity();
  switch (r.frame) {
    case ReactionFrame::Ground: break;
    case ReactionFrame::Body: X_GA = system.getBodyPose(ws, r.body); break;
    case ReactionFrame::ChildJointFrame: X_GA = system.getBodyPose(ws, jt.child_body) * jt.X_BM; break;
    case ReactionFrame::ParentJointFrame: X_GA = system.getBodyPose(ws, jt.parent_body) * jt.X_PF; break;
  }
  const Eigen::Matrix3d R_AG = X_GA.linear().transpose();
  const Eigen::Vector3d f = R_AG * g.force, mo = R_AG * g.moment, p = X_GA.inverse() * g.point;
  for (int k = 0; k < 3; ++k) {
    out[k] = f[k];
    out[3 + k] = mo[k];
    out[6 + k] = p[k];
  }
}

}  // namespace kneesim::muscle
