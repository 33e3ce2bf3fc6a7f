#include "sim/system.hpp"

#ifdef NDEBUG
#error "Simbody headers must not be compiled with NDEBUG: Debian's Simbody is built without it (simbody#701)"
#endif
#include <Simbody.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>

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
    double e[6] = {0, 0, 0, 0, 0, 0};
    for (int j = 0; j < nu; ++j) {
      e[j] = 1;
      const SimTK::SpatialVec H = multiplyByHMatrix(s, nu, e);
      f[j] = SimTK::dot(H[0], F[0]) + SimTK::dot(H[1], F[1]);
      e[j] = 0;
    }
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
    double e[6] = {0, 0, 0, 0, 0, 0};
    for (int j = 0; j < nu; ++j) {
      e[j] = 1;
      const SimTK::SpatialVec Hd = multiplyByHDotMatrix(s, nu, e);
      f[j] = SimTK::dot(Hd[0], F[0]) + SimTK::dot(Hd[1], F[1]);
      e[j] = 0;
    }
  }

 private:
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

}  // namespace

struct System::Impl {
  SimTK::MultibodySystem system;
  SimTK::SimbodyMatterSubsystem matter{system};
  SimTK::GeneralForceSubsystem forces{system};
  std::vector<SimTK::MobilizedBodyIndex> mobod;  // per model body
  // Per model coordinate: the mobilized body whose mobilizer it is (the child body's, except in a
  // ScapulothoracicJoint, which chains three) and its q's index in that mobilizer.
  std::vector<SimTK::MobilizedBodyIndex> coord_mobod;
  std::vector<int> coord_mq;
  std::vector<SimTK::ConstraintIndex> couplers;  // per model coupler
  std::vector<SimTK::ConstraintIndex> constraints;  // per Model::constraints entry
  std::vector<int> q_index;  // per model coordinate: index into State Q
  std::vector<int> u_index;  // per model coordinate: index into State U
  int nq = 0, nu = 0;
  // Station Jacobians: for each model body, the coordinates of the joint that moves it and the
  // body's parent; coordinates whose mobilizer has qdot != u (Gimbal, Ball, Free, Ellipsoid).
  std::vector<std::vector<int>> body_coords;
  std::vector<int> parent_body;
  std::vector<int> n_coords;   // coordinates whose q differs from u, grouped by mobilizer
  std::vector<int> n_group;    // their mobilized body (index), one group per mobilizer
  SimTK::State default_state;  // realised to Model stage with Euler angles
};

struct Workspace::Impl {
  SimTK::State state;
  // Station-Jacobian scratch, sized once at creation.
  std::vector<Eigen::Matrix<double, 6, 1>> H;  // per coordinate: (w, v) of its body for u = 1
  std::vector<Eigen::Vector3d> p_GB;           // per coordinate: its mobilized body's origin in ground
  SimTK::Vector q_unit, u_out;                 // N^-1 columns for qdot != u mobilizers
  Eigen::Matrix<double, Eigen::Dynamic, 6> block;  // one joint's columns while converting
  Eigen::Matrix<double, 6, 6> NInv;
  // Inverse dynamics buffers, sized once at creation.
  SimTK::Vector mobility_forces, udot, residual;
  SimTK::Vector_<SimTK::SpatialVec> body_forces;
  std::vector<Eigen::Matrix<double, 6, 1>> subtree;  // per body: force on its subtree
  std::vector<Eigen::Vector3d> p_GBody;              // per body: its origin in ground
};

