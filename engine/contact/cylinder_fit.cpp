#include "contact/cylinder_fit.hpp"

#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Dense>

#include "core/error.hpp"

namespace kneesim::contact {

namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

std::string formatNumber(double v) {
  std::ostringstream s;
  s.precision(4);
  s << v;
  return s.str();
}

[[noreturn]] void fail(const std::string& source, const std::string& what, const std::string& message) {
  throw InputError({source, 0, what}, message);
}

// Any unit vector perpendicular to unit a, and a third completing a right-handed basis.
void perpendicularBasis(const Vector3d& a, Vector3d& e1, Vector3d& e2) {
  Eigen::Index k;
  a.cwiseAbs().minCoeff(&k);
  e1 = a.cross(Vector3d::Unit(k)).normalized();
  e2 = a.cross(e1);
}

// Algebraic (Kasa) circle: least squares of x^2 + y^2 + D x + E y + F = 0. Points are centred and
// scaled first so the normal equations stay well conditioned. Returns false if degenerate.
bool fitCircleAlgebraic(const std::vector<Vector2d>& pts, Circle& out) {
  const int n = int(pts.size());
  Vector2d c = Vector2d::Zero();
  for (const auto& p : pts) c += p;
  c /= n;
  double s = 0;
  for (const auto& p : pts) s = std::max(s, (p - c).norm());
  if (!(s > 0)) return false;
  Eigen::MatrixXd A(n, 3);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    const Vector2d q = (pts[i] - c) / s;
    A.row(i) << q.x(), q.y(), 1.0;
    b[i] = -q.squaredNorm();
  }
  const Eigen::Vector3d x = A.colPivHouseholderQr().solve(b);
  const Vector2d center(-x[0] / 2, -x[1] / 2);
  const double r2 = center.squaredNorm() - x[2];
  if (!std::isfinite(r2) || r2 <= 0) return false;
  out.center = c + s * center;
  out.radius = s * std::sqrt(r2);
  return std::isfinite(out.radius);
}

FitErrors summarise(const Eigen::VectorXd& r) {
  FitErrors e;
  e.num_points = int(r.size());
  if (r.size() == 0) return e;
  e.mean_abs = r.cwiseAbs().mean();
  e.max_abs = r.cwiseAbs().maxCoeff();
  e.rms = std::sqrt(r.squaredNorm() / double(r.size()));
  return e;
}

// The damping loop of one Levenberg-Marquardt iteration on the normal equations A = J'J,
// g = J'r: raises lambda (x4) until tryStep(step) lowers the cost (it then keeps the step and
// returns true) and lowers lambda (/3) after that. False when no damping lowers the cost: the
// fit has converged to rounding.
template <int N, class TryStep>
bool takeDampedStep(const Eigen::Matrix<double, N, N>& A, const Eigen::Matrix<double, N, 1>& g, double& lambda,
                    Eigen::Matrix<double, N, 1>& step, TryStep&& tryStep) {
  const double diag_floor = 1e-15 * A.diagonal().maxCoeff();
  while (lambda < 1e20) {
    Eigen::Matrix<double, N, N> M = A;
    for (int k = 0; k < N; ++k) M(k, k) += lambda * (A(k, k) + diag_floor);
    step = M.ldlt().solve(-g);
    if (step.allFinite() && tryStep(step)) {
      lambda = std::max(lambda / 3, 1e-12);
      return true;
    }
    lambda *= 4;
  }
  return false;
}

struct CylinderState {
  Vector3d a, p;
  double R;
};

class CylinderLm {
 public:
  CylinderLm(const std::vector<Vector3d>& pts, const Vector3d& centroid)
      : pts_(pts), centroid_(centroid), r_(pts.size()), J_(pts.size(), 5) {}

  double calcCost(const CylinderState& s, Eigen::VectorXd& r) const {
    for (size_t i = 0; i < pts_.size(); ++i) {
      const Vector3d d = pts_[i] - s.p;
      r[Eigen::Index(i)] = (d - d.dot(s.a) * s.a).norm() - s.R;
    }
    return r.squaredNorm();
  }

  // Keeps the axis point at the centroid's axial position, so axis rotations pivot there and the
  // axial tilt and the axis position stay decoupled.
  void recentre(CylinderState& s) const { s.p += (centroid_ - s.p).dot(s.a) * s.a; }

