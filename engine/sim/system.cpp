#include "sim/system.hpp"

#ifdef NDEBUG
#error "Simbody headers must not be compiled with NDEBUG: Debian's Simbody is built without it (simbody#701)"
#endif
#include <Simbody.h>

#include "core/error.hpp"

namespace kneesim::sim {

namespace {

using model::JointType;

SimTK::Vec3 toSimTK(const Eigen::Vector3d& v) { return SimTK::Vec3(v.x(), v.y(), v.z()); }

SimTK::Transform toSimTK(const Eigen::Isometry3d& X) {
  SimTK::Mat33 R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R(i, j) = X.linear()(i, j);
  return SimTK::Transform(SimTK::Rotation(R, true), toSimTK(X.translation()));
}

Eigen::Isometry3d toEigen(const SimTK::Transform& X) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out.linear()(i, j) = X.R().asMat33()(i, j);
    out.translation()(i) = X.p()[i];
  }
  return out;
}

/// A model::Function seen as a SimTK::Function of @p n_args arguments. A transform axis with
/// no coordinates uses n_args = 0 and evaluates its function at 0 (a constant).
class ModelFunction final : public SimTK::Function {
 public:
  ModelFunction(model::FunctionPtr f, int n_args) : f_(std::move(f)), n_(n_args) {}
  SimTK::Real calcValue(const SimTK::Vector& x) const override {
    double buf[6] = {0, 0, 0, 0, 0, 0};
    for (int i = 0; i < n_; ++i) buf[i] = x[i];
    return f_->calcValue(buf);
  }
  SimTK::Real calcDerivative(const SimTK::Array_<int>& c, const SimTK::Vector& x) const override {
    if (n_ == 0) return 0.0;
    double buf[6] = {0, 0, 0, 0, 0, 0};
    for (int i = 0; i < n_; ++i) buf[i] = x[i];
    int comps[3] = {0, 0, 0};
    const int order = int(c.size());
    if (order > 2) return 0.0;  // only first and second derivatives are requested by Simbody
    for (int k = 0; k < order; ++k) comps[k] = c[k];
    return f_->calcDerivative(buf, comps, order);
  }
  int getArgumentSize() const override { return n_; }
  int getMaxDerivativeOrder() const override { return 2; }
  SimTK::Function* clone() const override { return new ModelFunction(f_, n_); }

 private:
  model::FunctionPtr f_;
  int n_;
};

/// Residual of a coordinate coupler, g(x) = scale * f(x_0..x_{n-1}) - x_n, kept at zero.
class CouplerResidual final : public SimTK::Function {
 public:
  CouplerResidual(model::FunctionPtr f, double scale, int n_indep) : f_(std::move(f)), scale_(scale), n_(n_indep) {}
  SimTK::Real calcValue(const SimTK::Vector& x) const override {
    double buf[6];
    for (int i = 0; i < n_; ++i) buf[i] = x[i];
    return scale_ * f_->calcValue(buf) - x[n_];
  }
  SimTK::Real calcDerivative(const SimTK::Array_<int>& c, const SimTK::Vector& x) const override {
    const int order = int(c.size());
    for (int k = 0; k < order; ++k)
      if (c[k] == n_) return (order == 1) ? -1.0 : 0.0;
    if (order > 2) return 0.0;
    double buf[6];
    for (int i = 0; i < n_; ++i) buf[i] = x[i];
    int comps[2] = {c[0], order > 1 ? c[1] : 0};
    return scale_ * f_->calcDerivative(buf, comps, order);
  }
  int getArgumentSize() const override { return n_ + 1; }
  int getMaxDerivativeOrder() const override { return 2; }
  SimTK::Function* clone() const override { return new CouplerResidual(f_, scale_, n_); }

 private:
  model::FunctionPtr f_;
  double scale_;
  int n_;
};

}  // namespace

struct System::Impl {
  SimTK::MultibodySystem system;
  SimTK::SimbodyMatterSubsystem matter{system};
  SimTK::GeneralForceSubsystem forces{system};
  std::vector<SimTK::MobilizedBodyIndex> mobod;  // per model body
  std::vector<SimTK::ConstraintIndex> couplers;  // per model coupler
  std::vector<int> q_index;  // per model coordinate: index into State Q
  std::vector<int> u_index;  // per model coordinate: index into State U
  int nq = 0, nu = 0;
  SimTK::State default_state;  // realised to Model stage with Euler angles
};