Workspace::Workspace(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Workspace::~Workspace() = default;

System::~System() = default;

System::System(model::ModelPtr model, SystemOptions options)
    : model_(std::move(model)), impl_(std::make_unique<Impl>()) {
  const model::Model& m = *model_;
  Impl& d = *impl_;
  SimTK::Force::Gravity(d.forces, d.matter, toSimTK(m.gravity));
  d.mobod.assign(m.bodies.size(), SimTK::MobilizedBodyIndex());
  d.mobod[0] = SimTK::GroundIndex;
  d.coord_mobod.assign(m.coordinates.size(), SimTK::MobilizedBodyIndex());
  d.coord_mq.assign(m.coordinates.size(), 0);

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
        case JointType::Ellipsoid:
          idx = SimTK::MobilizedBody::Ellipsoid(parent, X_PF, body, X_BM, toSimTK(jt.radii)).getMobilizedBodyIndex();
          qdot_is_u_ = false;
          break;
        case JointType::Scapulothoracic: {
          // OpenSim's ScapulothoracicJoint: an Ellipsoid mobilizer (abduction, elevation, upward
          // rotation) whose F frame is the parent frame turned pi/2 about z, with the radii
          // swapped to match (x, y -> y, x); a Pin (winging) about an axis in the ellipsoid's
          // tangent plane; a Weld to the scapula's joint frame. Both intermediate bodies are massless.
          const SimTK::Transform R_z90(SimTK::Rotation(SimTK::Pi / 2, SimTK::ZAxis), SimTK::Vec3(0));
          SimTK::MobilizedBody::Ellipsoid ellipsoid(parent, X_PF * R_z90, SimTK::Body::Massless(), R_z90,
                                                    SimTK::Vec3(jt.radii.y(), jt.radii.x(), jt.radii.z()));
          const double a = jt.winging_direction;
          const SimTK::Transform W(SimTK::Rotation(SimTK::UnitVec3(-std::sin(a), std::cos(a), 0), SimTK::ZAxis),
                                   SimTK::Vec3(jt.winging_origin.x(), jt.winging_origin.y(), 0));
          SimTK::MobilizedBody::Pin winging(ellipsoid, W, SimTK::Body::Massless(), W);
          idx = SimTK::MobilizedBody::Weld(winging, SimTK::Transform(), body, X_BM).getMobilizedBodyIndex();
          for (size_t k = 0; k < jt.coordinates.size(); ++k) {
            d.coord_mobod[jt.coordinates[k]] = k < 3 ? ellipsoid.getMobilizedBodyIndex() : winging.getMobilizedBodyIndex();
            d.coord_mq[jt.coordinates[k]] = k < 3 ? int(k) : 0;
          }
          qdot_is_u_ = false;
          break;
        }
        case JointType::Custom: {
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
            if (reversed) T = ~T;
            for (auto* f : functions) delete f;
            idx = SimTK::MobilizedBody::Weld(parent, X_PF * T, body, X_BM).getMobilizedBodyIndex();
          } else if (options.simbody_function_based) {
            idx = SimTK::MobilizedBody::FunctionBased(parent, X_PF, body, X_BM, nc, functions, coord_indices, axes, dir)
                      .getMobilizedBodyIndex();
          } else {
            for (auto* f : functions) delete f;
            const SimTK::MobilizedBodyIndex next(d.matter.getNumBodies());
            idx = SimTK::MobilizedBody::Custom(parent, new SpatialTransformMobilizer(d.matter, next, nc, lean_axes),
                                               X_PF, body, X_BM, dir)
                      .getMobilizedBodyIndex();
            KNEESIM_CHECK(idx == next, "Simbody numbered a new mobilized body unexpectedly");
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
    if (jt.type != JointType::Scapulothoracic)
      for (size_t k = 0; k < jt.coordinates.size(); ++k) {
        d.coord_mobod[jt.coordinates[k]] = idx;
        d.coord_mq[jt.coordinates[k]] = int(k);
      }
  }

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
    const SimTK::MobilizedBody& mb = d.matter.getMobilizedBody(d.coord_mobod[i]);
    KNEESIM_CHECK(d.coord_mq[i] < mb.getNumQ(d.default_state), "coordinate beyond its mobilizer's q");
    d.q_index[i] = int(mb.getFirstQIndex(d.default_state)) + d.coord_mq[i];
    d.u_index[i] = int(mb.getFirstUIndex(d.default_state)) + d.coord_mq[i];
  }
  // With Euler angles a Ball or Free mobilizer uses 3 of the 4 rotation q slots Simbody keeps
  // for its quaternion, so State::getNQ() may exceed the coordinates; the q in use must not.
  int nq_in_use = 0;
  for (SimTK::MobilizedBodyIndex b(1); b < d.matter.getNumBodies(); ++b)
    nq_in_use += d.matter.getMobilizedBody(b).getNumQ(d.default_state);
  KNEESIM_CHECK(nq_in_use == int(m.coordinates.size()),
                "Simbody uses " + std::to_string(nq_in_use) + " q but the model has " +
                    std::to_string(m.coordinates.size()) + " coordinates");
  for (size_t i = 0; i < m.coordinates.size(); ++i) d.default_state.updQ()[d.q_index[i]] = m.coordinates[i].default_value;
  d.body_coords.assign(m.bodies.size(), {});
  d.parent_body.assign(m.bodies.size(), -1);
  for (size_t j = 0; j < m.joints.size(); ++j) {
    const model::Joint& jt = m.joints[j];
    d.body_coords[jt.child_body] = jt.coordinates;
    d.parent_body[jt.child_body] = jt.parent_body;
    const bool q_is_u = jt.type != JointType::Gimbal && jt.type != JointType::Ball && jt.type != JointType::Free &&
                        jt.type != JointType::Ellipsoid && jt.type != JointType::Scapulothoracic;
    if (!q_is_u)
      for (size_t k = 0; k < jt.coordinates.size(); ++k) {
        if (jt.type == JointType::Scapulothoracic && k == 3) continue;  // the winging Pin has qdot = u
        d.n_coords.push_back(jt.coordinates[k]);
        d.n_group.push_back(int(d.coord_mobod[jt.coordinates[k]]));
      }
  }
  d.system.realize(d.default_state, SimTK::Stage::Position);
}

