#pragma once
// Plain Eigen forward kinematics of a model::Model for the model tests, written from the
// joint definitions (OpenSim/Simbody semantics) without Simbody. It checks the readers' frames
// and axes against hand-derived positions, and URDF round trips against the original model.

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "model/model.hpp"

namespace kneesim::test {

using model::Pose;
using model::Vec3;

inline Pose rot(const Vec3& axis, double angle) {
  Pose X = Pose::Identity();
  X.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  return X;
}

/// Simbody's Ellipsoid mobilizer with semi-axes @p r: M turned by the body-fixed X-Y-Z angles
/// q0..q2 in F; M's origin on the ellipsoid at (r_x n_x, r_y n_y, r_z n_z), n = M's z axis in F.
inline Pose ellipsoidMotion(const Vec3& r, double q0, double q1, double q2) {
  Pose X = Pose::Identity();
  X.linear() = (Eigen::AngleAxisd(q0, Vec3::UnitX()) * Eigen::AngleAxisd(q1, Vec3::UnitY()) *
                Eigen::AngleAxisd(q2, Vec3::UnitZ()))
                   .toRotationMatrix();
  X.translation() = r.cwiseProduct(X.linear().col(2));
  return X;
}

inline Pose shift(const Vec3& p) {
  Pose X = Pose::Identity();
  X.translation() = p;
  return X;
}

/// X_FM of joint @p jt for the full coordinate vector @p q (one entry per model coordinate).
inline Pose jointMotion(const model::Model& m, const model::Joint& jt, const std::vector<double>& q) {
  using model::JointType;
  auto c = [&](int k) { return q[jt.coordinates[k]]; };
  Pose X = Pose::Identity();
  switch (jt.type) {
    case JointType::Weld: break;
    case JointType::Pin: X = rot(Vec3::UnitZ(), c(0)); break;
    case JointType::Slider: X = shift(Vec3(c(0), 0, 0)); break;
    case JointType::Ball:
    case JointType::Gimbal:
      X = rot(Vec3::UnitX(), c(0)) * rot(Vec3::UnitY(), c(1)) * rot(Vec3::UnitZ(), c(2));
      break;
    case JointType::Universal: X = rot(Vec3::UnitX(), c(0)) * rot(Vec3::UnitY(), c(1)); break;
    case JointType::Free:
      X = shift(Vec3(c(3), c(4), c(5))) * rot(Vec3::UnitX(), c(0)) * rot(Vec3::UnitY(), c(1)) *
          rot(Vec3::UnitZ(), c(2));
      break;
    case JointType::Ellipsoid: X = ellipsoidMotion(jt.radii, c(0), c(1), c(2)); break;
    case JointType::Scapulothoracic: {
      // OpenSim's ScapulothoracicJoint (ScapulothoracicJoint.cpp): the ellipsoid's frame is F
      // turned pi/2 about z with the radii swapped to match; its M frame is the intermediate
      // body turned pi/2 about z; then winging about W's z, W at (x0, y0, 0) with its z axis
      // along (-sin a, cos a, 0); the scapula's joint frame is the winging body's frame.
      const Pose Rz = rot(Vec3::UnitZ(), M_PI / 2);
      const double a = jt.winging_direction;
      Pose W = Pose::Identity();
      const Vec3 zw(-std::sin(a), std::cos(a), 0);
      const Vec3 xw = zw.cross(Vec3::UnitZ()).normalized();
      W.linear().col(0) = xw;
      W.linear().col(1) = zw.cross(xw);
      W.linear().col(2) = zw;
      W.translation() = Vec3(jt.winging_origin.x(), jt.winging_origin.y(), 0);
      X = Rz * ellipsoidMotion(Vec3(jt.radii.y(), jt.radii.x(), jt.radii.z()), c(0), c(1), c(2)) * Rz.inverse() * W *
          rot(Vec3::UnitZ(), c(3)) * W.inverse();
      break;
    }
    case JointType::Custom: {
      Vec3 p = Vec3::Zero();
      Pose R = Pose::Identity();
      for (int a = 0; a < 6; ++a) {
        const model::TransformAxis& ax = jt.spatial[a];
        double args[6] = {0, 0, 0, 0, 0, 0};
        for (size_t k = 0; k < ax.coordinates.size(); ++k) args[k] = q[ax.coordinates[k]];
        const double v = ax.function->calcValue(args);
        if (a < 3)
          R = R * rot(ax.axis, v);
        else
          p += v * ax.axis.normalized();
      }
      X = shift(p) * R;
      break;
    }
  }
  if ((jt.reverse && m.format_version > 0 && m.format_version < 40000) || jt.reversed_in_tree) X = X.inverse();
  return X;
}

/// Ground poses of every body.
inline std::vector<Pose> bodyPoses(const model::Model& m, const std::vector<double>& q) {
  std::vector<Pose> X_G(m.bodies.size(), Pose::Identity());
  for (const model::Joint& jt : m.joints)  // finalize() put parents first
    X_G[jt.child_body] = X_G[jt.parent_body] * jt.X_PF * jointMotion(m, jt, q) * jt.X_BM.inverse();
  return X_G;
}

/// Ground position of the named marker.
inline Vec3 markerInGround(const model::Model& m, const std::vector<double>& q, const std::string& name) {
  const int k = m.findMarker(name);
  if (k < 0) throw std::runtime_error("no marker " + name);
  const model::Marker& mk = m.markers[k];
  return bodyPoses(m, q)[mk.body] * mk.p_BM;
}

/// A coordinate vector from name/value pairs (unnamed coordinates are zero).
inline std::vector<double> coordinateValues(const model::Model& m,
                                            const std::vector<std::pair<std::string, double>>& values) {
  std::vector<double> q(m.coordinates.size(), 0.0);
  for (const auto& nv : values) {
    const int k = m.findCoordinate(nv.first);
    if (k < 0) throw std::runtime_error("no coordinate " + nv.first);
    q[k] = nv.second;
  }
  return q;
}

}  // namespace kneesim::test
