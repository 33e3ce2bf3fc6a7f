#pragma once
// Seating the femoral component on the tibial insert, and the paper's hinge kinematics.
//
// The kgc4-jw implant files give each component in its own frame; their relative placement is
// not given. Seating places the femoral component (frame F) on the insert (frame I) at a flexion
// angle theta, reproducibly:
//
//  1. Flexion: rotate F by theta about the fitted cylinder axis (the hinge), in the flexion sense
//     of ComponentDirections::calcFlexionAxis, after aligning F's anatomical directions with I's.
//  2. Both condyles touching: for a given anterior-posterior and medial-lateral position of the
//     hinge point (and internal rotation), solve the hinge point's superior-inferior position h
//     and the varus-valgus rotation phi (about I's posterior axis, through the hinge point) so
//     that the minimal signed distance of EACH condyle to the insert is zero (Newton's method,
//     finite-difference Jacobian).
//  3. Lowest potential: choose the anterior-posterior and medial-lateral position (and, when
//     enabled, the internal rotation) that minimise h, the height of the hinge point: the femur
//     settles into the insert's dishes (quasi-Newton/BFGS, gradient from the implicit function
//     theorem on step 2). On a flat insert h does not depend on the position and the start is
//     kept.
//
// A condyle's signed distance is the smallest of (a) the signed distances of its articular
// points (mesh vertices, SurfacePoint) to the insert mesh and, when two-sided, (b) those of the
// insert's articular vertices on that side to the femoral mesh, so neither mesh's vertices
// penetrate the other's faces.
//
// Pose: X_IF = [R | p_IH - R p_FH] with R = R_sup(psi) R_post(phi) R_IF0 R_hinge(theta), where p_FH
// is the hinge point in F, p_IH where it is placed in I, R_IF0 the rotation aligning F's
// directions with I's, and R_post, R_sup rotations about I's posterior and superior directions.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "contact/condyle.hpp"
#include "contact/cylinder_fit.hpp"
#include "contact/distance.hpp"
#include "io/stl.hpp"

namespace kneesim::contact {

/// Signed distances from a fixed set of points (frame Q) to a closed target mesh (frame T).
class PointSetDistance {
 public:
  virtual ~PointSetDistance() = default;
  /// Number of query points.
  virtual int getNumPoints() const = 0;
  /// Fills @p distance (resized to getNumPoints()) with each point's signed distance to the
  /// target, negative inside. Points farther than @p max_distance from the surface (outside or
  /// inside) may get any value above max_distance.
  virtual void calcDistances(const Eigen::Isometry3d& X_TQ, double max_distance,
                             std::vector<double>& distance) const = 0;
};

/// Creates a PointSetDistance for @p target and @p points_Q (copied as needed).
using PointSetDistanceFactory = std::function<std::unique_ptr<PointSetDistance>(
    const io::TriangleMesh& target, const std::vector<Eigen::Vector3d>& points_Q)>;

/// A PointSetDistance computed by a distance provider plugin through DistanceField.
class ProviderPointSetDistance final : public PointSetDistance {
 public:
  /// Prepares @p provider for @p target and @p points_Q.
  ProviderPointSetDistance(const kneesim_distance_provider& provider, const io::TriangleMesh& target,
                           const std::vector<Eigen::Vector3d>& points_Q)
      : field_(provider, target, points_Q) {}
  int getNumPoints() const override { return field_.getNumPoints(); }
  void calcDistances(const Eigen::Isometry3d& X_TQ, double max_distance,
                     std::vector<double>& distance) const override {
    field_.calcDistances(X_TQ, max_distance, distance);
  }

