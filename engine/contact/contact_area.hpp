#pragma once
// Implant contact area per frame (Dao & Pouletaut 2015, section 2.4): the area of the tibial
// insert's articular surface that lies closer than a threshold (4 mm in the paper) to the femoral
// component, split into medial and lateral compartments, with each compartment's smallest signed
// distance and the centroid of its contact region.
//
// Discretisation. The articular surface is the insert's triangles whose three vertices are
// articular (selectInsertArticularVertices: facing up within 75 degrees, exposed). The signed
// distance to the femoral component is computed exactly at those vertices and interpolated
// linearly over each triangle; the contact region of a threshold t is the part of each triangle
// where the interpolated distance is below t (AreaRule::partial_triangles), clipped exactly by
// the medial/lateral plane. The error comes from the distance not being linear within a triangle:
// about h^2/8 |d''| in the position of the level line for edges of length h, i.e. an area error of
// about (perimeter of the region) x h^2 / (8 R) for a femoral radius R (~0.1% on JW's insert; the
// sphere-on-plane test bounds it). AreaRule::vertex_areas instead counts each vertex's area (a
// third of its articular triangles') when its distance is below t: simpler, but its error is of
// the order of (perimeter) x h/2.
//
// Minimum distances are over the articular vertices (the femur's closest point may lie between
// them: an error up to about h^2 / (8 R)). Distances are signed: a penetrating femur gives
// negative distances and counts as contact.
//
// Model/Data split: ContactAreaCalculator is immutable and may be shared between threads; each
// thread creates a ContactAreaWorkspace (distance-provider context and buffers). calcFrame does not
// allocate.

#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "contact/condyle.hpp"
#include "contact/distance.hpp"
#include "contact/mesh_distance.hpp"
#include "core/error.hpp"
#include "io/stl.hpp"
#include "plugin/kneesim_plugin.h"

namespace kneesim::contact {

/// How the contact region of a threshold is measured on the articular surface.
enum class AreaRule {
  partial_triangles,  ///< The part of each triangle where the linearly interpolated distance is below it.
  vertex_areas,       ///< The vertex areas (1/3 of the incident articular triangles) of vertices below it.
};
/// "partial_triangles" or "vertex_areas".
const char* toString(AreaRule rule);
/// Parses "partial_triangles" or "vertex_areas"; throws InputError at @p where otherwise.
AreaRule parseAreaRule(const std::string& text, const SourceLocation& where = {});

/// Settings of the contact-area computation.
struct ContactAreaOptions {
  /// The contact threshold (m): S is the articular area closer than this to the femoral
  /// component. Dao & Pouletaut use 4 mm.
  double threshold = 4e-3;
  /// More thresholds (m), each reported as a channel "S@<t in mm>mm" (e.g. "S@3mm").
  std::vector<double> extra_thresholds;
  AreaRule rule = AreaRule::partial_triangles;  ///< How areas are measured.
  /// Anatomical directions of the insert (superior for the articular selection, medial for the
  /// split). The defaults are those of the kgc4-jw files.
  ComponentDirections insert_directions;
  /// Largest angle between an articular vertex normal and the superior direction.
  double max_normal_angle = 75.0 * kDegree;
};

/// Name of the area channel of threshold @p t (m): "S@4mm", "S@2.5mm".
std::string areaChannelName(double t);

/// The contact measures of one frame. Lengths in m, areas in m^2, in the insert frame I.
struct ContactFrame {
  double S = 0, S_medial = 0, S_lateral = 0;  ///< Contact area at the threshold, total and per compartment.
  /// Smallest signed distance over the articular vertices, total and per compartment (negative:
  /// penetration).
  double dmin = 0, dmin_medial = 0, dmin_lateral = 0;
  /// Area-weighted centroid of each compartment's contact region (NaN when its area is zero).
  Eigen::Vector3d centroid_medial = Eigen::Vector3d::Zero(), centroid_lateral = Eigen::Vector3d::Zero();
  /// Area at each extra threshold, in ContactAreaOptions::extra_thresholds order.
  std::vector<double> S_extra;
};

class ContactAreaCalculator;

/// Per-thread data of a ContactAreaCalculator: the distance provider's context and the buffers of
/// one frame. Create with ContactAreaCalculator::createWorkspace.
class ContactAreaWorkspace {
 public:
  ~ContactAreaWorkspace();
  ContactAreaWorkspace(const ContactAreaWorkspace&) = delete;
  ContactAreaWorkspace& operator=(const ContactAreaWorkspace&) = delete;

  /// Signed distance (m) of each articular vertex at the last frame computed, in the order of
  /// ContactAreaCalculator::getArticularVertices; values beyond the search radius may be +-inf.
  const std::vector<double>& getDistances() const { return distance_; }

 private:
  friend class ContactAreaCalculator;
  ContactAreaWorkspace() = default;
  // One field per group of vertices (see ContactAreaCalculator::getSearchRadius); null: the
  // calculator's MeshDistance.
  std::unique_ptr<DistanceField> field_[2];
  std::vector<double> buffer_[2];
  std::vector<double> distance_;
  std::vector<double> clamped_;
};

/// Contact area of a tibial insert (frame I) against a femoral component (frame F) for poses
/// X_IF. Immutable after construction.
class ContactAreaCalculator {
 public:
  /// Selects the insert's articular surface and prepares distance queries to @p femur. With a
  /// @p provider (e.g. "fcl" from plugin::Registry; it must outlive the calculator), each
  /// workspace computes distances through it; with nullptr, through the engine's exact
  /// MeshDistance (slower, the reference). Both meshes must be closed and outward-oriented (read
  /// them with io::StlOptions::require_closed). Throws InputError (naming the mesh file) for
  /// unusable meshes or options (a negative or non-finite threshold, no articular surface).
  ContactAreaCalculator(io::TriangleMesh insert, io::TriangleMesh femur, ContactAreaOptions options = {},
                        const kneesim_distance_provider* provider = nullptr);
  ~ContactAreaCalculator();

