#include "gap/trial_inputs.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <set>

#include "core/paths.hpp"
#include "core/strings.hpp"
#include "gap/signals.hpp"
#include "io/c3d.hpp"
#include "io/knee_forces.hpp"
#include "io/storage.hpp"

namespace kneesim::gap {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string fmt(double v, int digits = 4) { return formatSignificant(v, digits); }

double percentileOf(std::vector<double> v, double q) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double pos = q * (v.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  return i + 1 < v.size() ? v[i] + (pos - i) * (v[i + 1] - v[i]) : v[i];
}

double frameRate(const std::vector<double>& t) {
  return t.size() > 1 ? (t.size() - 1) / (t.back() - t.front()) : 120.0;
}

// Columns of a storage interpolated onto `at` (tolerance half a frame of the storage).
std::vector<double> storageColumn(const io::Storage& s, int col, const std::vector<double>& at) {
  std::vector<double> t(s.getNumRows()), x(s.getNumRows());
  const int tc = s.findColumn("time");
  for (int i = 0; i < s.getNumRows(); ++i) {
    t[i] = s.data(i, tc);
    x[i] = s.data(i, col);
  }
  const double tol = t.size() > 1 ? 0.5 * (t.back() - t.front()) / (t.size() - 1) : 0.0;
  return interpolate(t, x, at, tol);
}

std::string stripPrefix(const std::string& label) {
  const size_t c = label.rfind(':');
  return c == std::string::npos ? label : label.substr(c + 1);
}

// Mean position (x, y) of the markers whose names (without subject prefix) are in `names` over
// the analog-time interval [t0, t1]; false if none is seen.
bool meanMarkerPosition(const io::C3dFile& c, const std::vector<std::string>& names, double t0, double t1,
                        Eigen::Vector2d& out) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  int count = 0;
  for (const auto& nm : names) {
    int m = -1;
    for (int k = 0; k < c.markers.getNumMarkers(); ++k)
      if (stripPrefix(c.markers.labels[k]) == nm) m = k;
    if (m < 0) continue;
    for (int f = 0; f < c.markers.getNumFrames(); ++f) {
      if (c.markers.time[f] < t0 || c.markers.time[f] > t1 || c.markers.isMissing(f, m)) continue;
      sum += c.markers.getPosition(f, m).head<2>();
      ++count;
    }
  }
  if (count == 0) return false;
  out = sum / count;
  return true;
}

}  // namespace

ActivityDefinition getActivityDefinition(const std::string& name) {
  const std::string n = toLower(name);
  if (n == "gait" || n == "walk" || n == "walking")
    return {"gait", 0.62,
            {{"loading response", 0.0, 0.12}, {"mid-stance", 0.12, 0.31}, {"terminal stance", 0.31, 0.50},
             {"pre-swing", 0.50, 0.62}, {"swing", 0.62, 1.0}}};
  if (n == "stair" || n == "stairs" || n == "stair ascent")
    return {"stair", 0.64,
            {{"weight acceptance", 0.0, 0.14}, {"pull-up", 0.14, 0.32}, {"forward continuance", 0.32, 0.64},
             {"foot clearance", 0.64, 0.82}, {"foot placement", 0.82, 1.0}}};
  if (n == "chair" || n == "chair rise" || n == "sit-to-stand")
    return {"chair", 0.5, {{"rise", 0.0, 0.25}, {"standing", 0.25, 0.5}, {"sit-down", 0.5, 0.8}, {"seated", 0.8, 1.0}}};
  return {name, 0.5, {{"first quarter", 0, 0.25}, {"second quarter", 0.25, 0.5}, {"third quarter", 0.5, 0.75},
                      {"fourth quarter", 0.75, 1.0}}};
}

const std::vector<double>& getChannel(const GapTrial& trial, const std::string& name) {
  auto it = trial.trial.channels.find(name);
  KNEESIM_CHECK(it != trial.trial.channels.end(), "trial '" + trial.trial.name + "' has no channel '" + name + "'");
  return it->second;
}

