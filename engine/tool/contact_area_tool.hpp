#pragma once
// ContactAreaTool: implant contact area over a trial from a setup file (Dao & Pouletaut 2015,
// section 2.4). Reads the femoral component and tibial insert STLs, places the femoral component
// on the insert at every frame from one of two kinematics sources, and writes the contact-area
// storage (.sto) and, on request, per-frame distance maps (.vtp + .pvd).
//
// Kinematics sources:
//  - <HingeKinematics>: the paper's hinge. Flexion only about the cylinder fitted to the femoral
//    condyles, the femur seated on the insert at every angle (contact::Seater). Flexion angles from
//    a list or range in the setup, a column of a .mot/.sto file (unit per its inDegrees), or the
//    goniometer column GON of an eKnee knee-force CSV (degrees); flexion = scale * value + offset.
//  - <ModelKinematics>: a model and a motion (e.g. IK output): the model is realised at each frame
//    and X_IF is taken from the bodies carrying the two meshes and the meshes' X_BG in the model.
//
// Each step is a public function so that a larger workflow (IK -> area -> identification) can
// call them with its own setup: readContactAreaSetup, readImplantMeshes, calcContactKinematics,
// makeContactAreaCalculator, runContactArea.

#include <functional>
#include <limits>
#include <memory>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "contact/condyle.hpp"
#include "contact/contact_area.hpp"
#include "core/error.hpp"
#include "io/stl.hpp"
#include "io/storage.hpp"
#include "model/model.hpp"
#include "plugin/registry.hpp"

namespace kneesim::xml {
class Node;
}  // namespace kneesim::xml

