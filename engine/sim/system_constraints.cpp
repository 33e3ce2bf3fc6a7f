// Coordinate couplers and OpenSim's constraints (Point, PointOnLine, ConstantDistance, Weld) as
// Simbody constraints: building them, their position errors, enabling and disabling them.

#include <string>
#include <vector>

#include "core/error.hpp"
#include "sim/system_internal.hpp"

namespace kneesim::sim {

namespace detail {

namespace {

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

void addCouplers(const model::Model& m, SimbodyTree& d) {
  // Couplers become Simbody constraints; IK enforces them by elimination (see ik/solver.cpp).
  for (const model::CoordinateCoupler& cc : m.couplers) {
    std::vector<SimTK::MobilizedBodyIndex> bodies;
    std::vector<SimTK::MobilizerQIndex> qs;
    auto add = [&](int coord) {
      bodies.push_back(d.coord_mobod[coord]);
      qs.push_back(SimTK::MobilizerQIndex(d.coord_mq[coord]));
    };
    for (int c : cc.independents) add(c);
    add(cc.dependent);
    SimTK::Constraint::CoordinateCoupler con(
        d.matter, new CouplerResidual(cc.function, cc.scale_factor, int(cc.independents.size())), bodies, qs);
    d.couplers.push_back(con.getConstraintIndex());
  }
}

void addConstraints(const model::Model& m, SimbodyTree& d) {
  // The model's other constraints as Simbody's: IK enforces them itself (ik/constraint_terms.cpp);
  // these give Simbody's own position errors to check it against.
  for (const model::Constraint& k : m.constraints) {
    SimTK::MobilizedBody& b1 = d.matter.updMobilizedBody(d.mobod[k.body1]);
    SimTK::MobilizedBody& b2 = d.matter.updMobilizedBody(d.mobod[k.body2]);
    const SimTK::Vec3 p1 = toSimTK(Eigen::Vector3d(k.X_B1F1.translation()));
    const SimTK::Vec3 p2 = toSimTK(Eigen::Vector3d(k.X_B2F2.translation()));
    switch (k.type) {
      case model::ConstraintType::Point:
        d.constraints.push_back(SimTK::Constraint::Ball(b1, p1, b2, p2).getConstraintIndex());
        break;
      case model::ConstraintType::ConstantDistance:
        d.constraints.push_back(SimTK::Constraint::Rod(b1, p1, b2, p2, k.distance).getConstraintIndex());
        break;
      case model::ConstraintType::PointOnLine:
        d.constraints.push_back(SimTK::Constraint::PointOnLine(b1, SimTK::UnitVec3(toSimTK(Eigen::Vector3d(k.X_B1F1.linear().col(0)))),
                                                               p1, b2, p2)
                                    .getConstraintIndex());
        break;
      case model::ConstraintType::Weld:
        d.constraints.push_back(
            SimTK::Constraint::Weld(b1, toSimTK(k.X_B1F1), b2, toSimTK(k.X_B2F2)).getConstraintIndex());
        break;
    }
  }
}

}  // namespace detail

Eigen::VectorXd System::calcCouplerErrors(const Workspace& ws) const {
  const model::Model& m = *model_;
  Eigen::VectorXd err(impl_->couplers.size());
  for (size_t i = 0; i < impl_->couplers.size(); ++i) {
    const SimTK::Constraint& con = impl_->matter.getConstraint(impl_->couplers[i]);
    if (!con.isDisabled(ws.impl_->state)) {
      const SimTK::Vector e = con.getPositionErrorsAsVector(ws.impl_->state);
      err[i] = e.size() > 0 ? e[0] : 0.0;
      continue;
    }
    // Disabled in this workspace: Simbody keeps no error for it; evaluate the same residual.
    const model::CoordinateCoupler& cc = m.couplers[i];
    const SimTK::Vector& Q = ws.impl_->state.getQ();
    double x[6];
    for (size_t k = 0; k < cc.independents.size(); ++k) x[k] = Q[impl_->q_index[cc.independents[k]]];
    err[i] = cc.scale_factor * cc.function->calcValue(x) - Q[impl_->q_index[cc.dependent]];
  }
  return err;
}

int System::getNumConstraintEquations(int k) const {
  KNEESIM_CHECK(k >= 0 && k < int(impl_->constraints.size()), "constraint index out of range");
  switch (model_->constraints[k].type) {
    case model::ConstraintType::Point: return 3;
    case model::ConstraintType::PointOnLine: return 2;
    case model::ConstraintType::ConstantDistance: return 1;
    case model::ConstraintType::Weld: return 6;
  }
  return 0;
}

Eigen::VectorXd System::calcConstraintPositionErrors(const Workspace& ws, int k) const {
  KNEESIM_CHECK(k >= 0 && k < int(impl_->constraints.size()), "constraint index out of range");
  const SimTK::Constraint& con = impl_->matter.getConstraint(impl_->constraints[k]);
  KNEESIM_CHECK(!con.isDisabled(ws.impl_->state), "constraint errors asked of a workspace where it is disabled");
  const SimTK::Vector e = con.getPositionErrorsAsVector(ws.impl_->state);
  Eigen::VectorXd out(e.size());
  for (int i = 0; i < e.size(); ++i) out[i] = e[i];
  return out;
}

namespace {

/// Enables or disables the Simbody constraints @p which in @p s; realises positions again if
/// anything changed.
void setEnabled(const SimTK::MultibodySystem& system, const SimTK::SimbodyMatterSubsystem& matter,
                const std::vector<SimTK::ConstraintIndex>& which, SimTK::State& s, bool enabled) {
  bool changed = false;
  for (SimTK::ConstraintIndex ci : which) {
    const SimTK::Constraint& con = matter.getConstraint(ci);
    if (con.isDisabled(s) == !enabled) continue;
    if (enabled)
      con.enable(s);
    else
      con.disable(s);
    changed = true;
  }
  if (changed) system.realize(s, SimTK::Stage::Position);
}

}  // namespace

void System::setConstraintsEnabled(Workspace& ws, bool enabled) const {
  setEnabled(impl_->system, impl_->matter, impl_->constraints, ws.impl_->state, enabled);
}

void System::setCouplersEnabled(Workspace& ws, bool enabled) const {
  setEnabled(impl_->system, impl_->matter, impl_->couplers, ws.impl_->state, enabled);
}

}  // namespace kneesim::sim