std::unique_ptr<Workspace> System::createWorkspace() const {
  auto impl = std::make_unique<Workspace::Impl>();
  impl->state = impl_->default_state;
  impl->H.assign(model_->coordinates.size(), Eigen::Matrix<double, 6, 1>::Zero());
  impl->p_GB.assign(model_->coordinates.size(), Eigen::Vector3d::Zero());
  impl->q_unit.resize(impl_->nq);
  impl->u_out.resize(impl_->nu);
  impl->NInv.setZero();
  impl->mobility_forces.resize(impl_->nu);
  impl->mobility_forces = 0;
  impl->udot.resize(impl_->nu);
  impl->residual.resize(impl_->nu);
  impl->body_forces.resize(impl_->matter.getNumBodies());
  impl->subtree.assign(model_->bodies.size(), Eigen::Matrix<double, 6, 1>::Zero());
  impl->p_GBody.assign(model_->bodies.size(), Eigen::Vector3d::Zero());
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
  // Column c of the Jacobian for a station S on a body at or below the body B that coordinate c
  // moves is w x (p_S - p_B) + v, with (w, v) = H_c, the spatial velocity of B in ground for
  // u_c = 1 (Simbody's hinge-matrix column, cached at Position stage). This costs O(stations x
  // depth) small products instead of one Simbody sweep per row, and allocates nothing.
  Workspace::Impl& w = *ws.impl_;
  const Impl& d = *impl_;
  const model::Model& m = *model_;
  const int n = int(bodies.size());
  KNEESIM_CHECK(int(stations.size()) == n && J.rows() == 3 * n && J.cols() == getNumCoordinates(),
                "station Jacobian sizes do not match");
  for (size_t c = 0; c < m.coordinates.size(); ++c) {
    const SimTK::MobilizedBody& mb = d.matter.getMobilizedBody(d.coord_mobod[c]);
    const SimTK::SpatialVec H = mb.getHCol(w.state, SimTK::MobilizerUIndex(d.coord_mq[c]));
    w.H[c] << H[0][0], H[0][1], H[0][2], H[1][0], H[1][1], H[1][2];
    const SimTK::Vec3& p = mb.getBodyOriginLocation(w.state);
    w.p_GB[c] = Eigen::Vector3d(p[0], p[1], p[2]);
  }
  J.setZero();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p_S = findStationLocation(ws, bodies[i], stations[i]);
    for (int a = bodies[i]; a > 0; a = d.parent_body[a])
      for (int c : d.body_coords[a])
        J.block<3, 1>(3 * i, c) = w.H[c].head<3>().cross(p_S - w.p_GB[c]) + w.H[c].tail<3>();
  }
  if (d.n_coords.empty()) return;
  // Mobilizers with qdot = N u, N != I: dp/dq = dp/du N^-1, one mobilizer's block at a time.
  for (size_t k = 0; k < d.n_coords.size();) {
    const int group = d.n_group[k];
    size_t e = k;
    while (e < d.n_coords.size() && d.n_group[e] == group) ++e;
    const int nb = int(e - k);
    for (int jj = 0; jj < nb; ++jj) {
      w.q_unit = 0;
      w.q_unit[d.q_index[d.n_coords[k + jj]]] = 1;
      d.matter.multiplyByNInv(w.state, false, w.q_unit, w.u_out);
      for (int ii = 0; ii < nb; ++ii) w.NInv(ii, jj) = w.u_out[d.u_index[d.n_coords[k + ii]]];
    }
    if (w.block.rows() != J.rows()) w.block.resize(J.rows(), 6);
    for (int ii = 0; ii < nb; ++ii) w.block.col(ii) = J.col(d.n_coords[k + ii]);
    for (int jj = 0; jj < nb; ++jj) {
      J.col(d.n_coords[k + jj]).setZero();
      for (int ii = 0; ii < nb; ++ii) J.col(d.n_coords[k + jj]) += w.NInv(ii, jj) * w.block.col(ii);
    }
    k = e;
  }
}