std::vector<double> findCrossings(const std::vector<double>& t, const std::vector<double>& x, double level,
                                  double hysteresis, bool up, double min_separation) {
  std::vector<double> out;
  // armed: the signal has been on the far side of level -/+ hysteresis since the last crossing.
  bool armed = false;
  for (size_t i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i])) continue;
    const double s = up ? x[i] - level : level - x[i];  // > 0 past the level in the crossing sense
    if (s <= -hysteresis) armed = true;
    if (armed && s >= 0 && i > 0 && std::isfinite(x[i - 1])) {
      const double sp = up ? x[i - 1] - level : level - x[i - 1];
      const double f = sp < 0 && s > sp ? -sp / (s - sp) : 0.0;
      const double tc = t[i - 1] + f * (t[i] - t[i - 1]);
      if (out.empty() || tc - out.back() >= min_separation) out.push_back(tc);
      armed = false;
    }
  }
  return out;
}

void setCycles(GapTrial& g, const std::vector<double>& starts_in, const std::vector<double>& mids_in) {
  const std::vector<double>& t = g.trial.time;
  const int n = static_cast<int>(t.size());
  KNEESIM_CHECK(n > 0, "setCycles on an empty trial");
  const double t0 = t.front(), t1 = t.back();
  std::vector<double> starts;
  for (double s : starts_in)
    if (s > t0 && s <= t1) starts.push_back(s);
  std::sort(starts.begin(), starts.end());
  std::vector<double> mids(mids_in.begin(), mids_in.end());
  std::sort(mids.begin(), mids.end());
  const ActivityDefinition act = getActivityDefinition(g.activity);

  // Typical duration: the median complete cycle; else from a start and the following middle event.
  std::vector<double> durations;
  for (size_t k = 0; k + 1 < starts.size(); ++k) durations.push_back(starts[k + 1] - starts[k]);
  double typical = kNaN;
  if (!durations.empty()) {
    typical = percentileOf(durations, 0.5);
  } else {
    for (double s : starts)
      for (double m : mids)
        if (m > s && std::isnan(typical)) typical = (m - s) / act.mid_fraction;
    if (std::isnan(typical)) typical = t1 - t0;
  }
  auto midIn = [&](double a, double b) {
    for (double m : mids)
      if (m > a && m < b) return m;
    return kNaN;
  };
  g.cycles.clear();
  if (starts.empty()) {
    Cycle c;
    c.start = t0;
    c.end = t0 + std::max(typical, t1 - t0);
    c.start_estimated = c.end_estimated = true;
    c.mid = midIn(t0, t1);
    g.cycles.push_back(c);
  } else {
    if (t0 < starts.front()) {
      Cycle c;
      c.end = starts.front();
      c.start = c.end - typical;
      c.start_estimated = true;
      c.mid = midIn(c.start, c.end);
      g.cycles.push_back(c);
    }
    for (size_t k = 0; k < starts.size(); ++k) {
      Cycle c;
      c.start = starts[k];
      if (k + 1 < starts.size()) {
        c.end = starts[k + 1];
      } else {
        c.end = c.start + typical;
        c.end_estimated = true;
      }
      c.mid = midIn(c.start, c.end);
      g.cycles.push_back(c);
    }
  }
  g.cycle_phase.assign(n, 0.0);
  g.cycle_index.assign(n, 0);
  size_t k = 0;
  std::vector<bool> seen(g.cycles.size(), false);
  for (int i = 0; i < n; ++i) {
    while (k + 1 < g.cycles.size() && t[i] >= g.cycles[k + 1].start) ++k;
    Cycle& c = g.cycles[k];
    if (!seen[k]) {
      c.begin_time = t[i];
      seen[k] = true;
    }
    c.end_time = t[i];
    double phi;
    if (std::isfinite(c.mid)) {
      const double m = act.mid_fraction;
      phi = t[i] < c.mid ? m * (t[i] - c.start) / (c.mid - c.start)
                         : m + (1 - m) * (t[i] - c.mid) / std::max(c.end - c.mid, 1e-9);
    } else {
      phi = (t[i] - c.start) / (c.end - c.start);
    }
    // Before an extrapolated start (a long wait before the first event) the frame belongs to no
    // cycle position: NaN, left out of cycle-normalised statistics.
    g.cycle_phase[i] = phi < -1e-9 ? std::numeric_limits<double>::quiet_NaN()
                                   : std::clamp(phi, 0.0, std::nextafter(1.0, 0.0));
    g.cycle_index[i] = static_cast<int>(k);
  }
}