namespace kneesim::tool {

/// Where the flexion angles of the hinge kinematics come from.
struct HingeKinematicsSpec {
  enum class Source { list, file_column, goniometer };
  Source source = Source::list;
  std::vector<double> flexion;  ///< Source::list: the angles (rad), one frame each.
  double time_step = 1.0;       ///< Source::list: time between frames (s); the first is at 0.
  std::string file;             ///< .mot/.sto (file_column) or knee-force CSV (goniometer), resolved.
  std::string column;           ///< file_column: the column label.
  /// flexion = scale * value + offset, value in rad (converted from the file's unit).
  double scale = 1.0, offset = 0.0;
  bool free_internal_rotation = false;  ///< Seating also minimises over internal rotation.
  /// Spacing (rad) of the flexion grid on which the femur is seated; the pose of every frame is
  /// then interpolated linearly in the seating coordinates between the two nearest knots and its
  /// residual gaps are measured. 0: seat every frame (about 0.6 s per frame on JW's meshes).
  double seating_grid = 1.0 * contact::kDegree;
  SourceLocation where;                 ///< The <HingeKinematics> element, for errors.
};

/// A model and a motion placing the two components.
struct ModelKinematicsSpec {
  std::string model_file;   ///< .osim or .urdf, resolved.
  std::string motion_file;  ///< .mot/.sto with a column per coordinate, resolved.
  std::string femoral_body, insert_body;  ///< Bodies carrying the femoral component and the insert.
  /// Meshes of those bodies (matched by file name without extension, e.g. "femoral_component"
  /// for femoral_component.vtp) whose X_BG and scale place the STL in the body; empty: the STL is
  /// in the body frame.
  std::string femoral_mesh, insert_mesh;
  SourceLocation where;  ///< The <ModelKinematics> element, for errors.
};

/// The contents of a ContactAreaTool setup file, paths resolved against its folder.
struct ContactAreaSetup {
  std::string setup_file;
  std::string name = "contact";
  std::string femur_file, insert_file;  ///< STL paths.
  /// Multiplies the STL coordinates (1: files in metres, 0.001: in millimetres); the size
  /// plausibility check (largest extent 1..50 cm) applies after it.
  double mesh_scale = 1.0;
  contact::ContactAreaOptions options;          ///< Thresholds, area rule, insert directions.
  contact::ComponentDirections femur_directions;  ///< Anatomical directions of the femoral component.
  /// "fcl" (default), any provider a loaded plugin registers, or "MeshDistance" (the engine's exact
  /// reference, no plugin).
  std::string distance_provider = "fcl";
  std::vector<std::string> plugins;  ///< Plugins to load (default: distance_fcl for an fcl* provider).
  bool use_model = false;            ///< ModelKinematics rather than HingeKinematics.
  HingeKinematicsSpec hinge;
  ModelKinematicsSpec model;
  /// Frames outside [time_start, time_end] are left out.
  double time_start = -std::numeric_limits<double>::infinity();
  double time_end = std::numeric_limits<double>::infinity();
  std::string results_directory;  ///< Resolved.
  std::string output_file;        ///< The .sto (resolved; default <results>/<name>_contact_area.sto).
  bool write_vtp = false;         ///< Also write distance maps.
  int vtp_every = 1;              ///< Every n-th frame gets a distance map.
  bool vtp_femur = true;          ///< Also write the placed femoral component per map frame.
  std::string hinge_file;         ///< Optional CSV of the seated hinge poses (resolved; "" none).
};

/// Reads a ContactAreaTool setup file (root <ContactAreaTool>, or inside <OpenSimDocument>).
/// Throws InputError with file, line and element for unknown elements, bad values, a missing or
/// doubled kinematics source.
ContactAreaSetup readContactAreaSetup(const std::string& path);

/// Reads <distance_provider> (default "fcl") and <plugins> of a setup element @p tool into @p s;
/// without <plugins>, an FCL provider loads the distance_fcl plugin. Shared by the setups that
/// describe a contact-area calculation (ContactAreaTool, KneeContactWorkflow).
void readDistanceProvider(const xml::Node& tool, ContactAreaSetup& s);

/// The two components, read as the setup says (closed meshes required, size checked).
struct ImplantMeshes {
  io::TriangleMesh femur, insert;
};
/// Reads the setup's STLs. Throws InputError for a missing, empty, open or non-manifold file or
/// one whose size is implausible for its unit ("is the file in millimetres?").
ImplantMeshes readImplantMeshes(const ContactAreaSetup& setup);

/// Poses of the femoral component in the insert frame over a trial.
struct ContactKinematics {
  std::vector<double> time;            ///< s.
  std::vector<Eigen::Isometry3d> X_IF;  ///< One per time.
  /// Extra per-frame columns for the storage (e.g. "flexion" in rad).
  std::vector<std::pair<std::string, std::vector<double>>> columns;
  std::string description;             ///< One line, for the storage header.
  std::vector<std::string> warnings;   ///< Tolerated problems, one line each.
};

/// Kinematics from @p model realised at every row of @p motion inside the setup's time range (the
/// bodies and meshes of setup.model; its model_file and motion_file are not read, @p motion_name
/// names the motion in messages). A coordinate without a column takes its coupler's value when it
/// is the dependent of a CoordinateCouplerConstraint, else its default; that is an error only for
/// an unlocked, uncoupled coordinate of a joint between the two bodies, which would move one
/// component relative to the other. Throws InputError for unknown bodies or meshes, scaled meshes,
/// such a missing column, a non-finite value or a time range that does not overlap the motion.
ContactKinematics calcModelKinematics(const ContactAreaSetup& setup, const model::ModelPtr& model,
                                      const io::Storage& motion, const std::string& motion_name,
                                      const std::function<void(const std::string&, int, int)>& progress = {});

/// The paper's hinge kinematics (the setup's femur_directions, insert directions and hinge
/// settings: seating grid, free internal rotation) at the flexion angles @p flexion (rad), one per
/// time of @p time; the setup's flexion source and time range are not used. Columns: flexion and
/// the residual gaps hinge_gap_medial/lateral. Throws InputError for non-finite angles or times.
ContactKinematics calcHingeKinematics(const ContactAreaSetup& setup, const ImplantMeshes& meshes,
                                      const std::vector<double>& time, const std::vector<double>& flexion,
                                      const std::function<void(const std::string&, int, int)>& progress = {});

/// Computes the kinematics the setup asks for. @p progress, if set, gets (what, done, total).
/// Throws InputError for missing files or columns, unknown bodies or meshes, a time range that
/// does not overlap the data.
ContactKinematics calcContactKinematics(const ContactAreaSetup& setup, const ImplantMeshes& meshes,
                                        const std::function<void(const std::string&, int, int)>& progress = {});

/// The contact-area calculator for the setup: loads the plugins into @p registry (which must
/// outlive the calculator) and looks up the provider (none for "MeshDistance").
std::unique_ptr<contact::ContactAreaCalculator> makeContactAreaCalculator(const ContactAreaSetup& setup,
                                                                          const ImplantMeshes& meshes,
                                                                          plugin::Registry& registry);

/// What a run did.
struct ContactAreaReport {
  contact::ContactSeries series;
  ContactKinematics kinematics;
  std::string distance_method;
  double articular_area = 0, search_radius = 0;
  std::vector<std::string> outputs;   ///< Files written.
  std::vector<std::string> warnings;
  double seconds_kinematics = 0, seconds_area = 0;
};

/// How a run reports back.
struct ContactAreaRunOptions {
  std::function<void(const std::string&, int, int)> progress;  ///< (what, done, total)
};

/// Runs the tool: meshes, kinematics, contact area per frame, then writes the outputs (all
/// computation first, every file atomically).
ContactAreaReport runContactArea(const ContactAreaSetup& setup, const ContactAreaRunOptions& options = {});

/// Writes a readable summary (frames, peaks with their times, outputs) to @p os.
void printContactAreaSummary(const ContactAreaReport& report, std::ostream& os);

}  // namespace kneesim::tool
