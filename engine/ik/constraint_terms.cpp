// Position equations of a model's body constraints for inverse kinematics (see the header).
#include "ik/constraint_terms.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace kneesim::ik {

using model::ConstraintType;
using Vec3 = Eigen::Vector3d;

ConstraintTerms::ConstraintTerms(const model::Model& model) {
  for (const model::Constraint& k : model.constraints) {
    Kind kind{k.type, int(bodies_.size()), n_equations_, k.distance};
    auto station = [&](int body, const Vec3& p) {
      bodies_.push_back(body);
      stations_.push_back(p);
    };
    const Vec3 o1 = k.X_B1F1.translation(), o2 = k.X_B2F2.translation();
    const Eigen::Matrix3d R1 = k.X_B1F1.linear(), R2 = k.X_B2F2.linear();
    switch (k.type) {
      case ConstraintType::Point:
      case ConstraintType::ConstantDistance:
        station(k.body1, o1);
        station(k.body2, o2);
        n_equations_ += k.type == ConstraintType::Point ? 3 : 1;
        break;
      case ConstraintType::PointOnLine:
        // a, a + n1, a + n2 on the line body (n1, n2 across the line: F1's y and z); the follower.
        station(k.body1, o1);
        station(k.body1, o1 + R1.col(1));
        station(k.body1, o1 + R1.col(2));
        station(k.body2, o2);
        n_equations_ += 2;
        break;
      case ConstraintType::Weld:
        // Origin and axis tips of F1, then of F2.
        station(k.body1, o1);
        for (int a = 0; a < 3; ++a) station(k.body1, o1 + R1.col(a));
        station(k.body2, o2);
        for (int a = 0; a < 3; ++a) station(k.body2, o2 + R2.col(a));
        n_equations_ += 6;
        break;
    }
    kinds_.push_back(kind);
  }
}

void ConstraintTerms::calcErrors(const std::vector<Vec3>& p, Eigen::Ref<Eigen::VectorXd> c) const {
  KNEESIM_CHECK(int(p.size()) == getNumStations() && c.size() == n_equations_, "constraint error sizes");
  for (const Kind& k : kinds_) {
    const Vec3* s = p.data() + k.first_station;
    const int r = k.first_row;
    switch (k.type) {
      case ConstraintType::Point:
        c.segment<3>(r) = s[1] - s[0];
        break;
      case ConstraintType::ConstantDistance:
        c[r] = (s[1] - s[0]).norm() - k.length;
        break;
      case ConstraintType::PointOnLine: {
        const Vec3 e = s[3] - s[0];
        c[r] = e.dot(s[1] - s[0]);
        c[r + 1] = e.dot(s[2] - s[0]);
        break;
      }
      case ConstraintType::Weld: {
        const Vec3 x1 = s[1] - s[0], y1 = s[2] - s[0], z1 = s[3] - s[0];
        const Vec3 x2 = s[5] - s[4], y2 = s[6] - s[4], z2 = s[7] - s[4];
        c[r] = x2.dot(y1);
        c[r + 1] = y2.dot(z1);
        c[r + 2] = z2.dot(x1);
        c.segment<3>(r + 3) = s[4] - s[0];
        break;
      }
    }
  }
}

void ConstraintTerms::calcJacobian(const std::vector<Vec3>& p, const Eigen::Ref<const Eigen::MatrixXd>& Js,
                                   Eigen::Ref<Eigen::MatrixXd> C) const {
  KNEESIM_CHECK(Js.rows() == 3 * getNumStations() && C.rows() == n_equations_ && C.cols() == Js.cols(),
                "constraint Jacobian sizes");
  // d(a . b) = a^T db + b^T da, with d(s_i - s_j) = J_i - J_j.
  auto J = [&](int station) { return Js.middleRows<3>(3 * station); };
  for (const Kind& k : kinds_) {
    const int i = k.first_station;
    const Vec3* s = p.data() + i;
    const int r = k.first_row;
    switch (k.type) {
      case ConstraintType::Point:
        C.middleRows<3>(r) = J(i + 1) - J(i);
        break;
      case ConstraintType::ConstantDistance:
        // Simbody's Rod cannot hold coincident points (the length is positive), so d != 0 near it.
        C.row(r).noalias() = (s[1] - s[0]).normalized().transpose() * (J(i + 1) - J(i));
        break;
      case ConstraintType::PointOnLine: {
        const Vec3 e = s[3] - s[0];
        for (int n = 0; n < 2; ++n) {
          const Vec3 d = s[1 + n] - s[0];
          C.row(r + n).noalias() = d.transpose() * (J(i + 3) - J(i));
          C.row(r + n).noalias() += e.transpose() * (J(i + 1 + n) - J(i));
        }
        break;
      }
      case ConstraintType::Weld: {
        // Rows: x2 . y1, y2 . z1, z2 . x1 (axis a2 of F2 against axis a1 of F1).
        const int pairs[3][2] = {{0, 1}, {1, 2}, {2, 0}};
        for (int n = 0; n < 3; ++n) {
          const int a2 = pairs[n][0], a1 = pairs[n][1];
          const Vec3 u2 = s[5 + a2] - s[4], u1 = s[1 + a1] - s[0];
          C.row(r + n).noalias() = u1.transpose() * (J(i + 5 + a2) - J(i + 4));
          C.row(r + n).noalias() += u2.transpose() * (J(i + 1 + a1) - J(i));
        }
        C.middleRows<3>(r + 3) = J(i + 4) - J(i);
        break;
      }
    }
  }
}

double ConstraintTerms::calcViolation(const std::vector<Vec3>& p, int index) const {
  KNEESIM_CHECK(index >= 0 && index < getNumConstraints(), "constraint index");
  const Kind& k = kinds_[index];
  const Vec3* s = p.data() + k.first_station;
  switch (k.type) {
    case ConstraintType::Point:
      return (s[1] - s[0]).norm();
    case ConstraintType::ConstantDistance:
      return std::abs((s[1] - s[0]).norm() - k.length);
    case ConstraintType::PointOnLine: {
      const Vec3 e = s[3] - s[0];
      return std::hypot(e.dot(s[1] - s[0]), e.dot(s[2] - s[0]));
    }
    case ConstraintType::Weld: {
      Eigen::Matrix3d R1, R2;
      for (int a = 0; a < 3; ++a) {
        R1.col(a) = s[1 + a] - s[0];
        R2.col(a) = s[5 + a] - s[4];
      }
      // The relative rotation's angle, from its sine and cosine (acos alone loses small angles).
      const Eigen::Matrix3d M = R1.transpose() * R2;
      const Vec3 w(M(2, 1) - M(1, 2), M(0, 2) - M(2, 0), M(1, 0) - M(0, 1));
      return std::max((s[4] - s[0]).norm(), std::atan2(0.5 * w.norm(), 0.5 * (M.trace() - 1.0)));
    }
  }
  return 0.0;
}

}  // namespace kneesim::ik