void System::calcGeneralizedForcesFromBodyForces(Workspace& ws, const SpatialColumns& F,
                                                 Eigen::Ref<Eigen::VectorXd> tau) const {
  // tau_c = H_c . (the force on the subtree of the body coordinate c moves, as a torque about
  // that body's origin and a force), with H_c Simbody's hinge-matrix column (see
  // calcStationJacobian). Subtree sums keep torques about the ground origin so they add without
  // shifting. Simbody's multiplyBySystemJacobianTranspose does the same but allocates.
  Workspace::Impl& w = *ws.impl_;
  const Impl& d = *impl_;
  const model::Model& m = *model_;
  KNEESIM_CHECK(F.cols() == int(m.bodies.size()) && tau.size() == getNumCoordinates(),
                "body force and generalised force sizes do not match the model");
  for (size_t b = 1; b < m.bodies.size(); ++b) {
    const SimTK::Vec3& p = d.matter.getMobilizedBody(d.mobod[b]).getBodyOriginLocation(w.state);
    w.p_GBody[b] = Eigen::Vector3d(p[0], p[1], p[2]);
    w.subtree[b].head<3>() = F.col(b).head<3>() + w.p_GBody[b].cross(Eigen::Vector3d(F.col(b).tail<3>()));
    w.subtree[b].tail<3>() = F.col(b).tail<3>();
  }
  for (auto j = m.joints.rbegin(); j != m.joints.rend(); ++j)  // children before parents
    if (j->parent_body > 0) w.subtree[j->parent_body] += w.subtree[j->child_body];
  for (size_t c = 0; c < m.coordinates.size(); ++c) {
    // The coordinate's own mobilizer (a ScapulothoracicJoint chains three above its body); the
    // subtree it moves is still that of the joint's child body.
    const int a = m.joints[m.coordinates[c].joint].child_body;
    const SimTK::MobilizedBody& mb = d.matter.getMobilizedBody(d.coord_mobod[c]);
    const SimTK::SpatialVec& H = mb.getHCol(w.state, SimTK::MobilizerUIndex(d.coord_mq[c]));
    const SimTK::Vec3& o = mb.getBodyOriginLocation(w.state);
    const Eigen::Vector3d f = w.subtree[a].tail<3>();
    const Eigen::Vector3d M = w.subtree[a].head<3>() - Eigen::Vector3d(o[0], o[1], o[2]).cross(f);
    tau[int(c)] = H[0][0] * M[0] + H[0][1] * M[1] + H[0][2] * M[2] + H[1][0] * f[0] + H[1][1] * f[1] + H[1][2] * f[2];
  }
}

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

