// Force platforms of C3D files: reading FORCE_PLATFORM's plate descriptions, and the ground
// reaction (force, centre of pressure, free moment) of a six-component plate in the lab frame.

#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "core/error.hpp"
#include "core/strings.hpp"
#include "io/c3d_detail.hpp"

namespace kneesim::io {

namespace detail {

void readForcePlates(C3dFile& out, int nch, double to_m) {
  auto fail = [&](const std::string& element, const std::string& msg) -> void {
    throw InputError({out.path, 0, element}, msg);
  };
  const int nplates = int(firstWhole(out, "FORCE_PLATFORM", "USED", 0, -32768, 65535));
  if (nplates > 0) {
    const C3dParameter* pt = out.findParameter("FORCE_PLATFORM", "TYPE");
    const C3dParameter* pc = out.findParameter("FORCE_PLATFORM", "CORNERS");
    const C3dParameter* po = out.findParameter("FORCE_PLATFORM", "ORIGIN");
    const C3dParameter* pch = out.findParameter("FORCE_PLATFORM", "CHANNEL");
    const C3dParameter* pcal = out.findParameter("FORCE_PLATFORM", "CAL_MATRIX");
    auto require = [&](const C3dParameter* p, const char* name, size_t n) {
      if (!p) fail(std::string("FORCE_PLATFORM:") + name, "expected this parameter for FORCE_PLATFORM:USED = " +
                                                              std::to_string(nplates) + " plates, not found");
      if (p->values.size() < n)
        fail(std::string("FORCE_PLATFORM:") + name, "expected at least " + std::to_string(n) + " values for " +
                                                        std::to_string(nplates) + " plates, got " +
                                                        std::to_string(p->values.size()));
    };
    require(pt, "TYPE", size_t(nplates));
    require(pc, "CORNERS", size_t(12 * nplates));
    require(po, "ORIGIN", size_t(3 * nplates));
    require(pch, "CHANNEL", size_t(nplates));
    const size_t per_plate = pch->dims.empty() ? 1 : size_t(pch->dims[0]);
    require(pch, "CHANNEL", per_plate * size_t(nplates));
    for (int p = 0; p < nplates; ++p) {
      ForcePlate fp;
      fp.type = int(toWhole(out, pt->values[size_t(p)], -32768, 65535, "FORCE_PLATFORM:TYPE"));
      for (int k = 0; k < 4; ++k)
        for (int j = 0; j < 3; ++j) fp.corners_m(j, k) = pc->values[size_t(12 * p + 3 * k + j)] * to_m;
      for (int j = 0; j < 3; ++j) fp.origin_m[j] = po->values[size_t(3 * p + j)] * to_m;
      for (size_t k = 0; k < per_plate; ++k) {
        const double chn = pch->values[size_t(p) * per_plate + k];
        if (!(chn >= 1 && chn < nch + 1.0))  // NaN too; checked before it becomes an integer
          fail("FORCE_PLATFORM:CHANNEL", "plate " + std::to_string(p + 1) + ": expected analog channel numbers 1.." +
                                             std::to_string(nch) + ", got " + formatSignificant(chn, 6));
        fp.channels.push_back(int(chn) - 1);
      }
      fp.cal_matrix.setIdentity();
      if (pcal && pcal->dims.size() >= 2 && pcal->dims[0] == 6 && pcal->dims[1] == 6 &&
          pcal->values.size() >= size_t(36 * (p + 1))) {
        for (int j = 0; j < 6; ++j)
          for (int i = 0; i < 6; ++i) fp.cal_matrix(i, j) = pcal->values[size_t(36 * p + 6 * j + i)];
        fp.has_cal_matrix = true;
      }
      out.plates.push_back(fp);
    }
  }
}

}  // namespace detail

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double forceUnitToNewtons(const std::string& u) {
  std::string s;
  for (char ch : toLower(trim(u)))
    if (ch != ' ' && ch != '.' && ch != '*' && ch != '-' && ch != '_') s += ch;
  if (s.empty() || s == "n") return 1.0;
  if (s == "kn") return 1000.0;
  if (s == "lbf" || s == "lb") return 4.4482216152605;
  return 0.0;
}

double momentUnitToNewtonMetres(const std::string& u, double default_scale) {
  std::string s;
  for (char ch : toLower(trim(u)))
    if (ch != ' ' && ch != '.' && ch != '*' && ch != '-' && ch != '_') s += ch;
  if (s.empty()) return default_scale;
  if (s == "nmm" || s == "mmn") return 1e-3;
  if (s == "nm" || s == "mn") return 1.0;
  if (s == "ncm") return 1e-2;
  if (s == "knm") return 1e3;
  return 0.0;
}

}  // namespace

