#pragma once
// `kneesim run build_model.xml` (<KneeModelTool>): builds the project's patient-specific knee model
// (models/jw-knee24) from an OpenSim 3 whole-body model and the implant STL files, and writes it in
// OpenSim format 40000.
//
// What it does, in order:
//  1. Frame checks. The source model's knee places the femoral component (frame F) on the tibial
//     component (frame T) at its default pose. With both STLs drawn in their body frames, the
//     tool measures each condyle's signed distance to the insert there, the difference from the
//     seated pose, how the femoral component's superior axis sits on the femur's mechanical axis
//     (hip centre to knee), and how the CT talus lies against the source model's ankle centre in
//     the tray frame. These figures establish that the STL component frames are the body frames.
//  2. Tibiofemoral path. contact::Seater seats the femoral component on the insert (both condyles
//     touching, lowest potential) at each flexion knot. In the insert's dishes the lowest-potential
//     antero-posterior position is flat to a few micrometres over about a millimetre, so the seated
//     positions scatter: the hinge point's antero-posterior and medio-lateral path is smoothed
//     (local linear regression, tricube weights), shifted to pass through the neutral seating, and
//     the femur re-seated on that path (height and varus solved so both condyles touch again).
//  3. The knee joint: a forward CustomJoint femoral_component -> tibial_component whose F frame is
//     the fitted hinge (origin on the cylinder axis, z the flexion axis) and whose M frame is where
//     that hinge sits in the tibial component at zero flexion on the path. knee_flexion is the
//     free coordinate; knee_adduction, knee_rotation, knee_tx, knee_ty, knee_tz follow it through
//     CoordinateCouplerConstraints (SimmSplines over the knots), so the condyles stay on the insert.
//  4. The patellofemoral joint: the patella (frame = the patellar component's STL frame, shared by
//     the button and the resected patella bone) rotates about the femoral component's z axis with
//     knee flexion (as the source model's patfem coupling does), and its distance from that axis is
//     chosen at every knot so the button's dome touches the femoral component (patfem_tx, patfem_ty
//     coupled); patfem_adduction, patfem_rotation and patfem_tz are locked at zero.
//  5. The rest of the right leg (pelvis, hip, femur, femoral component weld, tibial weld, ankle,
//     subtalar, mtp) is copied from the source model; the pelvis joint's parent frame turns the
//     model's y-up, x-forward axes into the lab's; markers are renamed to the C3D names.
//  6. A check through the built model (Simbody, couplers applied): the condyles' and the button's
//     gaps at the knots and half-way between them.

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "model/model.hpp"
#include "tool/run.hpp"

namespace kneesim::tool {

/// One marker of the built model.
struct KneeModelMarker {
  std::string name;    ///< Name in the built model (as the C3D files label it).
  std::string body;    ///< Body in the built model.
  /// Marker of the source model whose location is copied ("" when the source has none: the
  /// marker is put at the body origin for the marker placer to register).
  std::string source;
};

/// The contents of a <KneeModelTool> setup file; paths resolved against the setup file's folder.
struct KneeModelSetup {
  std::string setup_file;
  std::string name = "knee_model";  ///< Model name written.
  std::string source_model_file;
  std::string femoral_component_file, tibial_insert_file, tibial_tray_file;
  std::string patellar_button_file, patella_bone_file, fibula_file;  ///< "" leaves the mesh out.
  std::string talus_file;  ///< CT talus, only for the frame check ("" skips it).
  std::string output_model_file;
  std::string path_file;  ///< CSV of the tibiofemoral and patellofemoral path ("" for none).
  double neutral_flexion = 0;  ///< rad; the model's default knee flexion (a seated pose).
  std::vector<double> flexion_knots;  ///< rad, strictly increasing, containing 0.
  double smoothing_window = 15.0 * 3.14159265358979323846 / 180.0;  ///< Half-width (rad).
  /// Lab directions of the model's x (forward), y (up) and z axes, as columns.
  Eigen::Matrix3d R_lab_model = Eigen::Matrix3d::Identity();
  std::vector<KneeModelMarker> markers;
  /// Range overrides of copied coordinates: name -> (min, max) in rad or m.
  std::vector<std::pair<std::string, std::pair<double, double>>> ranges;
};

/// Reads a <KneeModelTool> setup file. Throws InputError (file, line, element) on bad input.
KneeModelSetup readKneeModelSetup(const std::string& path);

/// One knot of the built knee path.
struct KneePathKnot {
  double flexion = 0;  ///< Seating flexion angle (rad) about the fitted hinge.
  /// Knee coordinates at the knot: flexion, adduction, rotation (rad), tx, ty, tz (m).
  double q[6] = {0, 0, 0, 0, 0, 0};
  double gap_medial = 0, gap_lateral = 0;  ///< Residual gaps of the re-seated pose (m).
  /// How much higher the hinge point sits on the smoothed path than at the lowest potential (m).
  double height_above_lowest = 0;
  double patella_offset = 0;  ///< Radial offset of the patella from its neutral radius (m).
  double patella_gap = 0;     ///< Button-to-femoral-component gap at the knot (m).
};

/// Figures of a build.
struct KneeModelReport {
  // Frame checks (step 1).
  double source_gap_medial = 0, source_gap_lateral = 0;  ///< At the source model's default knee pose (m).
  Eigen::Vector3d source_minus_seated = Eigen::Vector3d::Zero();  ///< Source pose - seated pose, origin of F in T (m).
  double source_seated_angle = 0;  ///< Rotation between the two poses (rad).
  double femur_axis_flexion = 0;   ///< Femoral component superior axis vs femoral mechanical axis, sagittal (rad).
  double femur_axis_coronal = 0;   ///< ... coronal (rad; positive: the component's top tilts medially).
  Eigen::Vector3d talus_minus_ankle = Eigen::Vector3d::Zero();  ///< CT talus centroid - ankle centre, tray frame (m).
  double fibula_top = 0;           ///< Highest fibula point, tray frame y (m).
  double patella_cut_offset = 0;   ///< Patella bone's cut face (largest x) - button back plane (x = 0) (m).
  // Seating (step 2).
  double neutral_gap_medial = 0, neutral_gap_lateral = 0;  ///< Neutral seating residuals (m).
  Eigen::Vector3d neutral_hinge_I = Eigen::Vector3d::Zero();  ///< Neutral hinge point in T (m).
  double hinge_radius = 0;          ///< Fitted cylinder radius (m).
  std::vector<KneePathKnot> knots;  ///< The path.
  double max_knot_gap = 0;          ///< Largest |gap| over the knots (m).
  double max_smoothing_height = 0;  ///< Largest height_above_lowest (m).
  // The built model driven by knee_flexion alone, couplers applied (step 6).
  double model_knot_gap = 0;              ///< Largest condyle |gap| at the knots (m).
  double model_midpoint_gap = 0;          ///< Largest condyle |gap| half-way between knots (m).
  double model_knot_patella_gap = 0;      ///< Largest button |gap| at the knots (m).
  double model_midpoint_patella_gap = 0;  ///< ... half-way between knots (m).
  /// Readable lines with all of the above.
  std::vector<std::string> lines;
};

/// A built model and its figures.
struct KneeModelResult {
  std::shared_ptr<model::Model> model;
  KneeModelReport report;
};

/// Builds the model (does not write anything). Throws InputError for bad input files.
KneeModelResult buildKneeModel(const KneeModelSetup& setup);

/// Runs a <KneeModelTool> setup: builds the model, writes it (and the path CSV) atomically, prints
/// the report to options.out.
void runKneeModelTool(const std::string& setup_path, const RunOptions& options);

}  // namespace kneesim::tool
