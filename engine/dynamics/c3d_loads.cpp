#include "dynamics/c3d_loads.hpp"

#include <cmath>
#include <filesystem>
#include <limits>

#include "core/atomic_file.hpp"
#include "core/strings.hpp"
#include "dynamics/lowpass.hpp"
#include "model/model.hpp"

namespace kneesim::dynamics {

namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string plateElement(int p) { return "FORCE_PLATFORM[" + std::to_string(p + 1) + "]"; }

/// The analog part of @p c3d with the plates' channels checked and low-passed: what
/// io::calcPlateWrench reads.
io::C3dFile filteredPlates(const io::C3dFile& c3d, double cutoff_hz) {
  io::C3dFile f;
  f.path = c3d.path;
  f.plates = c3d.plates;
  f.markers.original_units = c3d.markers.original_units;
  f.analog = c3d.analog;
  for (int p = 0; p < int(c3d.plates.size()); ++p) {
    const io::ForcePlate& fp = c3d.plates[p];
    if (fp.type != 2 && fp.type != 4)
      throw InputError({c3d.path, 0, plateElement(p) + "/TYPE"},
                       "expected a six-component plate of TYPE 2 or 4, got TYPE " + std::to_string(fp.type));
    if (fp.type == 4 && !fp.has_cal_matrix)
      throw InputError({c3d.path, 0, plateElement(p) + "/CAL_MATRIX"},
                       "expected a calibration matrix for a TYPE 4 plate, got none");
    for (int ch : fp.channels) {
      for (Eigen::Index s = 0; s < f.analog.data.rows(); ++s)
        if (!std::isfinite(f.analog.data(s, ch)))
          throw InputError({c3d.path, 0, "ANALOG[" + f.analog.labels[ch] + "]"},
                           "expected finite plate outputs, got " + formatSignificant(f.analog.data(s, ch), 6) +
                               " at t = " + formatSignificant(f.analog.time[s], 6) + " s");
      if (cutoff_hz < 0 || f.analog.data.rows() < 4) continue;
      std::vector<double> x(f.analog.data.rows());
      for (Eigen::Index s = 0; s < f.analog.data.rows(); ++s) x[s] = f.analog.data(s, ch);
      x = lowpassIIR(padOddReflection(x, int(x.size()) / 2), 1.0 / f.analog.rate, cutoff_hz);
      const int pad = int(f.analog.data.rows()) / 2;
      for (Eigen::Index s = 0; s < f.analog.data.rows(); ++s) f.analog.data(s, ch) = x[size_t(pad + s)];
    }
  }
  return f;
}

/// The unit normal of plate @p fp's surface and its offset along it (n . x = d on the surface).
void plateSurface(const io::ForcePlate& fp, Eigen::Vector3d& n, double& d) {
  const Eigen::Vector3d x = fp.corners_m.col(0) - fp.corners_m.col(1), y = fp.corners_m.col(0) - fp.corners_m.col(3);
  n = x.cross(y).normalized();
  d = n.dot(fp.corners_m.rowwise().mean());
}

/// Mean position of @p foot's markers over [t0, t1] (frames where they are present), or false.
bool meanFootPosition(const io::C3dFile& c3d, const std::vector<int>& markers, double t0, double t1, Eigen::Vector3d& out) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  const io::MarkerTable& m = c3d.markers;
  for (int f = 0; f < m.getNumFrames(); ++f) {
    if (m.time[f] < t0 || m.time[f] > t1) continue;
    for (int k : markers)
      if (!m.isMissing(f, k)) {
        sum += m.getPosition(f, k);
        ++n;
      }
  }
  if (n == 0) return false;
  out = sum / n;
  return true;
}

/// The loaded stretches [first, last] (sample indices) of a plate: where its centre of pressure exists.
std::vector<std::pair<int, int>> loadedStretches(const io::PlateWrench& w) {
  std::vector<std::pair<int, int>> v;
  for (int s = 0; s < int(w.cop.size()); ++s) {
    if (!w.cop[s].allFinite()) continue;
    if (v.empty() || v.back().second != s - 1) v.push_back({s, s});
    v.back().second = s;
  }
  return v;
}

