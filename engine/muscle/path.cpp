// Muscle path geometry: active points, wrapping (OpenSim's GeometryPath::applyWrapObjects),
// length, and the generalised forces of a unit tension along the path.
#include "muscle/path.hpp"

#include <cmath>
#include <limits>

#include "core/error.hpp"

namespace kneesim::muscle {

using model::GeometryPath;
using model::PathPoint;
using model::PathPointType;

PathWorkspace::~PathWorkspace() = default;

PathSet::PathSet(const sim::System& system) : system_(system), model_(system.getModel()) {}

std::unique_ptr<PathWorkspace> PathSet::createWorkspace() const {
  std::unique_ptr<PathWorkspace> ws(new PathWorkspace());
  ws->paths.resize(model_.muscles.size());
  for (size_t i = 0; i < model_.muscles.size(); ++i) {
    const GeometryPath& path = model_.muscles[i].path;
    PathWorkspace::PathState& ps = ws->paths[i];
    ps.current.reserve(path.points.size() + 2 * path.wraps.size());
    ps.previous.assign(path.wraps.size(), WrapResult());
    ps.order.assign(path.wraps.size(), 0);
    ps.status.assign(path.wraps.size(), 0);
  }
  ws->X_GB.assign(model_.bodies.size(), Eigen::Isometry3d::Identity());
  ws->X_GW.assign(model_.wrap_objects.size(), Eigen::Isometry3d::Identity());
  ws->body_forces = sim::SpatialColumns::Zero(6, int(model_.bodies.size()));
  ws->q = Eigen::VectorXd::Zero(int(model_.coordinates.size()));
  ws->mobility = Eigen::VectorXd::Zero(int(model_.coordinates.size()));
  return ws;
}

Vec3 PathSet::calcPointInBody(const PathPoint& p, const Eigen::VectorXd& q) const {
  Vec3 p_B = p.p_BP;
  if (p.type == PathPointType::Moving)
    for (int k = 0; k < 3; ++k)
      if (p.location_functions[k] && p.location_coordinates[k] >= 0)
        p_B[k] = p.location_functions[k]->calcValue(q[p.location_coordinates[k]]);
  return p_B;
}

void PathSet::realize(const sim::Workspace& sws, const Eigen::VectorXd& q, PathWorkspace& ws) const {
  KNEESIM_CHECK(q.size() == int(model_.coordinates.size()), "coordinate vector size does not match the model");
  ws.q = q;
  for (size_t b = 0; b < model_.bodies.size(); ++b) ws.X_GB[b] = system_.getBodyPose(sws, int(b));
  for (size_t w = 0; w < model_.wrap_objects.size(); ++w)
    ws.X_GW[w] = ws.X_GB[model_.wrap_objects[w].body] * model_.wrap_objects[w].X_BW;
  for (int i = 0; i < getNumPaths(); ++i) computePath(i, ws);
}

void PathSet::computePath(int i, PathWorkspace& ws) const {
  const GeometryPath& path = model_.muscles[i].path;
  PathWorkspace::PathState& ps = ws.paths[i];
  ps.current.clear();
  for (size_t k = 0; k < path.points.size(); ++k) {
    const PathPoint& p = path.points[k];
    if (p.type == PathPointType::Conditional) {
      const double v = ws.q[p.coordinate];
      if (!(v >= p.range_min - 1e-5 && v <= p.range_max + 1e-5)) continue;
    }
    CurrentPoint cp;
    cp.body = p.body;
    cp.point = int(k);
    cp.p_G = ws.X_GB[p.body] * calcPointInBody(p, ws.q);
    ps.current.push_back(cp);
  }
  applyWrapObjects(i, ws);
  ps.length = calcLength(ps, path);
}

namespace {

/// Index in @p current of the tangent points of wrap @p w, or -1.
int findWrapPoints(const std::vector<CurrentPoint>& current, int w) {
  for (size_t j = 0; j < current.size(); ++j)
    if (current[j].point < 0 && current[j].wrap == w) return int(j);
  return -1;
}

void removeWrapPoints(std::vector<CurrentPoint>& current, int w) {
  const int j = findWrapPoints(current, w);
  if (j >= 0) current.erase(current.begin() + j, current.begin() + j + 2);
}

/// The wrap object of a current point, or -1 for a path point.
int wrapObjectOf(const CurrentPoint& p, const GeometryPath& path) {
  return p.point < 0 ? path.wraps[p.wrap].wrap_object : -1;
}

int statusCode(WrapStatus s) { return int(s); }

}  // namespace

void PathSet::applyWrapObjects(int i, PathWorkspace& ws) const {
  const GeometryPath& path = model_.muscles[i].path;
  PathWorkspace::PathState& ps = ws.paths[i];
  const int nw = int(path.wraps.size());
  if (nw < 1) return;
  std::vector<CurrentPoint>& cur = ps.current;
  for (int w = 0; w < nw; ++w) ps.order[w] = w;
  // One pass for a single wrap object; with several, up to eight passes, each starting from
  // the path the previous one left, until the length changes by less than 0.5 mm.
  const int max_iterations = nw < 2 ? 1 : 8;
  double last_length = std::numeric_limits<double>::infinity();
  const int np = int(path.points.size());
  for (int kk = 0; kk < max_iterations; ++kk) {
    for (int k = 0; k < nw; ++k) {
      ps.status[k] = statusCode(WrapStatus::NoWrap);
      const int w = ps.order[k];
      const model::PathWrap& pw = path.wraps[w];
      const model::WrapObject& wo = model_.wrap_objects[pw.wrap_object];
      removeWrapPoints(cur, w);
      if (!wo.active) continue;
      // The wrap's range of path points (1-based, -1 for the ends), narrowed to active points.
      const int wrap_start = pw.range_begin < 1 ? 0 : pw.range_begin - 1;
      const int wrap_end = pw.range_end < 1 ? np - 1 : pw.range_end - 1;
      int start = -1, end = -1;
      for (size_t j = 0; j < cur.size(); ++j) {
        const int pt = cur[j].point;
        if (pt >= wrap_start && pt <= wrap_end) {
          if (start < 0) start = int(j);
          end = int(j);
        }
      }
      if (start < 0) return;  // no active point in the range: OpenSim stops wrapping this path
      const Eigen::Isometry3d X_WG = ws.X_GW[pw.wrap_object].inverse();
      WrapResult best;
      int best_end = -1;
      double min_change = std::numeric_limits<double>::infinity();
      for (int pt1 = start; pt1 < end; ++pt1) {
        const int pt2 = pt1 + 1;
        const int o1 = wrapObjectOf(cur[pt1], path), o2 = wrapObjectOf(cur[pt2], path);
        if (o1 >= 0 && o1 == o2) continue;  // both tangent points of one object: on its surface
        WrapResult wr = ps.previous[w];
        const Vec3 p1 = X_WG * cur[pt1].p_G, p2 = X_WG * cur[pt2].p_G;
        const WrapStatus status = wrapSegment(wo, pw.method, p1, p2, wr);
        ps.status[k] = statusCode(status);
        if (status == WrapStatus::Mandatory) {
          best = wr;
          best_end = pt2;
          break;
        }
        if (status == WrapStatus::Wrapped) {
          const double change = (p1 - wr.r1).norm() + wr.length + (p2 - wr.r2).norm() - (p1 - p2).norm();
          if (change < min_change) {
            best = wr;
            best_end = pt2;
            min_change = change;
          }
        }
      }
      if (best_end < 0) {
        ps.previous[w] = WrapResult();
        continue;
      }
      best.has_previous = true;
      ps.previous[w] = best;
      CurrentPoint t1, t2;
      t1.body = t2.body = wo.body;
      t1.wrap = t2.wrap = w;
      t1.p_G = ws.X_GW[pw.wrap_object] * best.r1;
      t2.p_G = ws.X_GW[pw.wrap_object] * best.r2;
      t2.wrap_length = best.length;
      cur.insert(cur.begin() + best_end, t1);
      cur.insert(cur.begin() + best_end + 1, t2);
    }
    const double length = calcLength(ps, path);
    if (std::abs(length - last_length) < 0.0005) break;
    last_length = length;
    if (kk == 0 && nw > 1 && ps.status[0] == statusCode(WrapStatus::NoWrap) &&
        ps.status[1] == statusCode(WrapStatus::InsideRadius)) {
      // The first object did not wrap because the second put a point inside it: swap them.
      ps.order[0] = 1;
      ps.order[1] = 0;
      removeWrapPoints(cur, 0);
    }
  }
}

double PathSet::calcLength(const PathWorkspace::PathState& ps, const GeometryPath& path) const {
  double length = 0.0;
  for (size_t j = 0; j + 1 < ps.current.size(); ++j) {
    const CurrentPoint &a = ps.current[j], &b = ps.current[j + 1];
    const int oa = wrapObjectOf(a, path), ob = wrapObjectOf(b, path);
    if (oa >= 0 && oa == ob)
      length += b.wrap_length;
    else
      length += (b.p_G - a.p_G).norm();
  }
  return length;
}

void PathSet::calcGeneralizedForces(sim::Workspace& sws, PathWorkspace& ws, int i,
                                    Eigen::Ref<Eigen::VectorXd> g) const {
  ws.body_forces.setZero();
  ws.mobility.setZero();
  addLoads(ws, i, 1.0, ws.body_forces, ws.mobility);
  system_.calcGeneralizedForcesFromBodyForces(sws, ws.body_forces, g);
  g += ws.mobility;
}

void PathSet::addLoads(const PathWorkspace& ws, int i, double tension, sim::SpatialColumns& F,
                       Eigen::Ref<Eigen::VectorXd> mobility) const {
  const GeometryPath& path = model_.muscles[i].path;
  const std::vector<CurrentPoint>& cur = ws.paths[i].current;
  // A pull f at p: on the body, the force and its moment about the body's origin; a moving point
  // also does work through its own coordinates, f . dp/dq.
  auto apply = [&](const CurrentPoint& p, const Vec3& f) {
    F.col(p.body).head<3>() += (p.p_G - ws.X_GB[p.body].translation()).cross(f);
    F.col(p.body).tail<3>() += f;
    if (p.point < 0) return;
    const PathPoint& pp = path.points[p.point];
    if (pp.type != PathPointType::Moving) return;
    for (int k = 0; k < 3; ++k) {
      const int c = pp.location_coordinates[k];
      if (!pp.location_functions[k] || c < 0) continue;
      mobility[c] += f.dot(ws.X_GB[p.body].linear().col(k)) * pp.location_functions[k]->calcDerivative1(ws.q[c]);
    }
  };
  for (size_t j = 0; j + 1 < cur.size(); ++j) {
    const CurrentPoint &a = cur[j], &b = cur[j + 1];
    const int oa = wrapObjectOf(a, path), ob = wrapObjectOf(b, path);
    if (oa >= 0 && oa == ob) continue;  // along a wrap surface: internal to the wrap body
    Vec3 dir = b.p_G - a.p_G;
    const double len = dir.norm();
    // Coincident points (an end point inside a wrap surface): OpenSim's direction is NaN.
    dir = len < 1e-15 ? Vec3::Constant(std::numeric_limits<double>::quiet_NaN()) : Vec3(dir * (tension / len));
    apply(a, dir);
    apply(b, -dir);
  }
}

namespace {

/// Calls @p fn(coupler, x) for every coupler, x its independents' values, once per coupler per
/// pass: chains of couplers settle in at most one pass per coupler.
template <class Fn>
void sweepCouplers(const model::Model& model, const Eigen::VectorXd& q, Fn&& fn) {
  double x[8];
  for (size_t pass = 0; pass < model.couplers.size(); ++pass) {
    for (const model::CoordinateCoupler& cc : model.couplers) {
      const int na = int(cc.independents.size());
      KNEESIM_CHECK(na <= 8, "coupler with more than 8 independent coordinates");
      for (int k = 0; k < na; ++k) x[k] = q[cc.independents[k]];
      fn(cc, x);
    }
  }
}

}  // namespace

void calcCouplingMatrix(const model::Model& model, const Eigen::VectorXd& q, Eigen::Ref<Eigen::MatrixXd> C) {
  const int n = int(model.coordinates.size());
  KNEESIM_CHECK(C.rows() == n && C.cols() == n && q.size() == n, "coupling matrix size does not match the model");
  C.setIdentity();
  for (const model::CoordinateCoupler& cc : model.couplers) C.col(cc.dependent).setZero();
  // Each pass expresses dependent coordinates through their independents' columns.
  sweepCouplers(model, q, [&](const model::CoordinateCoupler& cc, const double* x) {
    C.row(cc.dependent).setZero();
    for (int k = 0; k < int(cc.independents.size()); ++k) {
      const int comp = k;
      const double df = cc.scale_factor * cc.function->calcDerivative(x, &comp, 1);
      C.row(cc.dependent) += df * C.row(cc.independents[k]);
    }
  });
}

void calcCouplingAcceleration(const model::Model& model, const Eigen::VectorXd& q, const Eigen::VectorXd& qdot,
                              Eigen::Ref<Eigen::VectorXd> d) {
  KNEESIM_CHECK(d.size() == q.size() && qdot.size() == q.size(), "coupling acceleration size does not match the model");
  d.setZero();
  sweepCouplers(model, q, [&](const model::CoordinateCoupler& cc, const double* x) {
    const int na = int(cc.independents.size());
    double a = 0.0;
    for (int i = 0; i < na; ++i) {
      const int ci = i;
      a += cc.function->calcDerivative(x, &ci, 1) * d[cc.independents[i]];
      for (int j = 0; j < na; ++j) {
        const int cij[2] = {i, j};
        a += cc.function->calcDerivative(x, cij, 2) * qdot[cc.independents[i]] * qdot[cc.independents[j]];
      }
    }
    d[cc.dependent] = cc.scale_factor * a;
  });
}

}  // namespace kneesim::muscle
