// OpenSim's joints as Simbody mobilized bodies: the built-in mobilizers, the ScapulothoracicJoint's
// chain of three, and CustomJoint's SpatialTransform as a Custom mobilizer that allocates nothing.

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>

#include "core/error.hpp"
#include "sim/system_internal.hpp"

namespace kneesim::sim::detail {

namespace {

using model::JointType;

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

/// OpenSim's CustomJoint as a Simbody Custom mobilizer, with the same kinematics as Simbody's
/// MobilizedBody::FunctionBased: X_FM = (R(f0, a0) R(f1, a1) R(f2, a2), f3 a3 + f4 a4 + f5 a5), the
/// rotations a body-fixed sequence and the translation expressed in F. Unlike FunctionBased it
/// evaluates the model functions on plain arrays and reads q and u straight from the State, so
/// realising positions allocates nothing (FunctionBased builds SimTK::Vectors for every function
/// call and copies q out of the State), which makes it about twice as fast.
///
/// H is recomputed in each multiplyByHMatrix() call instead of being cached in the State: Simbody
/// asks for one column per mobility, and each column needs only the derivatives of the axes that
/// depend on that coordinate, so nothing is evaluated twice but the two leading rotations.
class SpatialTransformMobilizer final : public SimTK::MobilizedBody::Custom::Implementation {
 public:
  struct Axis {
    model::FunctionPtr function;
    std::vector<int> args;  // indices into the joint's coordinates
    SimTK::UnitVec3 axis;
  };

  SpatialTransformMobilizer(SimTK::SimbodyMatterSubsystem& matter, SimTK::MobilizedBodyIndex self, int nc,
                            std::array<Axis, 6> axes)
      : Implementation(matter, nc, nc, 0), matter_(&matter), self_(self), nc_(nc), axes_(std::move(axes)) {}
  SpatialTransformMobilizer(const SpatialTransformMobilizer& o)
      : Implementation(o), matter_(o.matter_), self_(o.self_), nc_(o.nc_), axes_(o.axes_), first_q_(o.first_q_),
        first_u_(o.first_u_) {}

  Implementation* clone() const override { return new SpatialTransformMobilizer(*this); }

  SimTK::Transform calcMobilizerTransformFromQ(const SimTK::State&, int nq, const SimTK::Real* q) const override {
    KNEESIM_ASSERT(nq == nc_);
    double v[6];
    for (int a = 0; a < 6; ++a) v[a] = value(a, q);
    const SimTK::Rotation R = SimTK::Rotation(v[0], axes_[0].axis) * SimTK::Rotation(v[1], axes_[1].axis) *
                              SimTK::Rotation(v[2], axes_[2].axis);
    return SimTK::Transform(R, v[3] * axes_[3].axis + v[4] * axes_[4].axis + v[5] * axes_[5].axis);
  }

  SimTK::SpatialVec multiplyByHMatrix(const SimTK::State& s, int nu, const SimTK::Real* u) const override {
    KNEESIM_ASSERT(nu == nc_);
    double q[6];
    loadQ(s, q);
    double rate[6];
    bool turns = false;
    for (int a = 0; a < 6; ++a) {
      rate[a] = firstDerivative(a, q, u);
      turns = turns || (a < 3 && rate[a] != 0);
    }
    SimTK::SpatialVec V(SimTK::Vec3(0), SimTK::Vec3(0));
    if (turns) {  // Simbody asks column by column: a translation's column needs no rotation
      SimTK::Vec3 W[3];
      calcW(q, W);
      for (int a = 0; a < 3; ++a) V[0] += rate[a] * W[a];
    }
    for (int a = 3; a < 6; ++a) V[1] += rate[a] * axes_[a].axis;
    return V;
  }

  void multiplyByHTranspose(const SimTK::State& s, const SimTK::SpatialVec& F, int nu, SimTK::Real* f) const override {
    multiplyTransposeByColumns(nu, F, f, [&](const double* e) { return multiplyByHMatrix(s, nu, e); });
  }

