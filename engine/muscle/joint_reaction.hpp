#pragma once
// Joint reaction loads as OpenSim's JointReaction analysis reports them: at each frame the
// accelerations forward dynamics gives under gravity, external loads and the actuators' forces
// (a forces file, e.g. static optimisation's), then the load each chosen joint transmits, on its
// child or parent, expressed in ground, a body, or the joint's own frame on either side.
//
// The load is the joint's net load (dynamics::InverseDynamics::calcJointLoads): along the joint's
// free axes it includes what the actuators drive there (a reserve's moment about a hinge), which
// Simbody's mobilizer reaction may leave out; across them it is the reaction.

#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "core/error.hpp"
#include "dynamics/inverse_dynamics.hpp"
#include "dynamics/joint_loads.hpp"

namespace kneesim::muscle {

/// Where a reaction is expressed.
enum class ReactionFrame { Ground, Body, ChildJointFrame, ParentJointFrame };

/// One reported joint load.
struct ReactionRequest {
  int joint = -1;
  dynamics::LoadOnBody on = dynamics::LoadOnBody::Child;
  ReactionFrame frame = ReactionFrame::Ground;
  int body = -1;            ///< For ReactionFrame::Body.
  std::string frame_label;  ///< The frame's name in OpenSim's column labels.
};

/// Resolves OpenSim's joint_names, apply_on_bodies and express_in_frame lists for @p model (a
/// one-entry list applies to every joint; "All" names every joint). A frame is "ground", a body
/// name, or a joint frame "<joint>/<body>_offset" (OpenSim 4's name for the frame a 3.x joint
/// places on that body). Throws InputError at @p where for names the model lacks.
std::vector<ReactionRequest> resolveReactions(const model::Model& model, const std::vector<std::string>& joints,
                                              const std::vector<std::string>& on,
                                              const std::vector<std::string>& frames, const SourceLocation& where);

/// The OpenSim column labels of @p requests: <joint>_on_<body>_in_<frame>_fx .. _pz.
std::vector<std::string> reactionLabels(const model::Model& model, const std::vector<ReactionRequest>& requests);

/// Forward dynamics through inverse dynamics: the accelerations at which the model's inverse
/// dynamics equal given mobility forces, coordinate couplers and locks respected. Buffers sized
/// once; no allocation per call.
class ForwardAccelerations {
 public:
  explicit ForwardAccelerations(const dynamics::InverseDynamics& id);
  /// The accelerations (model order) at the state and applied forces held in @p ws (after
  /// setState() and the loads), with @p mobility forces on the coordinates.
  void calc(dynamics::IdWorkspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
            const Eigen::VectorXd& mobility, Eigen::VectorXd& qddot);

 private:
  const dynamics::InverseDynamics& id_;
  std::vector<int> free_;
  Eigen::MatrixXd C_, M_, K_;
  Eigen::VectorXd d_, tau_, e_, rhs_, a_;
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
};

/// The 9 numbers of @p request (fx fy fz mx my mz px py pz) from net joint loads @p F_joint.
void calcReaction(const sim::System& system, const sim::Workspace& ws, const sim::SpatialColumns& F_joint,
                  const ReactionRequest& request, double* out);

}  // namespace kneesim::muscle