 private:
  DistanceField field_;
};

/// A factory using @p provider (e.g. the "fcl" provider from plugin::Registry). The provider must
/// outlive the PointSetDistance objects it makes.
inline PointSetDistanceFactory makeProviderDistanceFactory(const kneesim_distance_provider& provider) {
  return [&provider](const io::TriangleMesh& target, const std::vector<Eigen::Vector3d>& points_Q) {
    return std::unique_ptr<PointSetDistance>(new ProviderPointSetDistance(provider, target, points_Q));
  };
}

/// Everything seating needs about the two components.
struct SeatingSetup {
  io::TriangleMesh femur;   ///< Femoral component in frame F (closed, outward-oriented).
  io::TriangleMesh insert;  ///< Tibial insert in frame I (closed, outward-oriented).
  Cylinder hinge_F;         ///< Flexion hinge in F (e.g. CondyleFits::both.cylinder).
  ComponentDirections femur_directions;   ///< Anatomical directions in F.
  ComponentDirections insert_directions;  ///< Anatomical directions in I.
  /// Articular points of each femoral condyle (F), checked against the insert mesh.
  std::vector<SurfacePoint> femur_medial_F, femur_lateral_F;
  /// Articular points of each insert compartment (I), checked against the femoral mesh when
  /// SeatingOptions::two_sided is set.
  std::vector<SurfacePoint> insert_medial_I, insert_lateral_I;
};

/// Fills a SeatingSetup with the default point selections:
///  - femur: every vertex of each condyle selected by selectArticularPoints relative to the
///    hinge, facing -30..150 deg, normal tilt <= 60 deg, recess <= 5 mm, all points kept;
///  - insert: every exposed vertex whose normal is within 75 deg of the insert's superior
///    direction, split medial/lateral by the plane through the insert's bounding-box centre.
/// Throws InputError (naming the mesh file) if a component has no such points.
SeatingSetup makeSeatingSetup(io::TriangleMesh femur, io::TriangleMesh insert, const Cylinder& hinge_F,
                              const ComponentDirections& femur_directions = {},
                              const ComponentDirections& insert_directions = {});

/// Settings of the seating solver.
struct SeatingOptions {
  /// Each condyle's gap |d| at the solution is at most this (m).
  double tolerance = 1e-7;
  /// The lowest-potential search stops when a step is shorter than this (m; internal rotation
  /// counts as its arc at 20 mm).
  double position_tolerance = 1e-5;
  /// Also minimise the height over internal-external rotation (otherwise held at the start's).
  bool free_internal_rotation = false;
  /// Check the insert's vertices against the femoral mesh as well (see the file comment).
  bool two_sided = true;
  int max_inner_iterations = 50;  ///< Newton iterations for (h, phi).
  int max_outer_iterations = 60;  ///< Quasi-Newton iterations for the lowest-potential position.
  /// Finite-difference step (m); angles use fd_step / 20 mm.
  double fd_step = 1e-6;
  /// Distance computation; empty: the built-in exact MeshDistance. Use
  /// makeProviderDistanceFactory to compute with a plugin (e.g. "fcl").
  PointSetDistanceFactory distance_factory;
};

/// The five seating coordinates besides flexion.
struct SeatingCoordinates {
  /// Position of the hinge point (the hinge axis point in F) in I (m).
  Eigen::Vector3d p_IH = Eigen::Vector3d::Zero();
  /// Rotation about I's posterior direction through the hinge point (rad); positive turns the
  /// femur's superior direction toward medial.
  double varus = 0;
  /// Rotation about I's superior direction (rad).
  double internal = 0;
};

/// A seated pose.
struct SeatingResult {
  double flexion = 0;  ///< Flexion angle about the hinge (rad).
  SeatingCoordinates q;  ///< The seated coordinates.
  Eigen::Isometry3d X_IF = Eigen::Isometry3d::Identity();  ///< Pose of F in I.
  /// Smallest signed distance of each condyle to the insert at X_IF (m): the residual gap (> 0)
  /// or penetration (< 0), |gap| <= tolerance when converged.
  double gap_medial = 0, gap_lateral = 0;
  /// Centre of each condyle's contact patch (in I): the mean of the femoral and insert points
  /// whose distance is within 10 um of that condyle's smallest distance.
  Eigen::Vector3d contact_medial_I = Eigen::Vector3d::Zero(), contact_lateral_I = Eigen::Vector3d::Zero();
  int inner_iterations = 0;      ///< Newton iterations, summed over all (h, phi) solves.
  int outer_iterations = 0;      ///< Lowest-potential (quasi-Newton) iterations.
  int distance_evaluations = 0;  ///< Evaluations of all point sets' distances.
  /// True when the gaps meet the tolerance and the position search stopped on its own criteria
  /// (short step or no further descent), not on the iteration limit.
  bool converged = false;
};

/// Seats a femoral component on an insert (see the file comment). Holds the distance structures
/// and buffers: create one per thread; calls do not allocate in their iterations.
class Seater {
 public:
  /// Prepares distance queries for @p setup. Throws InputError if the setup is unusable (no
  /// points on a condyle, zero hinge axis, bad directions).
  explicit Seater(SeatingSetup setup, SeatingOptions options = {});
  ~Seater();
  Seater(const Seater&) = delete;
  Seater& operator=(const Seater&) = delete;

  /// Seats at @p flexion (rad). Starts from @p start's coordinates when given (its flexion is
  /// ignored), else from the hinge point above the insert's bounding-box centre with the femur's
  /// lowest articular point 1 mm above the insert.
  SeatingResult calcSeating(double flexion, const SeatingCoordinates* start = nullptr);
  /// The neutral seating, calcSeating(0).
  SeatingResult calcNeutralSeating() { return calcSeating(0.0); }
  /// The paper's hinge assumption: flexion only about the fitted cylinder axis, seated at every
  /// angle of @p flexions (rad), each started from the previous result.
  std::vector<SeatingResult> calcHingeKinematics(const std::vector<double>& flexions);

  /// The pose X_IF for @p flexion and coordinates @p q.
  Eigen::Isometry3d calcPose(double flexion, const SeatingCoordinates& q) const;
  /// Each condyle's smallest signed distance at @p X_IF (medial, lateral), searching up to
  /// @p max_distance, and, if @p where_I is not null, the centre of its contact patch (in I, as
  /// in SeatingResult).
  void calcGaps(const Eigen::Isometry3d& X_IF, double max_distance, double gap[2], Eigen::Vector3d* where_I);

  /// The components and points being seated.
  const SeatingSetup& getSetup() const { return setup_; }
  /// The solver settings.
  const SeatingOptions& getOptions() const { return options_; }

 private:
  struct Impl;
  SeatingSetup setup_;
  SeatingOptions options_;
  std::unique_ptr<Impl> impl_;
};

/// Writes hinge kinematics as CSV (atomic): flexion_deg; hinge point p_IH (m); varus_deg,
/// internal_deg; gap_medial_m, gap_lateral_m; contact points (m); converged; iterations; and the
/// pose X_IF as a row-major 3x4 matrix X_IF_00..X_IF_23 (rotation, then translation in m).
void writeHingeKinematics(const std::string& path, const std::vector<SeatingResult>& results);

}  // namespace kneesim::contact
