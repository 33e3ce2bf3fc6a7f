#include "contact/seating.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <memory>

#include "contact/mesh_distance.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"

namespace kneesim::contact {

namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

// Position variables of the lowest-potential search (2 or 3), fixed-capacity so the search does
// not allocate.
using VecU = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 3, 1>;
using MatU = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 3, 3>;

constexpr double kInf = std::numeric_limits<double>::infinity();
// Lever that converts angles to lengths for step sizes and convergence tests.
constexpr double kLever = 0.02;
// Points within this distance of a condyle's smallest distance make up its contact patch.
constexpr double kContactBand = 1e-5;
// The first evaluation of a solve searches this far, so that points of a femur that starts deep
// in the insert still get correctly signed distances.
constexpr double kFarSearch = 0.05;

class ExactPointSetDistance final : public PointSetDistance {
 public:
  ExactPointSetDistance(std::shared_ptr<const MeshDistance> target, std::vector<Vector3d> points_Q)
      : target_(std::move(target)), points_(std::move(points_Q)) {}
  int getNumPoints() const override { return int(points_.size()); }
  void calcDistances(const Eigen::Isometry3d& X_TQ, double max_distance, std::vector<double>& distance) const override {
    distance.resize(points_.size());
    MeshDistanceQuery q;
    for (size_t i = 0; i < points_.size(); ++i)
      distance[i] = target_->calcSignedDistance(X_TQ * points_[i], max_distance, q) ? q.distance : kInf;
  }

 private:
  std::shared_ptr<const MeshDistance> target_;
  std::vector<Vector3d> points_;
};

}  // namespace

SeatingSetup makeSeatingSetup(io::TriangleMesh femur, io::TriangleMesh insert, const Cylinder& hinge_F,
                              const ComponentDirections& femur_directions,
                              const ComponentDirections& insert_directions) {
  SeatingSetup s;
  s.hinge_F = hinge_F;
  s.femur_directions = femur_directions;
  s.insert_directions = insert_directions;
  femur_directions.validate(femur.source_file);
  insert_directions.validate(insert.source_file);

  ArticularSelection sel;
  sel.directions = femur_directions;
  sel.min_facing_angle = -30 * kDegree;
  sel.max_facing_angle = 150 * kDegree;
  sel.max_normal_tilt = 60 * kDegree;
  sel.max_recess = 5e-3;
  sel.max_points = 0;
  sel.reference_point = hinge_F.point;
  sel.frame = SagittalFrame::fromHinge(hinge_F, femur_directions);
  sel.side = CondyleSide::medial;
  s.femur_medial_F = selectArticularPoints(femur, sel);
  sel.side = CondyleSide::lateral;
  s.femur_lateral_F = selectArticularPoints(femur, sel);

  const InsertArticularVertices articular = selectInsertArticularVertices(insert, insert_directions);
  const std::vector<Vector3d> normals = insert.calcVertexNormals();
  for (int v : articular.medial) s.insert_medial_I.push_back({insert.vertices[size_t(v)], normals[size_t(v)]});
  for (int v : articular.lateral) s.insert_lateral_I.push_back({insert.vertices[size_t(v)], normals[size_t(v)]});
  s.femur = std::move(femur);
  s.insert = std::move(insert);
  return s;
}

struct Seater::Impl {
  std::unique_ptr<PointSetDistance> femur_to_insert[2];  // medial, lateral
  std::unique_ptr<PointSetDistance> insert_to_femur[2];
  std::vector<Vector3d> femur_points[2], insert_points[2];
  std::vector<double> femur_buffer, insert_buffer;
  Eigen::Matrix3d B_I;   // columns: posterior, superior, medial of I (orthonormal)
  Eigen::Matrix3d R_IF0;
  Vector3d axis_F, p_FH;
  double insert_top = 0;
  Vector3d insert_centre = Vector3d::Zero();
  int evaluations = 0;
};