  SimTK::SpatialVec multiplyByHDotMatrix(const SimTK::State& s, int nu, const SimTK::Real* u) const override {
    // d/dt (H u) at fixed u: the rotated axes turn with the frames before them, and the rates
    // of the functions change through their second derivatives.
    KNEESIM_ASSERT(nu == nc_);
    double q[6], qd[6];
    loadQ(s, q);
    loadU(s, qd);
    double rate[6];
    bool turns = false;
    for (int a = 0; a < 3; ++a) {
      rate[a] = firstDerivative(a, q, u);
      turns = turns || rate[a] != 0;
    }
    SimTK::SpatialVec A(SimTK::Vec3(0), SimTK::Vec3(0));
    if (turns) {  // as in multiplyByHMatrix(): a translation's column needs no rotation
      SimTK::Vec3 W[3];
      calcW(q, W);
      const SimTK::Vec3 w1 = firstDerivative(0, q, qd) * W[0];  // angular velocity of frame 1 in F
      const SimTK::Vec3 w2 = w1 + firstDerivative(1, q, qd) * W[1];
      const SimTK::Vec3 Wdot[3] = {SimTK::Vec3(0), SimTK::cross(w1, W[1]), SimTK::cross(w2, W[2])};
      for (int a = 0; a < 3; ++a) A[0] += rate[a] * Wdot[a] + secondDerivative(a, q, u, qd) * W[a];
    }
    for (int a = 3; a < 6; ++a) A[1] += secondDerivative(a, q, u, qd) * axes_[a].axis;
    return A;
  }

  void multiplyByHDotTranspose(const SimTK::State& s, const SimTK::SpatialVec& F, int nu,
                               SimTK::Real* f) const override {
    multiplyTransposeByColumns(nu, F, f, [&](const double* e) { return multiplyByHDotMatrix(s, nu, e); });
  }

 private:
  /// f = M^T F for M = H or HDot, a column of M at a time (@p multiply gives M e for a unit e).
  template <class Multiply>
  static void multiplyTransposeByColumns(int nu, const SimTK::SpatialVec& F, SimTK::Real* f, Multiply multiply) {
    double e[6] = {0, 0, 0, 0, 0, 0};
    for (int j = 0; j < nu; ++j) {
      e[j] = 1;
      const SimTK::SpatialVec M = multiply(e);
      f[j] = SimTK::dot(M[0], F[0]) + SimTK::dot(M[1], F[1]);
      e[j] = 0;
    }
  }
  void loadQ(const SimTK::State& s, double* q) const {
    const SimTK::Vector& Q = s.getQ();
    const int first = firstIndex(s);
    for (int k = 0; k < nc_; ++k) q[k] = Q[first + k];
  }
  void loadU(const SimTK::State& s, double* u) const {
    const SimTK::Vector& U = s.getU();
    firstIndex(s);
    const int first = first_u_.get();
    for (int k = 0; k < nc_; ++k) u[k] = U[first + k];
  }
  /// Index of this mobilizer's first q in the State, looked up once: Simbody's getOneQ() finds
  /// it again (with a dynamic_cast) for every coordinate of every call. All States of a System
  /// share one layout (kneesim sets Euler angles in the default State before copying it).
  int firstIndex(const SimTK::State& s) const {
    int i = first_q_.get();
    if (i < 0) {
      const SimTK::MobilizedBody& mb = matter_->getMobilizedBody(self_);
      first_u_.set(int(mb.getFirstUIndex(s)));
      i = int(mb.getFirstQIndex(s));
      first_q_.set(i);
    }
    return i;
  }
  double value(int a, const double* q) const {
    double x[6] = {0, 0, 0, 0, 0, 0};
    const Axis& ax = axes_[a];
    for (size_t k = 0; k < ax.args.size(); ++k) x[k] = q[ax.args[k]];
    return ax.function->calcValue(x);
  }
  /// Rate of axis a's function for coordinate rates u: sum_k df/dx_k u[arg k].
  double firstDerivative(int a, const double* q, const double* u) const {
    const Axis& ax = axes_[a];
    double x[6], rate = 0;
    for (size_t k = 0; k < ax.args.size(); ++k) x[k] = q[ax.args[k]];
    for (size_t k = 0; k < ax.args.size(); ++k) {
      if (u[ax.args[k]] == 0) continue;
      const int c[1] = {int(k)};
      rate += ax.function->calcDerivative(x, c, 1) * u[ax.args[k]];
    }
    return rate;
  }
  /// sum_k sum_l d2f/dx_k dx_l u[arg k] qd[arg l].
  double secondDerivative(int a, const double* q, const double* u, const double* qd) const {
    const Axis& ax = axes_[a];
    double x[6], acc = 0;
    for (size_t k = 0; k < ax.args.size(); ++k) x[k] = q[ax.args[k]];
    for (size_t k = 0; k < ax.args.size(); ++k)
      for (size_t l = 0; l < ax.args.size(); ++l) {
        const double w = u[ax.args[k]] * qd[ax.args[l]];
        if (w == 0) continue;
        const int c[2] = {int(k), int(l)};
        acc += ax.function->calcDerivative(x, c, 2) * w;
      }
    return acc;
  }
  /// Rotation axes in F: a0, R1 a1, R1 R2 a2.
  /// Simbody asks for H and HDot one column at a time, all at the same q: the axes of the
  /// previous call on this thread are reused when it was this mobilizer (by a unique id, not an
  /// address that a later mobilizer could reuse) at the same q.
  void calcW(const double* q, SimTK::Vec3 W[3]) const {
    struct Last {
      std::uint64_t id = 0;
      double q[6];
      SimTK::Vec3 W[3];
    };
    static thread_local Last last;
    if (last.id == id_ && std::equal(q, q + nc_, last.q)) {
      for (int a = 0; a < 3; ++a) W[a] = last.W[a];
      return;
    }
    const SimTK::Rotation R1(value(0, q), axes_[0].axis);
    const SimTK::Rotation R12 = R1 * SimTK::Rotation(value(1, q), axes_[1].axis);
    W[0] = axes_[0].axis.asVec3();
    W[1] = (R1 * axes_[1].axis).asVec3();
    W[2] = (R12 * axes_[2].axis).asVec3();
    last.id = id_;
    std::copy(q, q + nc_, last.q);
    for (int a = 0; a < 3; ++a) last.W[a] = W[a];
  }