void System::realizeVelocity(Workspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot) const {
  KNEESIM_ASSERT(q.size() == getNumCoordinates() && qdot.size() == getNumCoordinates());
  SimTK::State& s = ws.impl_->state;
  SimTK::Vector& Q = s.updQ();
  SimTK::Vector& U = s.updU();
  for (int i = 0; i < q.size(); ++i) {
    Q[impl_->q_index[i]] = q[i];
    U[impl_->u_index[i]] = qdot[i];
  }
  impl_->system.realize(s, SimTK::Stage::Velocity);
}

void System::calcResidualForces(Workspace& ws, const Eigen::VectorXd& qddot, const SpatialColumns& F_G,
                                Eigen::Ref<Eigen::VectorXd> tau) const {
  const model::Model& m = *model_;
  const Impl& d = *impl_;
  Workspace::Impl& w = *ws.impl_;
  KNEESIM_CHECK(qddot.size() == getNumCoordinates() && tau.size() == getNumCoordinates() &&
                    F_G.cols() == int(m.bodies.size()),
                "inverse dynamics sizes do not match the model");
  for (int i = 0; i < qddot.size(); ++i) w.udot[d.u_index[i]] = qddot[i];
  // Gravity as body forces (the Gravity force element acts only when Dynamics is realised,
  // which inverse dynamics does not need): m g at the mass centre, moment about the origin.
  const SimTK::Vec3 g = toSimTK(m.gravity);
  w.body_forces = SimTK::SpatialVec(SimTK::Vec3(0), SimTK::Vec3(0));
  for (size_t b = 1; b < m.bodies.size(); ++b) {
    const SimTK::MobilizedBody& mb = d.matter.getMobilizedBody(d.mobod[b]);
    const SimTK::Vec3 p_BCm_G = mb.getBodyRotation(w.state) * toSimTK(m.bodies[b].mass_center);
    const SimTK::Vec3 f = m.bodies[b].mass * g + SimTK::Vec3(F_G(3, b), F_G(4, b), F_G(5, b));
    const SimTK::Vec3 moment = SimTK::cross(p_BCm_G, m.bodies[b].mass * g) + SimTK::Vec3(F_G(0, b), F_G(1, b), F_G(2, b));
    w.body_forces[d.mobod[b]] += SimTK::SpatialVec(moment, f);
  }
  d.matter.calcResidualForceIgnoringConstraints(w.state, w.mobility_forces, w.body_forces, w.udot, w.residual);
  for (int i = 0; i < tau.size(); ++i) tau[i] = w.residual[d.u_index[i]];
}