Seater::Seater(SeatingSetup setup, SeatingOptions options)
    : setup_(std::move(setup)), options_(std::move(options)), impl_(std::make_unique<Impl>()) {
  const std::string& fsrc = setup_.femur.source_file;
  setup_.femur_directions.validate(fsrc);
  setup_.insert_directions.validate(setup_.insert.source_file);
  if (!setup_.hinge_F.axis.allFinite() || setup_.hinge_F.axis.norm() == 0 || !setup_.hinge_F.point.allFinite())
    throw InputError({fsrc, 0, "seating"}, "expected a finite, non-zero hinge axis");
  if (setup_.femur_medial_F.empty() || setup_.femur_lateral_F.empty())
    throw InputError({fsrc, 0, "seating"}, "expected articular points on both femoral condyles, got none on one");
  if (options_.two_sided && (setup_.insert_medial_I.empty() || setup_.insert_lateral_I.empty()))
    throw InputError({setup_.insert.source_file, 0, "seating"},
                     "expected articular points on both sides of the insert for a two-sided check, got none on one");
  if (!(options_.tolerance > 0) || !(options_.fd_step > 0) || !(options_.position_tolerance > 0))
    throw InputError({fsrc, 0, "seating"}, "expected positive tolerance, position_tolerance and fd_step");

  Impl& m = *impl_;
  m.B_I = setup_.insert_directions.calcOrthonormalBasis();
  m.R_IF0 = setup_.femur_directions.calcRotationTo(setup_.insert_directions);
  m.axis_F = setup_.hinge_F.axis.normalized();
  if (m.axis_F.dot(setup_.femur_directions.calcFlexionAxis()) < 0) m.axis_F = -m.axis_F;
  m.p_FH = setup_.hinge_F.point;
  m.femur_points[0] = getPositions(setup_.femur_medial_F);
  m.femur_points[1] = getPositions(setup_.femur_lateral_F);
  m.insert_points[0] = getPositions(setup_.insert_medial_I);
  m.insert_points[1] = getPositions(setup_.insert_lateral_I);

  std::shared_ptr<const MeshDistance> insert_md, femur_md;
  auto make = [&](bool to_insert, const std::vector<Vector3d>& pts) -> std::unique_ptr<PointSetDistance> {
    const io::TriangleMesh& target = to_insert ? setup_.insert : setup_.femur;
    if (options_.distance_factory) return options_.distance_factory(target, pts);
    std::shared_ptr<const MeshDistance>& md = to_insert ? insert_md : femur_md;
    if (!md) md = std::make_shared<MeshDistance>(target);
    return std::make_unique<ExactPointSetDistance>(md, pts);
  };
  for (int s = 0; s < 2; ++s) {
    m.femur_to_insert[s] = make(true, m.femur_points[s]);
    if (options_.two_sided) m.insert_to_femur[s] = make(false, m.insert_points[s]);
  }
  m.femur_buffer.reserve(std::max(m.femur_points[0].size(), m.femur_points[1].size()));
  m.insert_buffer.reserve(std::max(m.insert_points[0].size(), m.insert_points[1].size()));

  const Vector3d up = m.B_I.col(1);
  m.insert_top = -kInf;
  for (const auto& v : setup_.insert.vertices) m.insert_top = std::max(m.insert_top, up.dot(v));
  const auto [lo, hi] = setup_.insert.calcBounds();
  m.insert_centre = 0.5 * (lo + hi);
}

Seater::~Seater() = default;

Eigen::Isometry3d Seater::calcPose(double flexion, const SeatingCoordinates& q) const {
  const Impl& m = *impl_;
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(q.internal, m.B_I.col(1)) * Eigen::AngleAxisd(q.varus, m.B_I.col(0)))
                                .toRotationMatrix() *
                            m.R_IF0 * Eigen::AngleAxisd(flexion, m.axis_F).toRotationMatrix();
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = R;
  X.translation() = q.p_IH - R * m.p_FH;
  return X;
}