  // Levenberg-Marquardt over (shift e1, shift e2, tilt e1, tilt e2, radius), re-linearised about
  // the current axis every iteration. Returns the iteration count.
  int run(CylinderState& s, int max_iterations, double length_scale) {
    recentre(s);
    double cost = calcCost(s, r_);
    double lambda = 1e-3;
    Eigen::VectorXd r_new(r_.size());
    int it = 0;
    for (; it < max_iterations; ++it) {
      Vector3d e1, e2;
      perpendicularBasis(s.a, e1, e2);
      for (size_t i = 0; i < pts_.size(); ++i) {
        const Vector3d d = pts_[i] - s.p;
        const double h = d.dot(s.a);
        const Vector3d w = d - h * s.a;
        const double rho = w.norm();
        const Vector3d n = rho > 0 ? Vector3d(w / rho) : Vector3d::Zero();
        const double n1 = n.dot(e1), n2 = n.dot(e2);
        J_.row(Eigen::Index(i)) << -n1, -n2, -h * n1, -h * n2, -1.0;
      }
      const Eigen::Matrix<double, 5, 5> A = J_.transpose() * J_;
      const Eigen::Matrix<double, 5, 1> g = J_.transpose() * r_;
      Eigen::Matrix<double, 5, 1> step;
      const bool accepted = takeDampedStep<5>(A, g, lambda, step, [&](const Eigen::Matrix<double, 5, 1>& d) {
        CylinderState t = s;
        t.p += d[0] * e1 + d[1] * e2;
        t.a = (s.a + d[2] * e1 + d[3] * e2).normalized();
        t.R += d[4];
        recentre(t);
        const double c = calcCost(t, r_new);
        if (!(c < cost)) return false;
        s = t;
        cost = c;
        r_.swap(r_new);
        return true;
      });
      if (!accepted) break;  // no direction lowers the cost: converged to rounding
      const double size = std::abs(step[0]) + std::abs(step[1]) + std::abs(step[4]) +
                          length_scale * (std::abs(step[2]) + std::abs(step[3]));
      if (size <= 1e-15 * length_scale) {
        ++it;
        break;
      }
    }
    return it;
  }

  const Eigen::VectorXd& getResiduals() const { return r_; }

 private:
  const std::vector<Vector3d>& pts_;
  Vector3d centroid_;
  Eigen::VectorXd r_;
  Eigen::MatrixXd J_;
};

CylinderFit fitCylinderImpl(const std::vector<Vector3d>& points, const std::vector<Vector3d>* normals,
                            const CylinderFitOptions& options) {
  const std::string& src = options.source;
  const char* what = "cylinder fit";
  const int n = int(points.size());
  if (n < 6) fail(src, what, "expected at least 6 points, got " + std::to_string(n));
  for (int i = 0; i < n; ++i)
    if (!points[i].allFinite())
      fail(src, what, "expected finite point coordinates, got a non-finite point (index " + std::to_string(i) + ")");
  if (normals && int(normals->size()) != n)
    fail(src, what, "expected one normal per point (" + std::to_string(n) + "), got " + std::to_string(normals->size()));

  Vector3d centroid = Vector3d::Zero();
  for (const auto& p : points) centroid += p;
  centroid /= n;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points) cov += (p - centroid) * (p - centroid).transpose();
  cov /= n;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> pca(cov);
  const Eigen::Vector3d ev = pca.eigenvalues();  // ascending
  double extent = 0;
  for (const auto& p : points) extent = std::max(extent, (p - centroid).norm());
  if (!(ev[2] > 0) || extent <= 1e-12 * std::max(1.0, centroid.norm())) fail(src, what, "expected points spanning a surface, got " + std::to_string(n) + " coincident points");
  if (ev[1] <= 1e-18 * ev[2])
    fail(src, what, "expected points spanning a curved surface, got " + std::to_string(n) + " collinear points");

  std::vector<Vector3d> starts;
  if (options.axis_guess) {
    if (!options.axis_guess->allFinite() || options.axis_guess->norm() == 0)
      fail(src, what, "expected a non-zero finite axis guess");
    starts.push_back(options.axis_guess->normalized());
  } else if (normals) {
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    for (const auto& nn : *normals) {
      const double len = nn.norm();
      if (len > 0 && std::isfinite(len)) m += nn * nn.transpose() / (len * len);
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(m);
    starts.push_back(es.eigenvectors().col(0));
  } else {
    for (int k = 2; k >= 0; --k) starts.push_back(pca.eigenvectors().col(k));
  }

  CylinderLm lm(points, centroid);
  bool have = false;
  CylinderFit best;
  double best_cost = std::numeric_limits<double>::infinity();
  std::vector<Vector2d> plane(n);
  for (const Vector3d& a0 : starts) {
    Vector3d e1, e2;
    perpendicularBasis(a0, e1, e2);
    for (int i = 0; i < n; ++i) plane[i] = Vector2d(e1.dot(points[i] - centroid), e2.dot(points[i] - centroid));
    Circle c0;
    if (!fitCircleAlgebraic(plane, c0) || c0.radius > options.max_radius_ratio * extent) continue;
    CylinderState s{a0, centroid + c0.center.x() * e1 + c0.center.y() * e2, c0.radius};
    const int iterations = lm.run(s, options.max_iterations, extent);
    if (!s.a.allFinite() || !s.p.allFinite() || !std::isfinite(s.R)) continue;
    const double cost = lm.getResiduals().squaredNorm();
    if (cost < best_cost) {
      best_cost = cost;
      best.cylinder = {s.a, s.p, s.R};
      best.errors = summarise(lm.getResiduals());
      best.iterations = iterations;
      have = true;
    }
  }
  // The curvature must be resolved by the data: over the points' width across the axis the
  // cylinder must bend away from its tangent plane by well over the residuals, or the points are
  // (nearly) planar and the radius only grows with more iterations.
  double sagitta = 0;
  if (have) {
    const Cylinder& c = best.cylinder;
    double width = 0;
    for (const auto& p : points) {
      const Vector3d d = p - centroid;
      width = std::max(width, (d - d.dot(c.axis) * c.axis).norm());
    }
    width = std::min(width, c.radius);
    sagitta = c.radius - std::sqrt(std::max(0.0, c.radius * c.radius - width * width));
  }
  if (!have || !(best.cylinder.radius > 0) || best.cylinder.radius > options.max_radius_ratio * extent ||
      !(sagitta > 10 * best.errors.rms))
    fail(src, what,
         "expected points on a curved surface, got " + std::to_string(n) +
             " nearly planar points (no cylinder with radius below " +
             formatNumber(options.max_radius_ratio * extent) + " m curves clearly more than they scatter)");

  Vector3d& a = best.cylinder.axis;
  if (options.axis_guess) {
    if (a.dot(*options.axis_guess) < 0) a = -a;
  } else {
    Eigen::Index k;
    a.cwiseAbs().maxCoeff(&k);
    if (a[k] < 0) a = -a;
  }
  return best;
}

}  // namespace

