#pragma once
// The knee's net load in clinical terms: from the load the femoral side applies to the tibial
// side (dynamics/joint_loads.hpp, expressed in the tibial body's frame), the compressive axial
// force, the anterior and medial shears, and the flexion, adduction and internal-rotation moments
// (net internal moments about the joint centre, positive in the sense of the joint's motion:
// flexion about the medial axis, adduction about the anterior axis, internal rotation about the
// superior axis, as for a right knee).

#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/storage.hpp"

namespace kneesim::dynamics {

/// The anatomical directions of the tibial frame's axes, as unit vectors in that frame.
struct KneeAxes {
  Eigen::Vector3d anterior = -Eigen::Vector3d::UnitX();
  Eigen::Vector3d superior = Eigen::Vector3d::UnitY();
  Eigen::Vector3d medial = Eigen::Vector3d::UnitZ();
};

/// Reads three words naming the tibial frame's x, y and z axes, each one of anterior, posterior,
/// superior, inferior, medial, lateral (JW's implant frame: "posterior superior medial"). Throws
/// std::invalid_argument unless they name three different directions.
KneeAxes parseKneeAxes(const std::string& words);

/// The columns of makeKneeLoadTable, after "time".
const std::vector<std::string>& getKneeLoadColumns();

/// The knee load table: time, knee_axial_force (N, compression positive), knee_ap_force (N, on the
/// tibia, anterior positive), knee_ml_force (N, medial positive), knee_flexion_moment,
/// knee_adduction_moment, knee_rotation_moment (N·m), from @p time and the joint's load on the
/// tibial body in its own frame (@p force, @p moment: one row per frame).
io::Storage makeKneeLoadTable(const std::vector<double>& time, const Eigen::MatrixX3d& force, const Eigen::MatrixX3d& moment,
                              const KneeAxes& axes);

}  // namespace kneesim::dynamics