void System::calcTreeKinematics(const Workspace& ws, TreeKinematics& kin) const {
  const model::Model& m = *model_;
  const Impl& d = *impl_;
  const SimTK::State& state = ws.impl_->state;
  const int nb = int(m.bodies.size()), nc = getNumCoordinates();
  if (int(kin.X_GB.size()) != nb) kin.X_GB.assign(nb, Eigen::Isometry3d::Identity());
  if (kin.V_GB.cols() != nb) kin.V_GB.resize(6, nb);
  if (kin.a_GB.cols() != nb) kin.a_GB.resize(6, nb);
  if (kin.H.cols() != nc) kin.H.resize(6, nc);
  for (int b = 0; b < nb; ++b) {
    const SimTK::MobilizedBody& mb = d.matter.getMobilizedBody(d.mobod[b]);
    kin.X_GB[b] = toEigen(mb.getBodyTransform(state));
    const SimTK::SpatialVec& V = mb.getBodyVelocity(state);
    kin.V_GB.col(b) << V[0][0], V[0][1], V[0][2], V[1][0], V[1][1], V[1][2];
    const SimTK::SpatialVec& a = d.matter.getTotalCoriolisAcceleration(state, d.mobod[b]);
    kin.a_GB.col(b) << a[0][0], a[0][1], a[0][2], a[1][0], a[1][1], a[1][2];
  }
  for (int c = 0; c < nc; ++c) kin.H.col(c) = getMobilityAxis(ws, c);
}

void calcBodyAccelerations(const model::Model& m, const TreeKinematics& kin, const Eigen::VectorXd& qddot,
                           SpatialColumns& A_G) {
  KNEESIM_CHECK(qddot.size() == int(m.coordinates.size()) && A_G.cols() == int(m.bodies.size()) &&
                    int(kin.X_GB.size()) == int(m.bodies.size()),
                "body acceleration sizes do not match the model");
  // J qddot recursively from the root (the parent's acceleration shifted to the child's origin
  // has no velocity term here: those are all in a_GB), then a_GB = Jdot qdot.
  A_G.col(0).setZero();
  for (const model::Joint& jt : m.joints) {
    const int b = jt.child_body, p = jt.parent_body;
    Eigen::Matrix<double, 6, 1> A = A_G.col(p);
    const Eigen::Vector3d r = kin.X_GB[b].translation() - kin.X_GB[p].translation();
    A.tail<3>() += Eigen::Vector3d(A_G.col(p).head<3>()).cross(r);
    for (int c : jt.coordinates) A += qddot[c] * kin.H.col(c);
    A_G.col(b) = A;
  }
  A_G.rightCols(A_G.cols() - 1) += kin.a_GB.rightCols(A_G.cols() - 1);
}

Eigen::Matrix<double, 6, 1> System::getMobilityAxis(const Workspace& ws, int coordinate) const {
  const model::Coordinate& co = model_->coordinates[coordinate];
  const SimTK::State& s = ws.impl_->state;
  // The coordinate's own mobilizer: in a ScapulothoracicJoint's chain it moves an intermediate
  // body, whose axis is shifted to the child body's origin (the rest of the chain is rigid).
  const SimTK::MobilizedBody& mb = impl_->matter.getMobilizedBody(impl_->coord_mobod[coordinate]);
  SimTK::SpatialVec H = mb.getHCol(s, SimTK::MobilizerUIndex(impl_->coord_mq[coordinate]));
  const SimTK::MobilizedBodyIndex child = impl_->mobod[model_->joints[co.joint].child_body];
  if (impl_->coord_mobod[coordinate] != child) {
    const SimTK::Vec3 r = impl_->matter.getMobilizedBody(child).getBodyOriginLocation(s) - mb.getBodyOriginLocation(s);
    H[1] += SimTK::cross(H[0], r);
  }
  Eigen::Matrix<double, 6, 1> out;
  out << H[0][0], H[0][1], H[0][2], H[1][0], H[1][1], H[1][2];
  return out;
}

Eigen::Matrix<double, 6, 1> System::getBodyVelocity(const Workspace& ws, int body) const {
  const SimTK::SpatialVec& V = impl_->matter.getMobilizedBody(impl_->mobod[body]).getBodyVelocity(ws.impl_->state);
  Eigen::Matrix<double, 6, 1> out;
  out << V[0][0], V[0][1], V[0][2], V[1][0], V[1][1], V[1][2];
  return out;
}

std::vector<int> System::getCoordinatesInTreeOrder() const {
  std::vector<int> order(model_->coordinates.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = int(i);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return impl_->u_index[a] < impl_->u_index[b]; });
  return order;
}

}  // namespace kneesim::sim