namespace {

// What one trial's files hold, read once.
struct TrialFiles {
  io::KneeForces kf;
  io::C3dFile c3d;
  io::Storage area, motion;
  bool have_forces = false, have_c3d = false, have_motion = false;
};

std::string trialWho(const TrialSource& src) { return "trial '" + src.name + "'"; }

// Checks that the trial's files exist (a missing one names the setup element that led to it: the
// readers would name only the path) and reads them; the knee forces re-timed to the C3D's frames.
TrialFiles readTrialFiles(const TrialSource& src, GapTrial& g) {
  const SourceLocation& where = src.where;
  const std::string who = trialWho(src);
  if (src.contact_area.empty())
    throw InputError(where, who + ": expected a contact-area .sto (the contact-area tool's output), got none");
  auto requireFile = [&](const std::string& path, const char* element, const char* what) {
    if (!path.empty() && !pathExists(path))
      throw InputError({where.file, where.line, where.element + "/" + element},
                       who + ": " + what + " not found: " + path);
  };
  requireFile(src.knee_forces, "knee_forces", "knee-force file");
  requireFile(src.c3d, "c3d", "C3D file");
  requireFile(src.contact_area, "contact_area", "contact-area file");
  requireFile(src.kinematics, "kinematics", "kinematics file");
  requireFile(src.knee_loads, "knee_loads", "knee-load file");
  TrialFiles f;
  // Without a knee-force file the trial has no measured force (NaN): it can be predicted, not diagnosed.
  f.have_forces = !src.knee_forces.empty();
  if (f.have_forces) f.kf = io::readKneeForces(src.knee_forces);
  f.have_c3d = !src.c3d.empty();
  if (f.have_c3d) {
    f.c3d = io::readC3d(src.c3d);
    if (f.have_forces) {
      f.kf = io::retimeToFrames(f.kf, f.c3d.first_frame, f.c3d.header.frame_rate);
      g.notes.push_back("knee forces re-timed to the frames of " + src.c3d);
    }
  }
  f.area = io::readStorage(src.contact_area);
  const io::Storage& area = f.area;
  if (area.findColumn("time") < 0 || area.findColumn("S") < 0 || area.getNumRows() < 2)
    throw InputError({src.contact_area, 0, ""}, "contact-area file: expected columns time and S, got " +
                                                     std::to_string(area.labels.size()) + " column(s) and " +
                                                     std::to_string(area.getNumRows()) + " row(s)");
  const Eigen::VectorXd s_col = area.getColumn("S");
  if (s_col.maxCoeff() > 0.1)
    throw InputError({src.contact_area, 0, "S"}, "contact area: expected m^2 (peaks near 1e-3), got a peak of " +
                                                     fmt(s_col.maxCoeff()) + " (mm^2?)");
  for (const auto& [k, v] : area.header)
    if (k == "kneesim_interim" && v != "false" && v != "0") g.interim_inputs = true;
  if (g.interim_inputs)
    g.notes.push_back("INTERIM contact areas (" + src.contact_area +
                      "): a stand-in derived from the measured force, not the contact-area tool's output");
  f.have_motion = !src.kinematics.empty();
  if (f.have_motion) f.motion = io::readStorage(src.kinematics);
  return f;
}

// The common time base: the knee-force frames (else the area file's) inside every source's range.
// Returns the interpolation tolerance (half a frame).
double setTimeBase(const TrialSource& src, const TrialFiles& f, GapTrial& g) {
  const io::Storage& area = f.area;
  const double at0 = area.data(0, area.findColumn("time")),
               at1 = area.data(area.getNumRows() - 1, area.findColumn("time"));
  std::vector<double> frames_in;
  if (f.have_forces) {
    frames_in = f.kf.time;
  } else {
    for (int i = 0; i < area.getNumRows(); ++i) frames_in.push_back(area.data(i, area.findColumn("time")));
    g.notes.push_back("no knee-force file: frames of the contact-area file, no measured force (prediction only)");
  }
  double lo = std::max({at0, frames_in.front(), src.time_range.begin});
  double hi = std::min({at1, frames_in.back(), src.time_range.end});
  if (f.have_motion) {
    lo = std::max(lo, f.motion.data(0, f.motion.findColumn("time")));
    hi = std::min(hi, f.motion.data(f.motion.getNumRows() - 1, f.motion.findColumn("time")));
  }
  const double half = 0.5 / frameRate(frames_in);
  for (double x : frames_in)
    if (x >= lo - half && x <= hi + half) g.trial.time.push_back(x);
  if (g.trial.time.size() < 10)
    throw InputError(src.where, trialWho(src) + ": expected the " + (f.have_forces ? "knee forces" : "frames") + " (" +
                                    fmt(frames_in.front()) + "-" + fmt(frames_in.back()) +
                                    " s), the contact areas (" + fmt(at0) + "-" + fmt(at1) + " s)" +
                                    (f.have_motion ? ", the kinematics" : std::string()) +
                                    " and the time range to overlap by at least 10 frames, got " +
                                    std::to_string(g.trial.time.size()));
  return half;
}

// The storage's columns named @p prefix* (every column but time when empty) as channels at the
// trial's frames, each finite there.
void addStorageChannels(const io::Storage& st, const std::string& file, const std::string& prefix, GapTrial& g) {
  const std::vector<double>& t = g.trial.time;
  for (size_t c = 0; c < st.labels.size(); ++c) {
    const std::string& lab = st.labels[c];
    if (lab == "time" || lab.rfind(prefix, 0) != 0) continue;
    std::vector<double> v = storageColumn(st, static_cast<int>(c), t);
    if (lab == "knee_flexion" && st.in_degrees)
      for (double& x : v) x *= M_PI / 180;
    for (double x : v)
      if (!std::isfinite(x))
        throw InputError({file, 0, lab}, "column '" + lab + "': expected finite values over " + fmt(t.front()) +
                                             "-" + fmt(t.back()) + " s, got NaN");
    g.trial.channels[lab] = std::move(v);
  }
}

// Every column of the contact-area file, the knee's net loads, the threshold and the areas' rates.
void addAreaChannels(const TrialSource& src, const TrialFiles& f, GapTrial& g) {
  auto& ch = g.trial.channels;
  const std::vector<double>& t = g.trial.time;
  const int n = static_cast<int>(t.size());
  const double rate = frameRate(t);
  addStorageChannels(f.area, src.contact_area, "", g);
  if (!src.knee_loads.empty()) addStorageChannels(io::readStorage(src.knee_loads), src.knee_loads, "knee_", g);
  for (const auto& [k, v] : f.area.header)
    if (k == "threshold" || k == "threshold_m") {
      double h;
      if (tryParseDouble(v, h)) ch["S_threshold"] = std::vector<double>(n, h);
    }
  for (const char* s : {"S", "S_medial", "S_lateral"}) {
    if (!ch.count(s)) continue;
    const std::string d = std::string(s) == "S" ? "dS_dt" : "d" + std::string(s) + "_dt";
    if (!ch.count(d)) {
      ch[d] = derivative(t, lowPass(ch[s], rate, std::min(10.0, 0.45 * rate)));
      g.notes.push_back(d + ": derivative of " + s + " low-passed at 10 Hz (not in the contact-area file)");
    }
  }
}

// knee_flexion from the chosen source (the area file, the kinematics or the goniometer).
void addFlexion(const TrialSource& src, const TrialFiles& f, double half, GapTrial& g) {
  const SourceLocation& where = src.where;
  const std::string who = trialWho(src);
  auto& ch = g.trial.channels;
  const std::vector<double>& t = g.trial.time;
  std::string fsrc = src.flexion_source;
  if (fsrc == "auto") fsrc = ch.count("knee_flexion") ? "area" : f.have_motion ? "kinematics" : "gon";
  if (fsrc == "area") {
    if (!ch.count("knee_flexion"))
      throw InputError(where, who + ": flexion source 'area': expected a knee_flexion column in " + src.contact_area);
    g.notes.push_back("knee_flexion from the contact-area file");
  } else if (fsrc == "kinematics") {
    if (!f.have_motion) throw InputError(where, who + ": flexion source 'kinematics': expected a kinematics file, got none");
    const int c = f.motion.findColumn(src.flexion_column);
    if (c < 0)
      throw InputError({src.kinematics, 0, ""}, "kinematics: expected a column '" + src.flexion_column + "', got " +
                                                    std::to_string(f.motion.labels.size()) + " other columns");
    std::vector<double> v = storageColumn(f.motion, c, t);
    if (f.motion.in_degrees)
      for (double& x : v) x *= M_PI / 180;
    ch["knee_flexion"] = v;
    g.notes.push_back("knee_flexion from " + src.kinematics + " column " + src.flexion_column);
  } else if (fsrc == "gon") {
    if (!f.have_forces)
      throw InputError(where, who + ": flexion source 'gon': expected a knee-force file with its GON column, got none");
    std::vector<double> gon = interpolate(f.kf.time, f.kf.goniometer, t, half);
    for (double x : gon)
      if (!std::isfinite(x))
        throw InputError({src.knee_forces, 0, "GON"}, who + ": flexion from GON: expected a GON column, got none or NaN");
    std::string note;
    gon = io::calcKneeFlexionDeg(gon, src.goniometer, &note);
    g.notes.push_back(note);
    for (double& x : gon) x *= M_PI / 180;
    ch["knee_flexion"] = gon;
  } else {
    throw InputError(where, who + ": flexion source: expected auto, area, kinematics or gon, got '" + fsrc + "'");
  }
}

// Channels derived from the flexion: trial_time, the flexion rate and, where the area file has no
// exact ones, dS/dflexion estimated from the rates. Returns the low-passed flexion (for the events).
std::vector<double> addFlexionDerived(GapTrial& g) {
  auto& ch = g.trial.channels;
  const std::vector<double>& t = g.trial.time;
  const int n = static_cast<int>(t.size());
  const double rate = frameRate(t);
  // Time since the recording's first frame: a drift over the recording, whichever cycles a fit sees.
  std::vector<double> since(n);
  for (int i = 0; i < n; ++i) since[i] = t[i] - t.front();
  ch["trial_time"] = std::move(since);
  std::vector<double> flex_smooth = lowPass(ch["knee_flexion"], rate, std::min(6.0, 0.45 * rate));
  ch["knee_flexion_rate"] = derivative(t, flex_smooth);
  for (const std::string side : {"", "_medial", "_lateral"}) {
    const std::string target = "dS" + side + "_dflexion", rate_name = "dS" + side + "_dt";
    if (ch.count(target) || !ch.count(rate_name)) continue;
    // d S / d theta from the rates: S' theta' / (theta'^2 + eps^2), eps a tenth of the peak rate,
    // so frames where the knee hardly moves give ~0 instead of dividing noise by noise. Exact for
    // hinge kinematics (S a function of theta alone) where the knee moves; an estimate otherwise.
    const auto& ds = ch[rate_name];
    const auto& dth = ch["knee_flexion_rate"];
    double peak = 0;
    for (double x : dth) peak = std::max(peak, std::abs(x));
    const double eps = std::max(0.1 * peak, 1e-6);
    std::vector<double> r(n);
    for (int i = 0; i < n; ++i) r[i] = ds[i] * dth[i] / (dth[i] * dth[i] + eps * eps);
    ch[target] = lowPass(r, rate, std::min(6.0, 0.45 * rate));
    g.notes.push_back(target + " estimated from the rates " + rate_name +
                      " and dtheta/dt (not in the contact-area file)");
  }
  return flex_smooth;
}

// Per foot, the plates' vertical and horizontal forces at the trial's frames (each plate assigned to
// the foot whose heel and toe markers lie nearest its centre of pressure), and the EMG envelopes.
void addPlatesAndEmg(const io::C3dFile& c3d, double half, GapTrial& g) {
  auto& ch = g.trial.channels;
  const std::vector<double>& t = g.trial.time;
  const int n = static_cast<int>(t.size());
  const double arate = c3d.analog.rate;
  // Per foot: vertical force and the horizontal components along the lab's x and y axes.
  const size_t na = c3d.analog.time.size();
  std::vector<double> right(na, 0.0), left(na, 0.0), right_x(na, 0.0), right_y(na, 0.0), left_x(na, 0.0),
      left_y(na, 0.0);
  bool any_right = false;
  for (int p = 0; p < static_cast<int>(c3d.plates.size()); ++p) {
    const io::PlateWrench w = io::calcPlateWrench(c3d, p);
    std::vector<double> fz(w.force.size());
    double cnt = 0, tmin = 1e300, tmax = -1e300;
    Eigen::Vector2d cop = Eigen::Vector2d::Zero();
    for (size_t i = 0; i < w.force.size(); ++i) {
      fz[i] = std::max(0.0, w.force[i].z());
      if (fz[i] > 50 && w.cop[i].allFinite()) {
        cop += w.cop[i].head<2>();
        cnt += 1;
        tmin = std::min(tmin, c3d.analog.time[i]);
        tmax = std::max(tmax, c3d.analog.time[i]);
      }
    }
    if (cnt == 0) continue;
    cop /= cnt;
    Eigen::Vector2d rp, lp;
    const bool hr = meanMarkerPosition(c3d, {"RHeel", "RToe"}, tmin, tmax, rp);
    const bool hl = meanMarkerPosition(c3d, {"LHeel", "LToe"}, tmin, tmax, lp);
    const bool is_right = hr && (!hl || (cop - rp).norm() < (cop - lp).norm());
    std::vector<double> f_frames = interpolate(c3d.analog.time, lowPass(fz, arate, 30.0), t, half);
    for (double& x : f_frames)
      if (!std::isfinite(x)) x = 0.0;
    ch["GRF:plate" + std::to_string(p + 1)] = f_frames;
    std::vector<double>& dst = is_right ? right : left;
    std::vector<double>& dst_x = is_right ? right_x : left_x;
    std::vector<double>& dst_y = is_right ? right_y : left_y;
    for (size_t i = 0; i < fz.size(); ++i) {
      dst[i] += fz[i];
      // Horizontal force only while the foot loads the plate (an unloaded plate's offsets are noise).
      if (fz[i] > 0 && w.force[i].allFinite()) dst_x[i] += w.force[i].x(), dst_y[i] += w.force[i].y();
    }
    any_right = any_right || is_right;
    g.notes.push_back("force plate " + std::to_string(p + 1) + " loaded " + fmt(tmin) + "-" + fmt(tmax) + " s: " +
                      (is_right ? "right (instrumented) foot" : "left foot") +
                      (hr ? "" : " (no right-foot markers: assumed left)"));
  }
  if (any_right) {
    const std::vector<std::pair<const char*, const std::vector<double>*>> feet = {
        {"GRF:vertical", &right}, {"GRF:vertical_left", &left}, {"GRF:x", &right_x},
        {"GRF:y", &right_y},      {"GRF:x_left", &left_x},     {"GRF:y_left", &left_y}};
    for (const auto& [name, v] : feet) {
      std::vector<double> at = interpolate(c3d.analog.time, lowPass(*v, arate, 30.0), t, half);
      for (double& x : at)
        if (!std::isfinite(x)) x = 0.0;
      ch[name] = std::move(at);
    }
  }
  for (int c = 0; c < c3d.analog.getNumChannels(); ++c) {
    const std::string& lab = c3d.analog.labels[c];
    const std::string desc = toLower(c3d.analog.descriptions[c]);
    if (desc.find("emg") == std::string::npos || lab == "load cell" || lab == "goniometer") continue;
    std::vector<double> raw(c3d.analog.data.rows());
    for (Eigen::Index i = 0; i < c3d.analog.data.rows(); ++i) raw[i] = c3d.analog.data(i, c);
    std::vector<double> env = interpolate(c3d.analog.time, emgEnvelope(raw, arate), t, half);
    for (double& x : env)
      if (!std::isfinite(x)) x = 0.0;
    ch["EMG:" + lab] = env;
    const auto [mn, mx] = std::minmax_element(raw.begin(), raw.end());
    ch["EMG_range:" + lab] = std::vector<double>(n, *mx - *mn);  // removed by normalizeEmg
  }
}

// GRF:vertical from the knee-force file's GRFz column (trials without a C3D).
void addGrfFromKneeForces(const TrialSource& src, const TrialFiles& f, double half, GapTrial& g) {
  std::vector<double> grf = interpolate(f.kf.time, f.kf.grfz, g.trial.time, half);
  bool finite = true;
  for (double& x : grf) {
    finite = finite && std::isfinite(x);
    x = std::max(0.0, x * src.knee_forces_grf_scale);
  }
  if (!finite)
    throw InputError({src.knee_forces, 0, "GRFz"}, trialWho(src) + ": GRF from the knee forces: expected a GRFz (or "
                                                                   "GRF) column with finite values, got none or NaN");
  g.trial.channels["GRF:vertical"] = grf;
  g.notes.push_back("GRF:vertical from the knee-force file's GRFz column x " + fmt(src.knee_forces_grf_scale) +
                    " N (force plate 1's vertical force; assumed under the instrumented foot)");
}

// The cycles, from the events the setup names (auto: plates for gait and stairs, flexion for a chair
// rise, else the knee force).
void findCycles(const TrialSource& src, bool have_forces, const std::vector<double>& flex_smooth, GapTrial& g) {
  const SourceLocation& where = src.where;
  const std::string who = trialWho(src);
  const auto& ch = g.trial.channels;
  const std::vector<double>& t = g.trial.time;
  std::string ev = src.events;
  if (ev == "auto") {
    if ((g.activity == "gait" || g.activity == "stair") && ch.count("GRF:vertical")) ev = "plates";
    else if (g.activity == "chair") ev = "flexion";
    else ev = "force";
  }
  std::vector<double> starts, mids;
  if (ev == "plates") {
    if (!ch.count("GRF:vertical"))
      throw InputError(where, who + ": events from force plates: expected a C3D with a plate under the right foot");
    const auto& f = ch.at("GRF:vertical");
    starts = findCrossings(t, f, 20.0, 10.0, true, 0.3);
    mids = findCrossings(t, f, 20.0, 10.0, false, 0.3);
    g.event_source = "force plates";
  } else if (ev == "force") {
    if (!have_forces)
      throw InputError(where, who + ": events from the knee force: expected a knee-force file, got none");
    const double rate = frameRate(t);
    const std::vector<double> f = lowPass(g.trial.measured_force, rate, std::min(10.0, 0.45 * rate));
    const double p10 = percentileOf(f, 0.1), p90 = percentileOf(f, 0.9), lvl = p10 + 0.4 * (p90 - p10);
    starts = findCrossings(t, f, lvl, 0.15 * (p90 - p10), true, 0.4);
    mids = findCrossings(t, f, lvl, 0.15 * (p90 - p10), false, 0.4);
    g.event_source = "knee force";
  } else if (ev == "flexion") {
    const double p10 = percentileOf(flex_smooth, 0.1), p90 = percentileOf(flex_smooth, 0.9);
    const double lvl = 0.5 * (p10 + p90);
    starts = findCrossings(t, flex_smooth, lvl, 0.15 * (p90 - p10), false, 0.5);
    mids = findCrossings(t, flex_smooth, lvl, 0.15 * (p90 - p10), true, 0.5);
    g.event_source = "flexion";
  } else if (ev == "times") {
    starts = src.event_times;
    g.event_source = "setup";
  } else {
    throw InputError(where, who + ": events: expected auto, plates, force, flexion or times, got '" + ev + "'");
  }
  setCycles(g, starts, mids);
  g.notes.push_back(std::to_string(g.cycles.size()) + " cycle(s) from " + g.event_source + " events");
}

}  // namespace

