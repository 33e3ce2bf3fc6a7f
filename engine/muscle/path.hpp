#pragma once
// Muscle paths of a model evaluated as OpenSim's GeometryPath evaluates them: the active path
// points, wrapping over the path's wrap objects (up to eight passes when a path has several),
// the length, and the generalised forces of a unit tension along the path, from which moment
// arms (r = -dL/dq, OpenSim's MomentArmSolver) and lengthening speed (-r . u) follow in closed
// form.
//
// Model/Data split: a PathSet is immutable and shared; everything a frame needs lives in a
// PathWorkspace, one per thread. Evaluating a frame allocates nothing.

#include <memory>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "muscle/wrap.hpp"
#include "sim/system.hpp"

namespace kneesim::muscle {

/// One point of a path as it stands in the current frame.
struct CurrentPoint {
  int body = -1;                     ///< Body the point moves with (a wrap object's body for tangent points).
  Vec3 p_G = Vec3::Zero();           ///< Location in ground.
  int point = -1;                    ///< Index into GeometryPath::points, or -1 for a tangent point.
  int wrap = -1;                     ///< Tangent points: index into GeometryPath::wraps.
  double wrap_length = 0.0;          ///< Second tangent point: length on the surface from the first.
};

/// Per-thread scratch and results of a PathSet.
class PathWorkspace {
 public:
  PathWorkspace(const PathWorkspace&) = delete;
  PathWorkspace& operator=(const PathWorkspace&) = delete;
  ~PathWorkspace();

 private:
  friend class PathSet;
  PathWorkspace() = default;
  struct PathState {
    std::vector<CurrentPoint> current;  // capacity: points + 2 wraps
    std::vector<WrapResult> previous;   // per wrap, the last best wrap
    std::vector<int> order, status;     // per wrap
    double length = 0.0;
  };
  std::vector<PathState> paths;
  std::vector<Eigen::Isometry3d> X_GB;  // per body
  std::vector<Eigen::Isometry3d> X_GW;  // per wrap object
  sim::SpatialColumns body_forces;
  Eigen::VectorXd q, mobility;
};

/// The muscle paths of a model (Model::muscles, in model order), evaluated on a sim::System.
class PathSet {
 public:
  /// Keeps a reference to @p system, which must outlive the PathSet.
  explicit PathSet(const sim::System& system);

  int getNumPaths() const { return int(model_.muscles.size()); }
  const sim::System& getSystem() const { return system_; }

  /// A workspace sized for this model's paths.
  std::unique_ptr<PathWorkspace> createWorkspace() const;

  /// Computes every path's current points and length for coordinates @p q (model order, SI),
  /// after system.realizePosition(sws, q).
  void realize(const sim::Workspace& sws, const Eigen::VectorXd& q, PathWorkspace& ws) const;

  /// Length of path @p i after realize().
  double getLength(const PathWorkspace& ws, int i) const { return ws.paths[i].length; }

  /// The points of path @p i in the current frame, after realize().
  const std::vector<CurrentPoint>& getCurrentPath(const PathWorkspace& ws, int i) const { return ws.paths[i].current; }

  /// Generalised forces of a unit tension along path @p i, one per coordinate in the
  /// coordinates' speeds: g = -dL/dq, each coordinate moved alone (couplers ignored; see
  /// calcCouplingMatrix()). After realize(); @p g has one entry per coordinate.
  void calcGeneralizedForces(sim::Workspace& sws, PathWorkspace& ws, int i, Eigen::Ref<Eigen::VectorXd> g) const;

  /// Adds the loads of a tension @p tension (N) along path @p i: to the bodies (@p F, one column
  /// per body: moment about its origin and force, in ground) and, for moving points, directly to
  /// their coordinates (@p mobility, one entry per coordinate). After realize(); no allocation.
  void addLoads(const PathWorkspace& ws, int i, double tension, sim::SpatialColumns& F,
                Eigen::Ref<Eigen::VectorXd> mobility) const;

 private:
  void computePath(int i, PathWorkspace& ws) const;
  void applyWrapObjects(int i, PathWorkspace& ws) const;
  double calcLength(const PathWorkspace::PathState& ps, const model::GeometryPath& path) const;
  Vec3 calcPointInBody(const model::PathPoint& p, const Eigen::VectorXd& q) const;

  const sim::System& system_;
  const model::Model& model_;
};

/// The coupling matrix C of the model's coordinate couplers at @p q: dq = C dq_free, where
/// column k is the motion of all coordinates when independent coordinate k moves alone (zero
/// columns for coupled coordinates). The moment arm of a path about coordinate k is C.col(k) . g.
/// @p C must be n x n (n coordinates); allocates nothing.
void calcCouplingMatrix(const model::Model& model, const Eigen::VectorXd& q, Eigen::Ref<Eigen::MatrixXd> C);

/// The accelerations of the coupled coordinates when every other coordinate's acceleration is
/// zero, at coordinates @p q and rates @p qdot (the couplers' curvature, sum f_ij qdot_i qdot_j):
/// with C from calcCouplingMatrix(), qddot = C qddot_free + d. Other entries of @p d are zero.
void calcCouplingAcceleration(const model::Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
                              Eigen::Ref<Eigen::VectorXd> d);

}  // namespace kneesim::muscle