double Cylinder::calcSignedDistance(const Vector3d& p) const {
  const Vector3d d = p - point;
  return (d - d.dot(axis) * axis).norm() - radius;
}

FitErrors calcFitErrors(const Cylinder& cylinder, const std::vector<Vector3d>& points) {
  Eigen::VectorXd r(points.size());
  for (size_t i = 0; i < points.size(); ++i) r[Eigen::Index(i)] = cylinder.calcSignedDistance(points[i]);
  return summarise(r);
}

CylinderFit fitCylinder(const std::vector<Vector3d>& points, const CylinderFitOptions& options) {
  return fitCylinderImpl(points, nullptr, options);
}

CylinderFit fitCylinder(const std::vector<Vector3d>& points, const std::vector<Vector3d>& normals,
                        const CylinderFitOptions& options) {
  return fitCylinderImpl(points, &normals, options);
}

CircleFit fitCircle(const std::vector<Vector2d>& points, const std::string& source) {
  const char* what = "circle fit";
  const int n = int(points.size());
  if (n < 3) fail(source, what, "expected at least 3 points, got " + std::to_string(n));
  for (int i = 0; i < n; ++i)
    if (!points[i].allFinite())
      fail(source, what, "expected finite point coordinates, got a non-finite point (index " + std::to_string(i) + ")");
  Vector2d centroid = Vector2d::Zero();
  for (const auto& p : points) centroid += p;
  centroid /= n;
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  double extent = 0;
  for (const auto& p : points) {
    cov += (p - centroid) * (p - centroid).transpose();
    extent = std::max(extent, (p - centroid).norm());
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> pca(cov);
  if (!(pca.eigenvalues()[1] > 0) || pca.eigenvalues()[0] <= 1e-18 * pca.eigenvalues()[1])
    fail(source, what, "expected points on a curve, got " + std::to_string(n) + " collinear or coincident points");

  const double max_radius = 1e3 * extent;
  Circle c;
  if (!fitCircleAlgebraic(points, c) || c.radius > max_radius)
    fail(source, what, "expected points on a circle arc, got " + std::to_string(n) + " nearly collinear points");

  // Levenberg-Marquardt on (cx, cy, R).
  Eigen::VectorXd r(n), r_new(n);
  Eigen::MatrixXd J(n, 3);
  auto cost = [&](const Circle& k, Eigen::VectorXd& res) {
    for (int i = 0; i < n; ++i) res[i] = (points[i] - k.center).norm() - k.radius;
    return res.squaredNorm();
  };
  double f = cost(c, r);
  double lambda = 1e-3;
  int it = 0;
  for (; it < 200; ++it) {
    for (int i = 0; i < n; ++i) {
      const Vector2d d = points[i] - c.center;
      const double rho = d.norm();
      const Vector2d u = rho > 0 ? Vector2d(d / rho) : Vector2d::Zero();
      J.row(i) << -u.x(), -u.y(), -1.0;
    }
    const Eigen::Matrix3d A = J.transpose() * J;
    const Eigen::Vector3d g = J.transpose() * r;
    Eigen::Vector3d step;
    const bool accepted = takeDampedStep<3>(A, g, lambda, step, [&](const Eigen::Vector3d& d) {
      const Circle t{c.center + d.head<2>(), c.radius + d[2]};
      const double ft = cost(t, r_new);
      if (!(ft < f)) return false;
      c = t;
      f = ft;
      r.swap(r_new);
      return true;
    });
    if (!accepted) break;
    if (step.cwiseAbs().sum() <= 1e-15 * extent) {
      ++it;
      break;
    }
  }
  if (!(c.radius > 0) || c.radius > max_radius || !c.center.allFinite())
    fail(source, what, "expected points on a circle arc, got " + std::to_string(n) + " nearly collinear points");
  CircleFit out;
  out.circle = c;
  out.errors = summarise(r);
  out.iterations = it;
  return out;
}

}  // namespace kneesim::contact