PlateWrench calcPlateWrench(const C3dFile& c3d, int plate, double min_normal_force) {
  const std::string element = "FORCE_PLATFORM[" + std::to_string(plate + 1) + "]";
  if (plate < 0 || plate >= int(c3d.plates.size()))
    throw InputError({c3d.path, 0, element}, "expected a plate index 0.." + std::to_string(int(c3d.plates.size()) - 1) +
                                                 ", got " + std::to_string(plate));
  const ForcePlate& fp = c3d.plates[size_t(plate)];
  if (fp.type != 2 && fp.type != 4)
    throw InputError({c3d.path, 0, element}, "expected force-plate type 2 or 4 (six-component), got type " + std::to_string(fp.type));
  if (fp.channels.size() < 6)
    throw InputError({c3d.path, 0, element}, "expected 6 channels (Fx Fy Fz Mx My Mz), got " + std::to_string(fp.channels.size()));
  const AnalogTable& a = c3d.analog;

  // Units per channel.
  const double length_default = c3d.markers.original_units == "m" ? 1.0 : c3d.markers.original_units == "cm" ? 1e-2 : 1e-3;
  double unit[6];
  for (int k = 0; k < 6; ++k) {
    const int ch = fp.channels[size_t(k)];
    const std::string u = size_t(ch) < a.units.size() ? a.units[size_t(ch)] : std::string();
    unit[k] = k < 3 ? forceUnitToNewtons(u) : momentUnitToNewtonMetres(u, length_default);
    if (unit[k] == 0)
      throw InputError({c3d.path, 0, "ANALOG:UNITS[" + a.labels[size_t(ch)] + "]"},
                       std::string("expected a ") + (k < 3 ? "force unit N, kN or lbf" : "moment unit N mm or N m") +
                           ", got '" + u + "'");
  }

  // Plate frame from the corners.
  const Eigen::Vector3d c1 = fp.corners_m.col(0), c2 = fp.corners_m.col(1), c4 = fp.corners_m.col(3);
  Eigen::Vector3d x = c1 - c2;
  const Eigen::Vector3d y0 = c1 - c4;
  Eigen::Vector3d z = x.cross(y0);
  if (!(x.norm() > 0) || !(z.norm() > 0))
    throw InputError({c3d.path, 0, element + "/CORNERS"}, "expected four corners spanning a plane, got a degenerate plate");
  x.normalize();
  z.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R_LP;
  R_LP.col(0) = x;
  R_LP.col(1) = y;
  R_LP.col(2) = z;
  const Eigen::Vector3d p_LC = fp.corners_m.rowwise().mean();  // centre of the working surface
  Eigen::Vector3d r_OC = fp.origin_m;                          // sensor origin -> surface centre, plate frame
  if (r_OC.z() > 0) r_OC = -r_OC;

  PlateWrench w;
  const Eigen::Index n = a.data.rows();
  w.force.resize(size_t(n));
  w.cop.resize(size_t(n));
  w.free_moment.resize(size_t(n));
  const Eigen::Vector3d nan3(kNaN, kNaN, kNaN);
  for (Eigen::Index s = 0; s < n; ++s) {
    Eigen::Matrix<double, 6, 1> raw;
    for (int k = 0; k < 6; ++k) raw[k] = a.data(s, fp.channels[size_t(k)]) * unit[k];
    if (fp.type == 4) raw = fp.cal_matrix * raw;
    const Eigen::Vector3d F = raw.head<3>();
    // Moment about the surface centre C: M_C = M_O + (O - C) x F = M_O + F x r_OC.
    const Eigen::Vector3d M_C = raw.tail<3>() + F.cross(r_OC);
    w.force[size_t(s)] = R_LP * F;
    if (!(std::fabs(F.z()) >= min_normal_force)) {
      w.cop[size_t(s)] = nan3;
      w.free_moment[size_t(s)] = nan3;
      continue;
    }
    // A force F at p = (px, py, 0) from C plus a free moment Tz about the normal gives
    // M_C = p x F + Tz e_z, so px = -My/Fz, py = Mx/Fz, Tz = Mz - (px Fy - py Fx).
    const double px = -M_C.y() / F.z();
    const double py = M_C.x() / F.z();
    const double tz = M_C.z() - (px * F.y() - py * F.x());
    w.cop[size_t(s)] = p_LC + R_LP * Eigen::Vector3d(px, py, 0.0);
    w.free_moment[size_t(s)] = R_LP * Eigen::Vector3d(0.0, 0.0, tz);
  }
  return w;
}

}  // namespace kneesim::io