/// The filtered plates' wrenches, which foot each plate sample goes to (-1: none) and the floor
/// (the first plate's surface, n . p = d).
struct PlateOwners {
  std::vector<io::PlateWrench> wrench;
  std::vector<std::vector<int>> owner;  // foot per plate sample
  Eigen::Vector3d floor_n = Eigen::Vector3d::UnitZ();
  double floor_d = 0;
};

/// Each loaded stretch of each plate goes to the foot whose markers are closest to its centre of
/// pressure, measured along the plate's surface; the choices go to @p assignments.
PlateOwners assignPlates(const io::C3dFile& c3d, const io::C3dFile& f, const PlateLoadOptions& options,
                         const std::vector<std::vector<int>>& foot_markers, std::vector<PlateAssignment>& assignments) {
  const int np = int(f.plates.size()), ns = int(f.analog.data.rows()), nf = int(options.feet.size());
  PlateOwners o;
  o.wrench.resize(np);
  o.owner.assign(np, std::vector<int>(size_t(ns), -1));
  for (int p = 0; p < np; ++p) {
    o.wrench[p] = io::calcPlateWrench(f, p, options.threshold_n);
    Eigen::Vector3d n;
    double d;
    plateSurface(f.plates[p], n, d);
    if (p == 0) o.floor_n = n, o.floor_d = d;
    for (const auto& [a, b] : loadedStretches(o.wrench[p])) {
      Eigen::Vector3d cop = Eigen::Vector3d::Zero();
      for (int s = a; s <= b; ++s) cop += o.wrench[p].cop[s];
      cop /= (b - a + 1);
      int best = -1;
      double best_d = std::numeric_limits<double>::infinity();
      for (int k = 0; k < nf; ++k) {
        Eigen::Vector3d m;
        if (!meanFootPosition(c3d, foot_markers[k], f.analog.time[a], f.analog.time[b], m)) continue;
        Eigen::Vector3d r = m - cop;
        r -= r.dot(n) * n;
        if (r.norm() < best_d) best_d = r.norm(), best = k;
      }
      if (best < 0)
        throw InputError({c3d.path, 0, plateElement(p)}, "expected foot markers during the plate's load at " +
                                                             formatSignificant(f.analog.time[a], 4) + "-" +
                                                             formatSignificant(f.analog.time[b], 4) + " s, got none");
      for (int s = a; s <= b; ++s) o.owner[p][s] = best;
      assignments.push_back({p, f.analog.time[a], f.analog.time[b], options.feet[best].name, best_d});
    }
  }
  return o;
}

/// Foot @p k's columns of @p g: the sum of its plates' wrenches about the lab origin, re-expressed
/// as a force at a point of the floor plus a free moment about its normal: with M = p x F + T n and
/// n . p = d, n x M = (n . F) p - d F, so p = (n x M + d F) / (n . F) and T = n . (M - p x F).
void writeFootWrench(const PlateOwners& o, int k, const Eigen::Matrix3d& R_GL, double threshold_n, io::Storage& g) {
  const int np = int(o.wrench.size()), ns = int(g.data.rows());
  std::vector<bool> loaded(size_t(ns), false);
  for (int s = 0; s < ns; ++s) {
    Eigen::Vector3d F = Eigen::Vector3d::Zero(), M = Eigen::Vector3d::Zero();
    for (int p = 0; p < np; ++p) {
      if (o.owner[p][s] != k) continue;
      F += o.wrench[p].force[s];
      M += o.wrench[p].cop[s].cross(o.wrench[p].force[s]) + o.wrench[p].free_moment[s];
    }
    const double Fn = o.floor_n.dot(F);
    if (!(std::abs(Fn) >= threshold_n)) continue;
    const Eigen::Vector3d p = (o.floor_n.cross(M) + o.floor_d * F) / Fn;
    const Eigen::Vector3d T = o.floor_n.dot(M - p.cross(F)) * o.floor_n;
    g.data.block<1, 3>(s, 1 + 9 * k) = (R_GL * F).transpose();
    g.data.block<1, 3>(s, 4 + 9 * k) = (R_GL * p).transpose();
    g.data.block<1, 3>(s, 7 + 9 * k) = (R_GL * T).transpose();
    loaded[s] = true;
  }
  // Unloaded samples keep the nearest earlier (else later) centre of pressure, so that the
  // splines ExternalForce fits through the points do not swing between the floor's origin and
  // the foot where the force is small.
  int last = -1;
  for (int s = 0; s < ns; ++s) {
    if (loaded[s]) {
      if (last < 0)
        for (int b = 0; b < s; ++b) g.data.block<1, 3>(b, 4 + 9 * k) = g.data.block<1, 3>(s, 4 + 9 * k);
      last = s;
    } else if (last >= 0) {
      g.data.block<1, 3>(s, 4 + 9 * k) = g.data.block<1, 3>(last, 4 + 9 * k);
    }
  }
}