struct Workspace::Impl {
  SimTK::State state;
  SimTK::Matrix JS;
  SimTK::Array_<SimTK::MobilizedBodyIndex> bodies;
  SimTK::Array_<SimTK::Vec3> stations;
  SimTK::Vector row_in, row_out;
};

Workspace::Workspace(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Workspace::~Workspace() = default;

System::~System() = default;

System::System(model::ModelPtr model) : model_(std::move(model)), impl_(std::make_unique<Impl>()) {
  const model::Model& m = *model_;
  Impl& d = *impl_;
  SimTK::Force::Gravity(d.forces, d.matter, toSimTK(m.gravity));
  d.mobod.assign(m.bodies.size(), SimTK::MobilizedBodyIndex());
  d.mobod[0] = SimTK::GroundIndex;

  for (const model::Joint& jt : m.joints) {
    const SourceLocation where{m.source_file, 0, "joint[" + jt.name + "]"};
    const model::Body& b = m.bodies[jt.child_body];
    SimTK::MassProperties mp;
    try {
      const SimTK::Inertia I_c(SimTK::Vec3(b.inertia(0, 0), b.inertia(1, 1), b.inertia(2, 2)),
                               SimTK::Vec3(b.inertia(0, 1), b.inertia(0, 2), b.inertia(1, 2)));
      mp = SimTK::MassProperties(b.mass, toSimTK(b.mass_center), I_c.shiftFromMassCenter(toSimTK(b.mass_center), b.mass));
    } catch (const std::exception&) {
      // Inertia does not affect kinematics; keep going with a valid stand-in and say so.
      warnings_.push_back("body '" + b.name + "': invalid inertia replaced by a point mass at its centre of mass");
      mp = SimTK::MassProperties(b.mass, toSimTK(b.mass_center),
                                 SimTK::Inertia(toSimTK(b.mass_center), b.mass));
    }
    const SimTK::Body::Rigid body(mp);
    SimTK::MobilizedBody& parent = d.matter.updMobilizedBody(d.mobod[jt.parent_body]);
    const SimTK::Transform X_PF = toSimTK(jt.X_PF), X_BM = toSimTK(jt.X_BM);
    // In OpenSim 3.x files `reverse` means the joint transform maps child to parent (Simbody's
    // Reverse mobilizer, as OpenSim 3.3 built it). OpenSim 4 keeps the joint's meaning and only
    // flips the tree, which for a parent-first tree is the forward mobilizer.
    const bool reversed = jt.reverse && m.format_version > 0 && m.format_version < 40000;
    const auto dir = reversed ? SimTK::MobilizedBody::Reverse : SimTK::MobilizedBody::Forward;
    SimTK::MobilizedBodyIndex idx;
    try {
      switch (jt.type) {
        case JointType::Weld:
          idx = SimTK::MobilizedBody::Weld(parent, X_PF, body, X_BM).getMobilizedBodyIndex();
          break;
        case JointType::Pin:
          idx = SimTK::MobilizedBody::Pin(parent, X_PF, body, X_BM, dir).getMobilizedBodyIndex();
          break;
        case JointType::Slider:
          idx = SimTK::MobilizedBody::Slider(parent, X_PF, body, X_BM, dir).getMobilizedBodyIndex();
          break;
        case JointType::Universal:
          idx = SimTK::MobilizedBody::Universal(parent, X_PF, body, X_BM, dir).getMobilizedBodyIndex();
          break;
        case JointType::Gimbal:
          idx = SimTK::MobilizedBody::Gimbal(parent, X_PF, body, X_BM, dir).getMobilizedBodyIndex();
          qdot_is_u_ = false;
          break;
        case JointType::Ball:
          idx = SimTK::MobilizedBody::Ball(parent, X_PF, body, X_BM, dir).getMobilizedBodyIndex();
          qdot_is_u_ = false;
          break;
        case JointType::Free:
          idx = SimTK::MobilizedBody::Free(parent, X_PF, body, X_BM, dir).getMobilizedBodyIndex();
          qdot_is_u_ = false;
          break;
        case JointType::Custom: {
          const int nc = int(jt.coordinates.size());
          std::vector<const SimTK::Function*> functions;
          std::vector<std::vector<int>> coord_indices;
          std::vector<SimTK::Vec3> axes;
          for (const model::TransformAxis& ax : jt.spatial) {
            std::vector<int> local;
            for (int c : ax.coordinates) {
              auto it = std::find(jt.coordinates.begin(), jt.coordinates.end(), c);
              if (it == jt.coordinates.end())
                throw InputError(where, "transform axis uses coordinate '" + m.coordinates[c].name +
                                            "' that belongs to another joint");
              local.push_back(int(it - jt.coordinates.begin()));
            }
            if (!local.empty() && int(local.size()) != ax.function->getArgumentSize())
              throw InputError(where, "transform axis function of type " + ax.function->getTypeName() + " takes " +
                                          std::to_string(ax.function->getArgumentSize()) + " arguments, got " +
                                          std::to_string(local.size()) + " coordinates");
            functions.push_back(new ModelFunction(ax.function, int(local.size())));
            coord_indices.push_back(local);
            axes.push_back(toSimTK(ax.axis));
          }
          if (nc == 0) {
            // A CustomJoint with no coordinates is a weld at its constant transform.
            SimTK::Vector none(0);
            SimTK::Rotation R = SimTK::Rotation(functions[0]->calcValue(none), SimTK::UnitVec3(axes[0])) *
                                SimTK::Rotation(functions[1]->calcValue(none), SimTK::UnitVec3(axes[1])) *
                                SimTK::Rotation(functions[2]->calcValue(none), SimTK::UnitVec3(axes[2]));
            SimTK::Vec3 p = functions[3]->calcValue(none) * axes[3] + functions[4]->calcValue(none) * axes[4] +
                            functions[5]->calcValue(none) * axes[5];
            SimTK::Transform T(R, p);
            if (reversed) T = ~T;
            for (auto* f : functions) delete f;
            idx = SimTK::MobilizedBody::Weld(parent, X_PF * T, body, X_BM).getMobilizedBodyIndex();
          } else {
            idx = SimTK::MobilizedBody::FunctionBased(parent, X_PF, body, X_BM, nc, functions, coord_indices, axes, dir)
                      .getMobilizedBodyIndex();
          }
          break;
        }
      }
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      throw InputError(where, std::string("Simbody rejected the joint: ") + e.what());
    }
    d.mobod[jt.child_body] = idx;
  }

  // Couplers become Simbody constraints; IK enforces them by elimination (see ik/solver.cpp).
  for (const model::CoordinateCoupler& cc : m.couplers) {
    std::vector<SimTK::MobilizedBodyIndex> bodies;
    std::vector<SimTK::MobilizerQIndex> qs;
    auto add = [&](int coord) {
      const model::Coordinate& c = m.coordinates[coord];
      bodies.push_back(d.mobod[m.joints[c.joint].child_body]);
      qs.push_back(SimTK::MobilizerQIndex(c.index_in_joint));
    };
    for (int c : cc.independents) add(c);
    add(cc.dependent);
    SimTK::Constraint::CoordinateCoupler con(
        d.matter, new CouplerResidual(cc.function, cc.scale_factor, int(cc.independents.size())), bodies, qs);
    d.couplers.push_back(con.getConstraintIndex());
  }

  try {
    d.system.realizeTopology();
    d.default_state = d.system.getDefaultState();
    d.matter.setUseEulerAngles(d.default_state, true);
    d.system.realizeModel(d.default_state);
  } catch (const std::exception& e) {
    throw InputError({m.source_file, 0, ""}, std::string("Simbody could not build the model: ") + e.what());
  }
  d.nq = d.default_state.getNQ();
  d.nu = d.default_state.getNU();
  d.q_index.resize(m.coordinates.size());
  d.u_index.resize(m.coordinates.size());
  for (size_t i = 0; i < m.coordinates.size(); ++i) {
    const model::Coordinate& c = m.coordinates[i];
    const SimTK::MobilizedBody& mb = d.matter.getMobilizedBody(d.mobod[m.joints[c.joint].child_body]);
    KNEESIM_CHECK(c.index_in_joint < mb.getNumQ(d.default_state), "coordinate beyond its mobilizer's q");
    d.q_index[i] = int(mb.getFirstQIndex(d.default_state)) + c.index_in_joint;
    d.u_index[i] = int(mb.getFirstUIndex(d.default_state)) + c.index_in_joint;
  }
  KNEESIM_CHECK(d.nq == int(m.coordinates.size()),
                "Simbody has " + std::to_string(d.nq) + " q but the model has " +
                    std::to_string(m.coordinates.size()) + " coordinates");
  for (size_t i = 0; i < m.coordinates.size(); ++i) d.default_state.updQ()[d.q_index[i]] = m.coordinates[i].default_value;
  d.system.realize(d.default_state, SimTK::Stage::Position);
}

std::unique_ptr<Workspace> System::createWorkspace() const {
  auto impl = std::make_unique<Workspace::Impl>();
  impl->state = impl_->default_state;
  impl_->system.realize(impl->state, SimTK::Stage::Position);
  return std::unique_ptr<Workspace>(new Workspace(std::move(impl)));
}

Eigen::VectorXd System::getDefaultCoordinates() const {
  Eigen::VectorXd q(model_->coordinates.size());
  for (size_t i = 0; i < model_->coordinates.size(); ++i) q[i] = model_->coordinates[i].default_value;
  return q;
}

void System::realizePosition(Workspace& ws, const Eigen::VectorXd& q) const {
  KNEESIM_ASSERT(q.size() == getNumCoordinates());
  SimTK::Vector& Q = ws.impl_->state.updQ();
  for (int i = 0; i < q.size(); ++i) Q[impl_->q_index[i]] = q[i];
  impl_->system.realize(ws.impl_->state, SimTK::Stage::Position);
}

Eigen::Isometry3d System::getBodyPose(const Workspace& ws, int body) const {
  return toEigen(impl_->matter.getMobilizedBody(impl_->mobod[body]).getBodyTransform(ws.impl_->state));
}

Eigen::Vector3d System::findStationLocation(const Workspace& ws, int body, const Eigen::Vector3d& p_BS) const {
  const SimTK::Vec3 p = impl_->matter.getMobilizedBody(impl_->mobod[body])
                            .findStationLocationInGround(ws.impl_->state, toSimTK(p_BS));
  return Eigen::Vector3d(p[0], p[1], p[2]);
}

void System::calcStationJacobian(Workspace& ws, const std::vector<int>& bodies,
                                 const std::vector<Eigen::Vector3d>& stations, Eigen::Ref<Eigen::MatrixXd> J) const {
  Workspace::Impl& w = *ws.impl_;
  const int n = int(bodies.size());
  KNEESIM_CHECK(int(stations.size()) == n && J.rows() == 3 * n && J.cols() == getNumCoordinates(),
                "station Jacobian sizes do not match");
  if (int(w.bodies.size()) != n) {
    w.bodies.resize(n);
    w.stations.resize(n);
  }
  for (int i = 0; i < n; ++i) {
    w.bodies[i] = impl_->mobod[bodies[i]];
    w.stations[i] = toSimTK(stations[i]);
  }
  if (w.JS.nrow() != 3 * n || w.JS.ncol() != impl_->nu) w.JS.resize(3 * n, impl_->nu);
  impl_->matter.calcStationJacobian(w.state, w.bodies, w.stations, w.JS);
  const int nc = getNumCoordinates();
  if (qdot_is_u_) {
    for (int c = 0; c < nc; ++c) {
      const int u = impl_->u_index[c];
      for (int r = 0; r < 3 * n; ++r) J(r, c) = w.JS(r, u);
    }
    return;
  }
  // dp/dq = dp/du * N^-1: each row r of JS times N^-1 is (N^-T r^T)^T.
  if (w.row_in.size() != impl_->nu) w.row_in.resize(impl_->nu);
  if (w.row_out.size() != impl_->nq) w.row_out.resize(impl_->nq);
  for (int r = 0; r < 3 * n; ++r) {
    for (int u = 0; u < impl_->nu; ++u) w.row_in[u] = w.JS(r, u);
    impl_->matter.multiplyByNInv(w.state, true, w.row_in, w.row_out);
    for (int c = 0; c < nc; ++c) J(r, c) = w.row_out[impl_->q_index[c]];
  }
}

Eigen::VectorXd System::calcCouplerErrors(const Workspace& ws) const {
  Eigen::VectorXd err(impl_->couplers.size());
  for (size_t i = 0; i < impl_->couplers.size(); ++i) {
    const SimTK::Vector e = impl_->matter.getConstraint(impl_->couplers[i]).getPositionErrorsAsVector(ws.impl_->state);
    err[i] = e.size() > 0 ? e[0] : 0.0;
  }
  return err;
}

}  // namespace kneesim::sim