void Seater::calcGaps(const Eigen::Isometry3d& X_IF, double max_distance, double gap[2], Vector3d* where_I) {
  Impl& m = *impl_;
  const Eigen::Isometry3d X_FI = X_IF.inverse();
  for (int s = 0; s < 2; ++s) {
    m.femur_to_insert[s]->calcDistances(X_IF, max_distance, m.femur_buffer);
    gap[s] = kInf;
    for (double d : m.femur_buffer) gap[s] = std::min(gap[s], d);
    if (m.insert_to_femur[s]) {
      m.insert_to_femur[s]->calcDistances(X_FI, max_distance, m.insert_buffer);
      for (double d : m.insert_buffer) gap[s] = std::min(gap[s], d);
    }
    if (!where_I) continue;
    // Conforming surfaces have many points within nanometres of the smallest distance, so the
    // single closest point is arbitrary: report the centre of those within the contact band.
    Vector3d sum = Vector3d::Zero();
    int count = 0;
    const double band = gap[s] + kContactBand;
    for (size_t i = 0; i < m.femur_buffer.size(); ++i)
      if (m.femur_buffer[i] <= band) {
        sum += X_IF * m.femur_points[s][i];
        ++count;
      }
    if (m.insert_to_femur[s])
      for (size_t i = 0; i < m.insert_buffer.size(); ++i)
        if (m.insert_buffer[i] <= band) {
          sum += m.insert_points[s][i];
          ++count;
        }
    where_I[s] = count > 0 ? Vector3d(sum / count) : Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  ++m.evaluations;
}

namespace {

// Solver state shared by the inner (h, phi) and outer (position) searches of one seating.
struct Solve {
  Solve(Seater& s, const SeatingOptions& o, double f, const Eigen::Matrix3d& B_I)
      : seater(s), opt(o), flexion(f), posterior(B_I.col(0)), superior(B_I.col(1)), medial(B_I.col(2)) {}

  Seater& seater;
  const SeatingOptions& opt;
  double flexion;
  Vector3d posterior, superior, medial;  // I's directions
  int inner_iterations = 0;
  // Jacobian of the gaps over (h, phi), reused across Newton iterations and solves while it
  // keeps halving the residual (it changes little between nearby poses).
  Eigen::Matrix2d J = Eigen::Matrix2d::Zero();
  bool have_J = false;
  // d(h, phi)/du at the last gradient, to predict the start of the next inner solve.
  Eigen::Matrix<double, 2, Eigen::Dynamic, 0, 2, 3> dy;

  Vector2d gaps(const SeatingCoordinates& q, double max_distance) {
    double g[2];
    seater.calcGaps(seater.calcPose(flexion, q), max_distance, g, nullptr);
    return Vector2d(g[0], g[1]);
  }

  Eigen::Matrix2d calcJacobian(const SeatingCoordinates& q, const Vector2d& r, double search) {
    const double eps_h = opt.fd_step, eps_phi = opt.fd_step / kLever;
    SeatingCoordinates q1 = q, q2 = q;
    q1.p_IH += eps_h * superior;
    q2.varus += eps_phi;
    Eigen::Matrix2d Jn;
    Jn.col(0) = (gaps(q1, search) - r) / eps_h;
    Jn.col(1) = (gaps(q2, search) - r) / eps_phi;
    return Jn;
  }

  // Newton's method on (h, phi) so that both condyles' gaps vanish. Updates q; false on failure.
  // @p search bounds the distances looked at first; it must exceed the deepest penetration
  // expected at q (gaps beyond it are searched again without the bound).
  bool solveInner(SeatingCoordinates& q, double search = kFarSearch) {
    Vector2d r = gaps(q, search);
    if (!(r.cwiseAbs().maxCoeff() < search)) r = gaps(q, kFarSearch);
    for (int it = 0;; ++it) {
      const double size = r.cwiseAbs().maxCoeff();
      if (size <= opt.tolerance) return true;
      if (it >= opt.max_inner_iterations || !std::isfinite(size)) return false;
      const double near = 2e-3 + 4 * size;
      bool fresh = false;
      if (!have_J) {
        J = calcJacobian(q, r, near);
        have_J = fresh = true;
      }
      Vector2d step;
      const double jmax = J.cwiseAbs().maxCoeff();
      if (J.allFinite() && std::abs(J.determinant()) > 1e-12 * jmax * jmax) {
        step = J.partialPivLu().solve(-r);
      } else {
        step = Vector2d(-r.minCoeff(), 0.0);  // no usable Jacobian: drop the femur straight down
      }
      // At most 5 mm and 5 degrees per step.
      step /= std::max({1.0, std::abs(step[0]) / 5e-3, std::abs(step[1]) / (5 * kDegree)});
      bool accepted = false;
      double alpha = 1;
      for (int ls = 0; ls < 12; ++ls, alpha /= 2) {
        SeatingCoordinates t = q;
        t.p_IH += alpha * step[0] * superior;
        t.varus += alpha * step[1];
        const Vector2d rt = gaps(t, 2e-3 + 4 * (size + alpha * (std::abs(step[0]) + kLever * std::abs(step[1]))));
        if (rt.cwiseAbs().maxCoeff() < size) {
          q = t;
          // A stale Jacobian that no longer halves the residual is refreshed.
          if (!fresh && (ls > 0 || rt.cwiseAbs().maxCoeff() > 0.5 * size)) have_J = false;
          r = rt;
          accepted = true;
          break;
        }
        if (!fresh) break;  // retry with a fresh Jacobian before shortening the step
      }
      ++inner_iterations;
      if (!accepted) {
        if (fresh) return false;
        have_J = false;
      }
    }
  }

  // Position variables of the lowest-potential search: (posterior, medial[, lever * internal]).
  VecU getVariables(const SeatingCoordinates& q, int m) const {
    VecU u(m);
    u[0] = posterior.dot(q.p_IH);
    u[1] = medial.dot(q.p_IH);
    if (m == 3) u[2] = kLever * q.internal;
    return u;
  }
  void setVariables(SeatingCoordinates& q, const VecU& u) const {
    q.p_IH += (u[0] - posterior.dot(q.p_IH)) * posterior + (u[1] - medial.dot(q.p_IH)) * medial;
    if (u.size() == 3) q.internal = u[2] / kLever;
  }

  // Gradient of the seated height h over the position variables (implicit function theorem:
  // dy/du = -J_y^-1 J_u for y = (h, phi) holding both gaps at zero). Refreshes J and dy.
  VecU calcGradient(const SeatingCoordinates& q, int m) {
    const double eps = opt.fd_step;
    const Vector2d r = gaps(q, 2e-3);
    J = calcJacobian(q, r, 2e-3);
    have_J = true;
    Eigen::Matrix<double, 2, Eigen::Dynamic, 0, 2, 3> Ju(2, m);
    for (int k = 0; k < m; ++k) {
      VecU u = getVariables(q, m);
      u[k] += eps;
      SeatingCoordinates t = q;
      setVariables(t, u);
      Ju.col(k) = (gaps(t, 2e-3) - r) / eps;
    }
    dy.setZero(2, m);
    if (!J.allFinite() || !Ju.allFinite() || J.determinant() == 0) {
      have_J = false;
      return VecU::Zero(m);
    }
    dy = -(J.inverse() * Ju);
    return dy.row(0).transpose();
  }

  // The lowest-potential search over the position variables from a seated q (both gaps closed):
  // quasi-Newton (BFGS on the seated height) with a backtracking line search, each trial position
  // re-seated by solveInner. Moves q and counts its accepted steps in outer_iterations; returns
  // whether the search settled (no descent left) rather than ran out of iterations.
  bool descend(SeatingCoordinates& q, int& outer_iterations) {
    bool settled = false;
    const int nv = opt.free_internal_rotation ? 3 : 2;
    MatU Binv = 0.01 * MatU::Identity(nv, nv);
    VecU u = getVariables(q, nv);
    double h = superior.dot(q.p_IH);
    VecU g = calcGradient(q, nv);
    double max_step = 4e-3;
    for (; outer_iterations < opt.max_outer_iterations;) {
      if (g.cwiseAbs().maxCoeff() == 0) {
        settled = true;  // flat: the height does not depend on the position
        break;
      }
      VecU p = -Binv * g;
      if (p.dot(g) >= 0) {
        Binv = 0.01 * MatU::Identity(nv, nv);
        p = -Binv * g;
      }
      // Trust region: at most 4 mm, and at most 4 times the last accepted step, so a curvature
      // estimate spoilt by a kink of the faceted surfaces cannot throw the femur across the dish.
      p /= std::max(1.0, p.cwiseAbs().maxCoeff() / max_step);
      // Predicted descent below the height resolution: the position is as low as it gets.
      if (-g.dot(p) < 1e-2 * opt.tolerance) {
        settled = true;
        break;
      }
      bool accepted = false, linear = false;
      double alpha = 1;
      SeatingCoordinates qt;
      for (int ls = 0; alpha * p.cwiseAbs().maxCoeff() >= opt.position_tolerance; ++ls, alpha /= 2) {
        qt = q;
        setVariables(qt, u + alpha * p);
        // First-order prediction of (h, phi) at the trial position.
        const Vector2d dy_t = alpha * (dy * p);
        qt.p_IH += dy_t[0] * superior;
        qt.varus += dy_t[1];
        if (!solveInner(qt, 3e-3 + 4 * alpha * p.cwiseAbs().maxCoeff())) continue;
        const double ht = superior.dot(qt.p_IH);
        if (ht < h + 1e-4 * alpha * g.dot(p)) {
          accepted = true;
          linear = alpha == 1 && h - ht >= -0.9 * g.dot(p);
          break;
        }
      }
      if (!accepted) {
        settled = true;  // no descent left within the gaps' resolution
        break;
      }
      ++outer_iterations;
      const VecU s = alpha * p;
      max_step = std::min(4e-3, 4 * s.cwiseAbs().maxCoeff());
      u += s;
      q = qt;
      h = superior.dot(q.p_IH);
      const VecU g_new = calcGradient(q, nv);
      const VecU y = g_new - g;
      const double sy = s.dot(y);
      if (alpha < 0.1) {
        Binv = 0.01 * MatU::Identity(nv, nv);  // the model was poor: restart from steepest descent
      } else if (sy > 1e-12 * s.norm() * y.norm()) {
        // BFGS update of the inverse Hessian.
        const MatU I = MatU::Identity(nv, nv);
        const double rho = 1 / sy;
        Binv = (I - rho * s * y.transpose()) * Binv * (I - rho * y * s.transpose()) + rho * s * s.transpose();
      }
      // The height fell as predicted by its slope alone (the dish bottoms are faceted, so the
      // height is piecewise nearly linear): take longer steps.
      if (linear) Binv *= 2;
      g = g_new;
      if (s.cwiseAbs().maxCoeff() < opt.position_tolerance) {
        settled = true;
        break;
      }
    }
    return settled;
  }
};

}  // namespace

SeatingResult Seater::calcSeating(double flexion, const SeatingCoordinates* start) {
  Impl& m = *impl_;
  m.evaluations = 0;
  SeatingResult res;
  res.flexion = flexion;
  Solve solve(*this, options_, flexion, m.B_I);

  SeatingCoordinates q;
  if (start) {
    q = *start;
  } else {
    q.p_IH = m.B_I.col(0).dot(m.insert_centre) * m.B_I.col(0) + m.B_I.col(2).dot(m.insert_centre) * m.B_I.col(2);
    // Lowest femoral articular point 1 mm above the insert's highest point.
    const Eigen::Isometry3d X = calcPose(flexion, q);
    double low = kInf;
    for (int s = 0; s < 2; ++s)
      for (const auto& p : m.femur_points[s]) low = std::min(low, solve.superior.dot(X * p));
    q.p_IH += (m.insert_top - low + 1e-3) * solve.superior;
  }

  const bool ok = solve.solveInner(q);
  const bool settled = ok && solve.descend(q, res.outer_iterations);

  res.q = q;
  res.X_IF = calcPose(flexion, q);
  double gap[2];
  Vector3d where[2];
  calcGaps(res.X_IF, 1e-2, gap, where);
  res.gap_medial = gap[0];
  res.gap_lateral = gap[1];
  res.contact_medial_I = where[0];
  res.contact_lateral_I = where[1];
  res.inner_iterations = solve.inner_iterations;
  res.distance_evaluations = m.evaluations;
  res.converged = ok && settled && std::max(std::abs(gap[0]), std::abs(gap[1])) <= options_.tolerance;
  return res;
}

std::vector<SeatingResult> Seater::calcHingeKinematics(const std::vector<double>& flexions) {
  std::vector<SeatingResult> out;
  out.reserve(flexions.size());
  for (double f : flexions) out.push_back(calcSeating(f, out.empty() ? nullptr : &out.back().q));
  return out;
}

void writeHingeKinematics(const std::string& path, const std::vector<SeatingResult>& results) {
  writeFileAtomically(path, [&](std::ostream& os) {
    os << "flexion_deg,p_IH_x_m,p_IH_y_m,p_IH_z_m,varus_deg,internal_deg,gap_medial_m,gap_lateral_m,"
          "contact_medial_x_m,contact_medial_y_m,contact_medial_z_m,contact_lateral_x_m,contact_lateral_y_m,"
          "contact_lateral_z_m,converged,inner_iterations,outer_iterations";
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j) os << ",X_IF_" << i << j;
    os << "\n" << std::setprecision(12);
    for (const auto& r : results) {
      os << r.flexion / kDegree << "," << r.q.p_IH.x() << "," << r.q.p_IH.y() << "," << r.q.p_IH.z() << ","
         << r.q.varus / kDegree << "," << r.q.internal / kDegree << "," << r.gap_medial << "," << r.gap_lateral;
      for (const Vector3d* c : {&r.contact_medial_I, &r.contact_lateral_I}) os << "," << c->x() << "," << c->y() << "," << c->z();
      os << "," << (r.converged ? 1 : 0) << "," << r.inner_iterations << "," << r.outer_iterations;
      const Eigen::Matrix<double, 3, 4> M = r.X_IF.matrix().topRows<3>();
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 4; ++j) os << "," << M(i, j);
      os << "\n";
    }
  });
}

}  // namespace kneesim::contact