GapTrial assembleTrial(const TrialSource& src) {
  GapTrial g;
  g.activity = getActivityDefinition(src.activity).name;
  g.trial.name = src.name;
  g.trial.source = src.where;
  const TrialFiles f = readTrialFiles(src, g);
  const double half = setTimeBase(src, f, g);
  const int n = g.getNumFrames();
  if (f.have_forces) {
    g.trial.measured_force = interpolate(f.kf.time, f.kf.total, g.trial.time, half);
    g.medial = interpolate(f.kf.time, f.kf.medial, g.trial.time, half);
    g.lateral = interpolate(f.kf.time, f.kf.lateral, g.trial.time, half);
  } else {
    g.trial.measured_force = g.medial = g.lateral = std::vector<double>(n, kNaN);
  }
  addAreaChannels(src, f, g);
  addFlexion(src, f, half, g);
  const std::vector<double> flex_smooth = addFlexionDerived(g);
  if (f.have_c3d) addPlatesAndEmg(f.c3d, half, g);
  if (!f.have_c3d && f.have_forces && src.knee_forces_grf_scale > 0) addGrfFromKneeForces(src, f, half, g);
  findCycles(src, f.have_forces, flex_smooth, g);
  return g;
}

std::vector<std::string> normalizeEmg(std::vector<GapTrial>& trials, const std::vector<std::string>& flexors,
                                      const std::vector<std::string>& extensors,
                                      const std::map<std::string, double>* given_peaks,
                                      std::map<std::string, double>* peaks_used) {
  std::set<std::string> labels, dead;
  for (const auto& g : trials)
    for (const auto& [k, v] : g.trial.channels)
      if (startsWith(k, "EMG_range:")) {
        const std::string lab = k.substr(10);
        labels.insert(lab);
        if (v.empty() || v[0] < 0.1) dead.insert(lab);
      }
  std::map<std::string, double> peak;
  for (const auto& lab : labels) {
    if (dead.count(lab)) continue;
    if (given_peaks) {
      // A channel the given peaks lack (dead or absent where they were taken) is dropped.
      auto it = given_peaks->find(lab);
      if (it != given_peaks->end()) peak[lab] = it->second;
      else dead.insert(lab);
      continue;
    }
    for (const auto& g : trials) {
      auto it = g.trial.channels.find("EMG:" + lab);
      if (it == g.trial.channels.end()) continue;
      for (double x : it->second) peak[lab] = std::max(peak[lab], x);
    }
  }
  if (peaks_used) *peaks_used = peak;
  for (auto& g : trials) {
    auto& ch = g.trial.channels;
    bool has_emg = false;
    for (const auto& lab : labels) {
      ch.erase("EMG_range:" + lab);
      auto it = ch.find("EMG:" + lab);
      if (it == ch.end()) continue;
      has_emg = true;
      if (dead.count(lab) || !(peak[lab] > 0)) {
        ch.erase(it);
        continue;
      }
      for (double& x : it->second) x /= peak[lab];
    }
    if (!has_emg) continue;
    auto meanOf = [&](const std::vector<std::string>& group, std::vector<std::string>& used) {
      std::vector<double> m(g.getNumFrames(), 0.0);
      for (const auto& lab : group) {
        auto it = ch.find("EMG:" + lab);
        if (it == ch.end()) continue;
        used.push_back(lab);
        for (size_t i = 0; i < m.size(); ++i) m[i] += it->second[i];
      }
      for (double& x : m) x /= std::max<size_t>(used.size(), 1);
      return m;
    };
    std::vector<std::string> uf, ue;
    const std::vector<double> fl = meanOf(flexors, uf), ex = meanOf(extensors, ue);
    if (uf.empty() || ue.empty()) {
      g.notes.push_back("no EMG:cocontraction: no usable flexor or extensor EMG");
      continue;
    }
    std::vector<double> cc(fl.size());
    for (size_t i = 0; i < cc.size(); ++i) cc[i] = std::min(fl[i], ex[i]);
    ch["EMG:cocontraction"] = cc;
    g.notes.push_back("EMG:cocontraction = min(mean of " + join(uf, ", ") + "; mean of " + join(ue, ", ") +
                      "), envelopes (6 Hz) normalised to their peak over all trials");
  }
  return std::vector<std::string>(dead.begin(), dead.end());
}

}  // namespace kneesim::gap
