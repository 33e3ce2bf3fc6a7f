// Wrapping over an ellipsoid as OpenSim's WrapEllipsoid computes it: a wrapping plane through
// both end points and a surface point c1 (from Frans van der Helm's axis technique, a "fan" of
// closest surface points, or the midpoint, blended as the hybrid method blends them), tangent
// points found in that plane by damped Gauss-Newton iterations, and the path along the plane's
// section of the surface in 1 mm chords. Coordinates are scaled so the radii average 1.
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "muscle/wrap.hpp"
#include "muscle/wrap_math.hpp"

namespace kneesim::muscle {

using namespace wrapmath;
using model::WrapMethod;

namespace {

constexpr double kMuBlendMin = 0.7073;  // 100 % fan below (must exceed cos 45 degrees)
constexpr double kMuBlendMax = 0.9;     // 100 % Frans above
constexpr int kFanSamples = 300;
constexpr double kSvBoundaryBlend = 0.3;
constexpr double kTiny = 0.00000001;


/// Closest point (x, y) of the ellipse (x/a)^2 + (y/b)^2 = 1 to (u, v) (Eberly, Graphics Gems
/// IV, with OpenSim's handling of points near the axes).
void closestPointToEllipse(double a, double b, double u, double v, double& x, double& y) {
  const double a2 = a * a, b2 = b * b, a2u2 = a2 * u * u, b2v2 = b2 * v * v;
  const bool near_x = std::abs(u) <= kRoundoff, near_y = std::abs(v) <= kRoundoff;
  if (near_x && near_y) {
    if (a < b) {
      x = u < 0.0 ? -a : a;
      y = v;
    } else {
      x = u;
      y = v < 0.0 ? -b : b;
    }
    return;
  }
  if (near_x) {
    if (a >= b || std::abs(v) >= b - a2 / b) {
      x = u;
      y = v >= 0 ? b : -b;
    } else {
      y = b2 * v / (b2 - a2);
      const double ydb = y / b;
      x = a * std::sqrt(std::abs(1 - ydb * ydb));
    }
    return;
  }
  if (near_y) {
    if (b >= a || std::abs(u) >= a - b2 / a) {
      x = u >= 0 ? a : -a;
      y = v;
    } else {
      x = a2 * u / (a2 - b2);
      const double xda = x / a;
      y = b * std::sqrt(std::abs(1 - xda * xda));
    }
    return;
  }
  double t = (u / a) * (u / a) + (v / b) * (v / b) < 1.0 ? 0.0 : std::max(a, b) * std::sqrt(u * u + v * v);
  double P = 0, Q = 0;
  for (int i = 0; i < 64; ++i) {
    P = t + a2;
    Q = t + b2;
    const double f = P * P * Q * Q - a2u2 * Q * Q - b2v2 * P * P;
    if (std::abs(f) < 1e-09) break;
    const double fp = 2.0 * (P * Q * (P + Q) - a2u2 * Q - b2v2 * P);
    t -= f / fp;
  }
  x = a2 * u / P;
  y = b2 * v / Q;
}

/// OpenSim's WrapEllipsoid::findClosestPoint: the point of the ellipsoid with semi-axes @p a
/// closest to @p p. Near a coordinate plane (or when @p special_axis >= 0) the problem is solved
/// in that plane's ellipse; @p unscaled picks the plane as OpenSim does, by the unscaled radii.
Vec3 findClosestPoint(const Vec3& a, const Vec3& p, const Vec3& unscaled, int special_axis = -1) {
  if (special_axis < 0) {
    double min_sum = std::numeric_limits<double>::infinity();
    for (int i = 0; i < 3; ++i) {
      if (std::abs(p[i]) > kRoundoff) continue;
      const double sum = unscaled.sum() - unscaled[i];
      if (min_sum > sum) {
        special_axis = i;
        min_sum = sum;
      }
    }
  }
  Vec3 c = p;
  if (special_axis == 0) {
    closestPointToEllipse(a[1], a[2], p[1], p[2], c[1], c[2]);
    return c;
  }
  if (special_axis == 1) {
    closestPointToEllipse(a[2], a[0], p[2], p[0], c[2], c[0]);
    return c;
  }
  if (special_axis == 2) {
    closestPointToEllipse(a[0], a[1], p[0], p[1], c[0], c[1]);
    return c;
  }
  const double a2 = a[0] * a[0], b2 = a[1] * a[1], c2 = a[2] * a[2];
  const double a2u2 = a2 * p[0] * p[0], b2v2 = b2 * p[1] * p[1], c2w2 = c2 * p[2] * p[2];
  double t = (p.array() / a.array()).square().sum() < 1.0 ? 0.0 : a.maxCoeff() * p.norm();
  for (int i = 0; i < 64; ++i) {
    const double P = t + a2, Q = t + b2, R = t + c2;
    const double P2 = P * P, Q2 = Q * Q, R2 = R * R;
    const double f = P2 * Q2 * R2 - a2u2 * Q2 * R2 - b2v2 * P2 * R2 - c2w2 * P2 * Q2;
    if (std::abs(f) < 1e-09) return Vec3(a2 * p[0] / P, b2 * p[1] / Q, c2 * p[2] / R);
    const double PQ = P * Q, PR = P * R, QR = Q * R, PQR = P * Q * R;
    const double fp = 2.0 * (PQR * (QR + PR + PQ) - a2u2 * QR * (Q + R) - b2v2 * PR * (P + R) - c2w2 * PQ * (P + Q));
    t -= f / fp;
  }
  // OpenSim returns without setting the point when Newton's method does not converge.
  return Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
}

/// The four residuals of the tangency conditions at r (OpenSim's ee[]).
Eigen::Vector4d tangencyResiduals(const Vec3& r, double d1, const Vec3& p1, const Vec3& a, const Vec3& vs,
                                  double vs4) {
  const Vec3 nr = 2.0 * r.cwiseQuotient(a.cwiseProduct(a));
  Eigen::Vector4d ee;
  ee[0] = vs.dot(r) + vs4;
  ee[1] = r.cwiseQuotient(a).squaredNorm() - 1.0;
  ee[2] = nr.dot(r) + d1;
  ee[3] = nr.dot(p1) + d1;
  return ee;
}

/// OpenSim's calcTangentPoint: moves @p r1 (on the surface, in the plane vs.x + vs4 = 0) until
/// the line from @p p1 touches the ellipsoid there (Levenberg-Marquardt on four residuals).
void calcTangentPoint(double p1e, Vec3& r1, const Vec3& p1, const Vec3& a, const Vec3& vs, double vs4) {
  if (std::abs(p1e) < 0.0001) {
    r1 = p1;
    return;
  }
  const Vec3 a2 = a.cwiseProduct(a);
  double d1 = -(2.0 * r1.cwiseQuotient(a2)).dot(r1);
  Eigen::Vector4d ee = tangencyResiduals(r1, d1, p1, a, vs, vs4);
  double ssqo = ee.squaredNorm(), ssq = ssqo, alpha = 0.01;
  for (int nit = 0; ssq > kTiny && nit < 50; ++nit) {
    Eigen::Matrix4d dedth;
    for (int i = 0; i < 3; ++i) {
      dedth(i, 0) = vs[i];
      dedth(i, 1) = 2.0 * r1[i] / a2[i];
      dedth(i, 2) = 2.0 * (2.0 * r1[i]) / a2[i];
      dedth(i, 3) = 2.0 * p1[i] / a2[i];
    }
    dedth.row(3) << 0.0, 0.0, 1.0, 1.0;
    const double pcos = normalized(r1 - p1).dot(normalized(-p1));
    const double dd = pcos > 0.1 ? 1.0 - std::pow(pcos, 100) : 1.0;
    const Eigen::Vector4d v = -dedth * ee;
    Eigen::Matrix4d dedth2 = dedth * dedth.transpose();
    const Eigen::Vector4d diag = dedth2.diagonal();
    Eigen::Vector4d vt = Eigen::Vector4d::Zero();
    auto advance = [&](double f) {
      r1 += f * vt.head<3>();
      d1 += f * vt[3];
      ee = tangencyResiduals(r1, d1, p1, a, vs, vs4);
    };
    // Raise the damping until a step lowers the residual...
    for (int nit2 = 0; ssq >= ssqo && nit2 < 1000; ++nit2) {
      dedth2.diagonal() = diag * (1.0 + alpha);
      vt = dd * (dedth2.inverse() * v) / 16.0;
      advance(1.0);
      ssqo = ssq;
      ssq = ee.squaredNorm();
      alpha *= 4.0;
    }
    alpha /= 8.0;
    // ...then double the step while it keeps lowering it, and take back the last doubling.
    double fakt = 0.5;
    for (int nit2 = 0; ssq <= ssqo && nit2 < 1000; ++nit2) {
      fakt *= 2.0;
      advance(fakt);
      ssqo = ssq;
      ssq = ee.squaredNorm();
    }
    advance(-fakt);
    ssq = ee.squaredNorm();
    ssqo = ssq;
  }
}

/// The path from r1 to r2 along the section of the ellipsoid by the wrapping plane (OpenSim's
/// CalcDistanceOnEllipsoid): its length, and the first and last interior points when it has
/// some. All in scaled coordinates; @p factor turns lengths back to metres for the chord count.
struct SurfacePath {
  double length = 0.0;
  int interior = 0;
  Vec3 first_interior, last_interior;
};

SurfacePath calcDistanceOnEllipsoid(const Vec3& r1, const Vec3& r2, const Vec3& a, const Vec3& vs, double vs4,
                                    bool far_side_wrap, double factor) {
  constexpr double kSegmentLength = 0.001;  // metres
  SurfacePath out;
  const double len = (r1 - r2).norm() / factor;
  if (len < kSegmentLength) {
    out.length = len * factor;
    return out;
  }
  int segments = int(len / kSegmentLength);
  if (segments > 499) segments = 499;
  out.interior = segments - 1;
  int imax = 0;
  for (int i = 1; i < 3; ++i)
    if (std::abs(vs[i]) > std::abs(vs[imax])) imax = i;
  const Vec3 u = Vec3::Unit(imax);
  const double mu = -vs4 / vs.dot(u);  // the centre is the origin
  const Vec3 a0 = mu * u;
  const Vec3 ar1 = normalized(r1 - a0), ar2 = normalized(r2 - a0);
  const double phi0 = std::acos(ar1.dot(ar2));
  const double dphi = far_side_wrap ? -(2 * M_PI - phi0) / segments : phi0 / segments;
  const Vec3 vsz = normalized(ar1.cross(ar2));
  const Vec3 vsy = vsz.cross(ar1);
  const Vec3 f2 = a0.cwiseQuotient(a);
  Vec3 prev = r1;
  for (int i = 0; i < out.interior; ++i) {
    const double phi = (i + 1) * dphi;
    const Vec3 r = std::cos(phi) * ar1 + std::sin(phi) * vsy;
    const Vec3 f1 = r.cwiseQuotient(a);
    const double aa = f1.dot(f1), bb = 2.0 * f1.dot(f2), cc = f2.dot(f2) - 1.0;
    const double mu3 = (-bb + std::sqrt(bb * bb - 4.0 * aa * cc)) / (2.0 * aa);
    const Vec3 s = a0 + mu3 * r;
    if (i == 0) out.first_interior = s;
    out.last_interior = s;
    out.length += (s - prev).norm();
    prev = s;
  }
  out.length += (r2 - prev).norm();
  return out;
}

/// The surface point c1 the wrapping plane passes through (with p1 and p2), as OpenSim's
/// WrapEllipsoid finds it from the chord r1-r2 of the line p1-p2 inside the ellipsoid: Frans van
/// der Helm's axis technique, the "fan" of closest points, or the midpoint, blended by @p method.
struct PlanePoint {
  Vec3 c1;
  bool fan_used = false;
  double fan_weight = 0.0;
  double t_best = NAN;  ///< Where the axis technique's line point lies on r1-r2 (0..1 inside).
};

PlanePoint findPlanePoint(const Vec3& r1, const Vec3& r1r2, const Vec3& p1p2, const Vec3& a, const Vec3& radii,
                          WrapMethod method) {
  Vec3 mu = normalized(p1p2).cwiseAbs();
  Vec3 t;
  Vec3 t_sv[3], t_c1[3];
  for (int i = 0; i < 3; ++i) {
    t[i] = -r1[i] / r1r2[i];
    t_sv[i] = r1 + t[i] * r1r2;
    t_c1[i] = findClosestPoint(a, t_sv[i], radii, i);
  }
  int best = 0;
  for (int i = 1; i < 3; ++i)
    if (mu[i] > mu[best]) best = i;
  PlanePoint out;
  out.t_best = t[best];
  Vec3 c1 = Vec3::Constant(NAN), sv = Vec3::Constant(NAN);
  if (method == WrapMethod::Hybrid || method == WrapMethod::Axial) {
    if (method == WrapMethod::Hybrid && mu[best] > kMuBlendMin) {
      // Fade the axis technique out when its sv falls near or beyond the ends of r1-r2.
      double s = 1.0;
      if (t[best] < 0.0 || t[best] > 1.0)
        s = 0.0;
      else if (t[best] < kSvBoundaryBlend)
        s = t[best] / kSvBoundaryBlend;
      else if (t[best] > 1.0 - kSvBoundaryBlend)
        s = (1.0 - t[best]) / kSvBoundaryBlend;
      if (s < 1.0) mu[best] = kMuBlendMin + s * (mu[best] - kMuBlendMin);
    }
    if (method == WrapMethod::Axial || mu[best] > kMuBlendMin) {
      c1 = t_c1[best];
      sv = t_sv[best];
    }
    if (method == WrapMethod::Hybrid && mu[best] < kMuBlendMax) {
      // The fan: average direction from points of r1-r2 to their closest surface points.
      Vec3 v_sum = Vec3::Zero();
      const Vec3 mid = r1 + 0.5 * r1r2;
      for (int i = 1; i < kFanSamples - 1; ++i) {
        const Vec3 sample = r1 + (double(i) / kFanSamples) * r1r2;
        v_sum += normalized(findClosestPoint(a, sample, radii) - sample);
      }
      const Vec3 c_fan = mid + normalized(v_sum);
      out.fan_used = true;
      if (mu[best] <= kMuBlendMin) {
        c1 = findClosestPoint(a, c_fan, radii);
        sv = mid;
        out.fan_weight = 1.0;
      } else {
        const double tt = (mu[best] - kMuBlendMin) / (kMuBlendMax - kMuBlendMin);
        const Vec3 c_fan_surface = findClosestPoint(a, c_fan, radii);
        const Vec3 blend = tt * c1 + (1.0 - tt) * c_fan_surface;
        sv = tt * sv + (1.0 - tt) * mid;
        c1 = findClosestPoint(a, blend, radii);
        out.fan_weight = 1.0 - tt;
      }
    }
  } else {  // midpoint
    sv = r1 + 0.5 * r1r2;
    c1 = findClosestPoint(a, sv, radii);
  }
  out.c1 = c1;
  (void)sv;  // the line point c1 was found from: OpenSim computes it and does not use it
  return out;
}

/// A quadrant restriction flips c1 onto the active half (and the tangent points' start with it).
/// OpenSim's test for an unset fan weight never succeeds (its -infinity minus -infinity is NaN),
/// so only a fan result is blended back.
void flipIntoQuadrant(int axis, int sign, const PlanePoint& pp, const Vec3& a, const Vec3& radii, Vec3& c1, Vec3& r1,
                      Vec3& r2) {
  if (sign == 0 || dsign(c1[axis]) == sign) return;
  const Vec3 orig_c1 = c1;
  c1[axis] = -c1[axis];
  r1 = r2 = c1;
  const double w = pp.fan_used ? std::min(pp.fan_weight, 1.0) : 0.0;
  if (w > 0.0) {
    const double bisection = (orig_c1[axis] + c1[axis]) / 2.0;
    c1[axis] = c1[axis] + w * (bisection - c1[axis]);
    c1 = findClosestPoint(a, c1, radii);
  }
}

}  // namespace

WrapStatus wrapEllipsoid(const Vec3& radii, WrapMethod method, int axis, int sign, const Vec3& point1,
                         const Vec3& point2, WrapResult& result) {
  // Scale so that the radii average 1 (the factor depends on the radii only).
  const double factor = 3.0 / radii.sum();
  const Vec3 p1 = point1 * factor, p2 = point2 * factor, a = radii * factor;
  const double p1e = p1.cwiseQuotient(a).squaredNorm() - 1.0;
  const double p2e = p2.cwiseQuotient(a).squaredNorm() - 1.0;
  if (p1e < -0.0001 || p2e < -0.0001) return WrapStatus::InsideRadius;

  const Vec3 p1p2 = p1 - p2;
  const double ppm = normalized(p1).dot(normalized(p2)) - 1.0;  // angle between the end points seen from the centre
  if (std::abs(ppm) < 0.0001) return WrapStatus::NoWrap;

  // Does the line p1-p2 cross the ellipsoid between the two points?
  const Vec3 f1 = p1p2.cwiseQuotient(a), f2 = p2.cwiseQuotient(a);
  const double aa = f1.dot(f1), bb = 2.0 * f1.dot(f2), cc = f2.dot(f2) - 1.0;
  const double disc = bb * bb - 4.0 * aa * cc;
  if (disc < 0.0) return WrapStatus::NoWrap;
  const double l1 = (-bb + std::sqrt(disc)) / (2.0 * aa), l2 = (-bb - std::sqrt(disc)) / (2.0 * aa);
  if (!(0.0 < l1 && l1 < 1.0) || !(0.0 < l2 && l2 < 1.0)) return WrapStatus::NoWrap;
  Vec3 r1 = p2 + l1 * p1p2, r2 = p2 + l2 * p1p2;

  const PlanePoint pp = findPlanePoint(r1, r2 - r1, p1p2, a, radii, method);
  Vec3 c1 = pp.c1;

  // Start both tangent points at c1 so they stay on c1's side of the ellipsoid.
  const bool use_c1 = method != WrapMethod::Axial || (pp.t_best > 0.0 && pp.t_best < 1.0);
  if (use_c1) r1 = r2 = c1;

  flipIntoQuadrant(axis, sign, pp, a, radii, c1, r1, r2);

  // The wrapping plane through p1, p2 and c1, then the tangent points in it.
  const Vec3 vs = normalized(p1p2.cross(p1 - c1));
  const double vs4 = -vs.dot(c1);
  calcTangentPoint(p1e, r1, p1, a, vs, vs4);
  calcTangentPoint(p2e, r2, p2, a, vs, vs4);

  bool far_side_wrap = false;
  SurfacePath path = calcDistanceOnEllipsoid(r1, r2, a, vs, vs4, far_side_wrap, factor);
  if (sign != 0 && path.interior > 0) {
    // A wrong-way wrap: the first or last chord turns back towards its end point.
    const Vec3 r1p1 = normalized(p1 - r1), r1w1 = normalized(path.first_interior - r1);
    const Vec3 r2p2 = normalized(p2 - r2), r2w2 = normalized(path.last_interior - r2);
    if (r1p1.dot(r1w1) > 0.0 || r2p2.dot(r2w2) > 0.0) {
      far_side_wrap = true;
      path = calcDistanceOnEllipsoid(r1, r2, a, vs, vs4, far_side_wrap, factor);
    }
  }
  result.length = path.length / factor;
  result.r1 = r1 / factor;
  result.r2 = r2 / factor;
  return WrapStatus::Mandatory;
}

}  // namespace kneesim::muscle
