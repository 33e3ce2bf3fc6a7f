#pragma once
// The position equations of a model's body constraints (Point, PointOnLine, ConstantDistance,
// Weld) as inverse kinematics uses them: values and Jacobians from station positions.
//
// Each constraint is written in terms of stations (points fixed on bodies): the constrained
// points, and the tips of the unit axes that carry a line or a frame. The caller computes the
// stations' positions and Jacobians (sim::System) and this class combines them, so a frame's
// solve allocates nothing. The equations are Simbody's, so that a weighted sum of their squares
// is the penalty OpenSim's AssemblySolver adds for a finite constraint_weight:
//   Point             p2 - p1                                  (3, m)
//   PointOnLine       (p2 - a) . n_k, n_1 and n_2 across the line (2, m)
//   ConstantDistance  |p2 - p1| - L                            (1, m)
//   Weld              x2 . y1, y2 . z1, z2 . x1, then o2 - o1     (6: 3 dimensionless, 3 m)

#include <vector>

#include <Eigen/Core>

#include "model/model.hpp"

namespace kneesim::ik {

/// Position equations of Model::constraints, in model order.
class ConstraintTerms {
 public:
  explicit ConstraintTerms(const model::Model& model);

  /// Stations to evaluate, in order: body and location in the body.
  const std::vector<int>& getStationBodies() const { return bodies_; }
  const std::vector<Eigen::Vector3d>& getStations() const { return stations_; }
  int getNumStations() const { return int(bodies_.size()); }
  /// Number of equations (rows of the error vector).
  int getNumEquations() const { return n_equations_; }
  int getNumConstraints() const { return int(kinds_.size()); }

  /// The equations' values from the stations' positions in ground, @p p (one per station).
  void calcErrors(const std::vector<Eigen::Vector3d>& p, Eigen::Ref<Eigen::VectorXd> c) const;

  /// Their Jacobian with respect to some variables z: @p Js holds the stations' position
  /// Jacobians (rows 3i..3i+2 for station i, one column per variable); @p C gets one row per
  /// equation. Allocates nothing.
  void calcJacobian(const std::vector<Eigen::Vector3d>& p, const Eigen::Ref<const Eigen::MatrixXd>& Js,
                    Eigen::Ref<Eigen::MatrixXd> C) const;

  /// How far constraint @p k is from being satisfied, in words a user reads: the distance
  /// between points (Point), from the line (PointOnLine), from the length (ConstantDistance),
  /// or the larger of the origins' distance (m) and the frames' relative angle (rad, Weld).
  double calcViolation(const std::vector<Eigen::Vector3d>& p, int k) const;

 private:
  struct Kind {
    model::ConstraintType type;
    int first_station;
    int first_row;
    double length;  // ConstantDistance
  };
  std::vector<Kind> kinds_;
  std::vector<int> bodies_;
  std::vector<Eigen::Vector3d> stations_;
  int n_equations_ = 0;
};

}  // namespace kneesim::ik