  static std::uint64_t nextId() {
    static std::atomic<std::uint64_t> counter{0};
    return ++counter;
  }

  /// A State index shared by threads (every thread stores the same value; first_u_ is stored
  /// before first_q_ is released), copyable because Simbody clones implementations.
  struct CachedIndex {
    mutable std::atomic<int> value{-1};
    CachedIndex() = default;
    CachedIndex(const CachedIndex& o) : value(o.value.load(std::memory_order_acquire)) {}
    int get() const { return value.load(std::memory_order_acquire); }
    void set(int v) const { value.store(v, std::memory_order_release); }
  };

  const SimTK::SimbodyMatterSubsystem* matter_;
  SimTK::MobilizedBodyIndex self_;
  int nc_;
  std::array<Axis, 6> axes_;
  CachedIndex first_q_, first_u_;
  std::uint64_t id_ = nextId();
};

/// The mass properties of body @p b about its origin; an inertia Simbody rejects is replaced by a
/// point mass at the centre of mass (inertia does not affect kinematics), said in @p warnings.
SimTK::MassProperties massProperties(const model::Body& b, std::vector<std::string>& warnings) {
  try {
    const SimTK::Inertia I_c(SimTK::Vec3(b.inertia(0, 0), b.inertia(1, 1), b.inertia(2, 2)),
                             SimTK::Vec3(b.inertia(0, 1), b.inertia(0, 2), b.inertia(1, 2)));
    return SimTK::MassProperties(b.mass, toSimTK(b.mass_center), I_c.shiftFromMassCenter(toSimTK(b.mass_center), b.mass));
  } catch (const std::exception&) {
    // Inertia does not affect kinematics; keep going with a valid stand-in and say so.
    warnings.push_back("body '" + b.name + "': invalid inertia replaced by a point mass at its centre of mass");
    return SimTK::MassProperties(b.mass, toSimTK(b.mass_center), SimTK::Inertia(toSimTK(b.mass_center), b.mass));
  }
}

/// What every joint's mobilized body is built from.
struct JointFrames {
  SimTK::MobilizedBody& parent;
  const SimTK::Body::Rigid& body;
  SimTK::Transform X_PF, X_BM;
  bool reversed;
  SimTK::MobilizedBody::Direction dir;
};

/// OpenSim's ScapulothoracicJoint: an Ellipsoid mobilizer (abduction, elevation, upward rotation)
/// whose F frame is the parent frame turned pi/2 about z, with the radii swapped to match (x, y ->
/// y, x); a Pin (winging) about an axis in the ellipsoid's tangent plane; a Weld to the scapula's
/// joint frame. Both intermediate bodies are massless. Maps the joint's coordinates to the first two.
SimTK::MobilizedBodyIndex addScapulothoracic(const model::Joint& jt, const JointFrames& f, SimbodyTree& d) {
  const SimTK::Transform R_z90(SimTK::Rotation(SimTK::Pi / 2, SimTK::ZAxis), SimTK::Vec3(0));
  SimTK::MobilizedBody::Ellipsoid ellipsoid(f.parent, f.X_PF * R_z90, SimTK::Body::Massless(), R_z90,
                                            SimTK::Vec3(jt.radii.y(), jt.radii.x(), jt.radii.z()));
  const double a = jt.winging_direction;
  const SimTK::Transform W(SimTK::Rotation(SimTK::UnitVec3(-std::sin(a), std::cos(a), 0), SimTK::ZAxis),
                           SimTK::Vec3(jt.winging_origin.x(), jt.winging_origin.y(), 0));
  SimTK::MobilizedBody::Pin winging(ellipsoid, W, SimTK::Body::Massless(), W);
  const SimTK::MobilizedBodyIndex idx =
      SimTK::MobilizedBody::Weld(winging, SimTK::Transform(), f.body, f.X_BM).getMobilizedBodyIndex();
  for (size_t k = 0; k < jt.coordinates.size(); ++k) {
    d.coord_mobod[jt.coordinates[k]] = k < 3 ? ellipsoid.getMobilizedBodyIndex() : winging.getMobilizedBodyIndex();
    d.coord_mq[jt.coordinates[k]] = k < 3 ? int(k) : 0;
  }
  return idx;
}

/// OpenSim's CustomJoint: a weld at its constant transform when it has no coordinates, else
/// Simbody's FunctionBased mobilizer (SystemOptions::simbody_function_based) or the lean
/// SpatialTransformMobilizer with the same kinematics.
SimTK::MobilizedBodyIndex addCustom(const model::Model& m, const model::Joint& jt, const JointFrames& f,
                                    const SystemOptions& options, SimbodyTree& d, const SourceLocation& where) {
  const int nc = int(jt.coordinates.size());
  std::vector<const SimTK::Function*> functions;
  std::vector<std::vector<int>> coord_indices;
  std::vector<SimTK::Vec3> axes;
  std::array<SpatialTransformMobilizer::Axis, 6> lean_axes;
  for (int a = 0; a < 6; ++a) {
    const model::TransformAxis& ax = jt.spatial[a];
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
    if (ax.axis.norm() < 1e-12)
      throw InputError(where, "transform axis " + std::to_string(a + 1) + ": expected a non-zero axis, got 0 0 0");
    functions.push_back(new ModelFunction(ax.function, int(local.size())));
    coord_indices.push_back(local);
    axes.push_back(toSimTK(ax.axis));
    lean_axes[a] = {ax.function, local, SimTK::UnitVec3(toSimTK(ax.axis))};
  }
  if (nc == 0) {
    // A CustomJoint with no coordinates is a weld at its constant transform.
    SimTK::Vector none(0);
    SimTK::Rotation R = SimTK::Rotation(functions[0]->calcValue(none), SimTK::UnitVec3(axes[0])) *
                        SimTK::Rotation(functions[1]->calcValue(none), SimTK::UnitVec3(axes[1])) *
                        SimTK::Rotation(functions[2]->calcValue(none), SimTK::UnitVec3(axes[2]));
    SimTK::Vec3 p = functions[3]->calcValue(none) * SimTK::UnitVec3(axes[3]) +
                    functions[4]->calcValue(none) * SimTK::UnitVec3(axes[4]) +
                    functions[5]->calcValue(none) * SimTK::UnitVec3(axes[5]);
    SimTK::Transform T(R, p);
    if (f.reversed) T = ~T;
    for (auto* fn : functions) delete fn;
    return SimTK::MobilizedBody::Weld(f.parent, f.X_PF * T, f.body, f.X_BM).getMobilizedBodyIndex();
  }
  if (options.simbody_function_based)
    return SimTK::MobilizedBody::FunctionBased(f.parent, f.X_PF, f.body, f.X_BM, nc, functions, coord_indices, axes,
                                               f.dir)
        .getMobilizedBodyIndex();
  for (auto* fn : functions) delete fn;
  const SimTK::MobilizedBodyIndex next(d.matter.getNumBodies());
  const SimTK::MobilizedBodyIndex idx =
      SimTK::MobilizedBody::Custom(f.parent, new SpatialTransformMobilizer(d.matter, next, nc, lean_axes), f.X_PF,
                                   f.body, f.X_BM, f.dir)
          .getMobilizedBodyIndex();
  KNEESIM_CHECK(idx == next, "Simbody numbered a new mobilized body unexpectedly");
  return idx;
}

/// A built-in Simbody mobilizer of type @p M between the joint's frames.
template <class M>
SimTK::MobilizedBodyIndex addBuiltIn(const JointFrames& f) {
  return M(f.parent, f.X_PF, f.body, f.X_BM, f.dir).getMobilizedBodyIndex();
}

/// The mobilized body of joint @p jt's child, of the joint's type.
SimTK::MobilizedBodyIndex addJoint(const model::Model& m, const model::Joint& jt, const JointFrames& f,
                                   const SystemOptions& options, SimbodyTree& d, const SourceLocation& where) {
  using MB = SimTK::MobilizedBody;
  switch (jt.type) {
    case JointType::Weld: return MB::Weld(f.parent, f.X_PF, f.body, f.X_BM).getMobilizedBodyIndex();
    case JointType::Pin: return addBuiltIn<MB::Pin>(f);
    case JointType::Slider: return addBuiltIn<MB::Slider>(f);
    case JointType::Universal: return addBuiltIn<MB::Universal>(f);
    case JointType::Gimbal: return addBuiltIn<MB::Gimbal>(f);
    case JointType::Ball: return addBuiltIn<MB::Ball>(f);
    case JointType::Free: return addBuiltIn<MB::Free>(f);
    case JointType::Ellipsoid: return MB::Ellipsoid(f.parent, f.X_PF, f.body, f.X_BM, toSimTK(jt.radii)).getMobilizedBodyIndex();
    case JointType::Scapulothoracic: return addScapulothoracic(jt, f, d);
    case JointType::Custom: return addCustom(m, jt, f, options, d, where);
  }
  return SimTK::MobilizedBodyIndex();  // not reached: every JointType is a case
}

}  // namespace

bool isQDotEqualToU(JointType t) {
  return t != JointType::Gimbal && t != JointType::Ball && t != JointType::Free && t != JointType::Ellipsoid &&
         t != JointType::Scapulothoracic;
}

void addJoints(const model::Model& m, const SystemOptions& options, SimbodyTree& d,
               std::vector<std::string>& warnings) {
  d.mobod.assign(m.bodies.size(), SimTK::MobilizedBodyIndex());
  d.mobod[0] = SimTK::GroundIndex;
  d.coord_mobod.assign(m.coordinates.size(), SimTK::MobilizedBodyIndex());
  d.coord_mq.assign(m.coordinates.size(), 0);
  for (const model::Joint& jt : m.joints) {
    const SourceLocation where{m.source_file, 0, "joint[" + jt.name + "]"};
    const SimTK::Body::Rigid body(massProperties(m.bodies[jt.child_body], warnings));
    // In OpenSim 3.x files `reverse` means the joint transform maps child to parent (Simbody's
    // Reverse mobilizer, as OpenSim 3.3 built it). OpenSim 4 keeps the joint's meaning and only
    // flips the tree, which for a parent-first tree is the forward mobilizer (and the Reverse one
    // for a joint the tree uses from its child, reversed_in_tree).
    const bool reversed = (jt.reverse && m.format_version > 0 && m.format_version < 40000) || jt.reversed_in_tree;
    const JointFrames f{d.matter.updMobilizedBody(d.mobod[jt.parent_body]), body, toSimTK(jt.X_PF),
                        toSimTK(jt.X_BM), reversed,
                        reversed ? SimTK::MobilizedBody::Reverse : SimTK::MobilizedBody::Forward};
    SimTK::MobilizedBodyIndex idx;
    try {
      idx = addJoint(m, jt, f, options, d, where);
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      throw InputError(where, std::string("Simbody rejected the joint: ") + e.what());
    }
    d.mobod[jt.child_body] = idx;
    if (jt.type != JointType::Scapulothoracic)
      for (size_t k = 0; k < jt.coordinates.size(); ++k) {
        d.coord_mobod[jt.coordinates[k]] = idx;
        d.coord_mq[jt.coordinates[k]] = int(k);
      }
  }
}

}  // namespace kneesim::sim::detail