  /// A workspace for one thread.
  std::unique_ptr<ContactAreaWorkspace> createWorkspace() const;

  /// Computes the contact measures at pose @p X_IF (pose of F in I). @p out.S_extra must have
  /// one entry per extra threshold (calcFrame resizes it otherwise, allocating once). Throws
  /// InputError if the distance provider fails (a pose that is not a rigid transform).
  void calcFrame(ContactAreaWorkspace& ws, const Eigen::Isometry3d& X_IF, ContactFrame& out) const;

  /// The settings.
  const ContactAreaOptions& getOptions() const { return options_; }
  /// The insert and femoral component meshes.
  const io::TriangleMesh& getInsert() const { return insert_; }
  const io::TriangleMesh& getFemur() const { return femur_; }
  /// The articular vertices (insert vertex indices): the medial ones first, then the lateral.
  const std::vector<int>& getArticularVertices() const { return vertices_; }
  /// Number of medial articular vertices (the first ones of getArticularVertices).
  int getNumMedialVertices() const { return n_medial_; }
  /// The articular triangles, as indices into getArticularVertices.
  const std::vector<Eigen::Vector3i>& getArticularTriangles() const { return triangles_; }
  /// Total area of the articular surface (m^2) and of each compartment.
  double getArticularArea() const { return area_total_; }
  double getArticularArea(CondyleSide side) const;
  /// Distances are exact within this distance of the femoral component (m) for all articular
  /// vertices: the largest threshold plus the longest articular edge at 90% of the vertices. The
  /// other vertices (with a longer edge) are searched up to the largest threshold plus their
  /// longest edge (getLongEdgeSearchRadius), so every triangle a threshold crosses has exact
  /// distances at its three vertices.
  double getSearchRadius() const { return radius_[0]; }
  /// The search radius of the vertices with the longest edges (m).
  double getLongEdgeSearchRadius() const { return radius_[1]; }
  /// Number of articular vertices searched up to getLongEdgeSearchRadius.
  int getNumLongEdgeVertices() const { return int(group_[1].size()); }
  /// The provider's name, or "MeshDistance".
  std::string getDistanceMethod() const;

 private:
  struct TriangleData {
    Eigen::Vector3i v;       // local vertex indices
    double area = 0;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    signed char side = 0;    // +1 medial, -1 lateral, 0 crossing the split plane
  };
  void accumulate(const double* d, double t, bool split, ContactFrame* frame, double& total) const;

  io::TriangleMesh insert_, femur_;
  ContactAreaOptions options_;
  const kneesim_distance_provider* provider_ = nullptr;
  std::unique_ptr<MeshDistance> exact_;  // when provider_ is null
  std::vector<int> vertices_;
  int n_medial_ = 0;
  std::vector<Eigen::Vector3d> points_I_;    // articular vertex positions
  std::vector<double> vertex_area_;          // per articular vertex (vertex_areas rule)
  std::vector<Eigen::Vector3i> triangles_;
  std::vector<TriangleData> tri_;
  Eigen::Vector3d split_point_ = Eigen::Vector3d::Zero(), medial_ = Eigen::Vector3d::UnitZ();
  double area_total_ = 0, area_medial_ = 0, area_lateral_ = 0;
  // Vertices (local indices) searched up to radius_[0] and radius_[1], and each vertex's radius.
  std::vector<int> group_[2];
  double radius_[2] = {0, 0};
  std::vector<double> vertex_radius_;
};

/// A contact-area time series.
struct ContactSeries {
  std::vector<double> time;          ///< s (or frame numbers when the source has no clock).
  std::vector<ContactFrame> frames;  ///< One per time.
  std::vector<double> extra_thresholds;  ///< m, naming ContactFrame::S_extra.
  /// dS/dt, dS_medial/dt, dS_lateral/dt (m^2/s): central differences, one-sided at the ends
  /// (0 for a single frame).
  std::vector<double> dS_dt, dS_medial_dt, dS_lateral_dt;
};

/// Computes every frame of @p X_IF (one pose per time, in order, using @p ws so coherent
/// providers profit from the continuity) and the time derivatives. @p progress, if set, is called
/// with (done, total); @p on_frame, if set, after each frame with its index and the workspace
/// (whose getDistances() hold that frame's distance map).
ContactSeries calcContactSeries(const ContactAreaCalculator& calculator, ContactAreaWorkspace& ws,
                                const std::vector<double>& time, const std::vector<Eigen::Isometry3d>& X_IF,
                                const std::function<void(int, int)>& progress = {},
                                const std::function<void(int, const ContactAreaWorkspace&)>& on_frame = {});

/// Fills the time derivatives of @p series from its areas and times.
void calcAreaDerivatives(ContactSeries& series);

/// The channels of @p series as named columns (time first): S, S_medial, S_lateral, dmin,
/// dmin_medial, dmin_lateral, cx_medial, cy_medial, cz_medial, cx_lateral, cy_lateral,
/// cz_lateral, S@<t>mm per extra threshold, dS_dt, dS_medial_dt, dS_lateral_dt. SI units.
std::vector<std::pair<std::string, std::vector<double>>> getContactChannels(const ContactSeries& series);

}  // namespace kneesim::contact