/// The ExternalLoads that apply each foot's columns to its body (feet without a body are left out).
ExternalLoadsSpec footLoads(const io::C3dFile& c3d, const PlateLoadOptions& options, const std::string& name) {
  ExternalLoadsSpec loads;
  loads.name = name;
  loads.datafile = c3d.path + " (force plates)";
  loads.datafile_where = {c3d.path, 0, ""};
  for (const FootSpec& foot : options.feet) {
    if (foot.body.empty()) continue;
    ExternalForceSpec e;
    e.name = foot.name + "_ground_reaction";
    e.applied_to_body = foot.body;
    e.force_identifier = foot.name + "_ground_force_v";
    e.point_identifier = foot.name + "_ground_force_p";
    e.torque_identifier = foot.name + "_ground_torque_";
    e.where = foot.where;
    for (const char* tag : {"applied_to_body", "force_identifier", "point_identifier", "torque_identifier"})
      e.elements[tag] = foot.where;
    loads.forces.push_back(e);
  }
  return loads;
}

}  // namespace

GroundReactions calcGroundReactions(const io::C3dFile& c3d, const PlateLoadOptions& options) {
  if (options.feet.empty()) throw InputError({c3d.path, 0, ""}, "expected at least one foot to assign the plates to, got none");
  const io::C3dFile f = filteredPlates(c3d, options.cutoff_hz);
  const int ns = int(f.analog.data.rows()), nf = int(options.feet.size());
  std::vector<std::vector<int>> foot_markers(nf);
  for (int k = 0; k < nf; ++k)
    for (const std::string& name : options.feet[k].markers) {
      const int m = c3d.markers.findMarker(name);
      if (m < 0) throw InputError(options.feet[k].where, "expected marker '" + name + "' in " + c3d.path + ", not found");
      foot_markers[k].push_back(m);
    }
  GroundReactions out;
  const PlateOwners owners = assignPlates(c3d, f, options, foot_markers, out.assignments);

  const Eigen::Matrix3d R_GL = model::poseFromXYZ(options.rotation_deg * M_PI / 180.0, Eigen::Vector3d::Zero()).linear();
  io::Storage& g = out.grf;
  g.name = fs::path(c3d.path).stem().string() + "_grf";
  g.labels = {"time"};
  for (const FootSpec& foot : options.feet)
    for (const char* part : {"_ground_force_v", "_ground_force_p", "_ground_torque_"})
      for (const char* axis : {"x", "y", "z"}) g.labels.push_back(foot.name + part + axis);
  g.data.setZero(ns, 1 + 9 * nf);
  for (int s = 0; s < ns; ++s) g.data(s, 0) = f.analog.time[s];
  for (int k = 0; k < nf; ++k) writeFootWrench(owners, k, R_GL, options.threshold_n, g);
  out.loads = footLoads(c3d, options, g.name);
  return out;
}

void stageGroundReactions(const GroundReactions& grf, const std::string& mot_path, const std::string& xml_path,
                          AtomicFileSet& out) {
  out.addContents(mot_path, io::formatStorage(grf.grf));
  const fs::path rel = fs::path(mot_path).lexically_relative(fs::path(xml_path).parent_path());
  out.addContents(xml_path, formatExternalLoads(grf.loads, rel.empty() ? mot_path : rel.string()));
}

}  // namespace kneesim::dynamics
