// The knee contact force the musculoskeletal way per workflow trial (tool/workflow_muscles.hpp):
// the chain's model, static optimization and the knee reaction, the medial/lateral split, errors.
#include "tool/workflow_muscles.hpp"

#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <algorithm>

#include "core/json.hpp"
#include "core/paths.hpp"
#include "core/strings.hpp"
#include "dynamics/c3d_loads.hpp"
#include "dynamics/coordinate_smoothing.hpp"
#include "dynamics/joint_loads.hpp"
#include "dynamics/tool.hpp"
#include "dynamics/trajectory.hpp"
#include "gap/signals.hpp"
#include "io/c3d.hpp"
#include "model/osim_forces.hpp"
#include "model/osim_reader.hpp"
#include "muscle/adopt_muscles.hpp"

namespace kneesim::tool {

namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double cpuSeconds() { return double(std::clock()) / CLOCKS_PER_SEC; }

// The ID setup's ground reactions bound to @p model (null when it has none).
std::unique_ptr<dynamics::ExternalLoads> loadGroundReactions(const dynamics::IdSetup& id, const model::Model& model) {
  if (!id.plates_c3d_file.empty()) {
    if (!pathExists(id.plates_c3d_file)) throw InputError(id.locate("ForcePlates"), "C3D file not found: " + id.plates_c3d_file);
    const dynamics::GroundReactions g = dynamics::calcGroundReactions(io::readC3d(id.plates_c3d_file), id.plates);
    return std::make_unique<dynamics::ExternalLoads>(g.loads, model, g.grf);
  }
  if (id.external_loads_file.empty()) return nullptr;
  if (!pathExists(id.external_loads_file))
    throw InputError(id.locate("external_loads_file"), "ExternalLoads file not found: " + id.external_loads_file);
  return std::make_unique<dynamics::ExternalLoads>(dynamics::readExternalLoads(id.external_loads_file), model);
}

// Metrics and correlation of @p predicted against @p measured over @p frames.
void measure(const std::string& trial, const std::vector<double>& time, const std::vector<double>& predicted,
             const std::vector<double>& measured, const std::vector<int>& frames, double body_mass,
             identify::FitMetrics& m, double& r) {
  identify::MetricsAccumulator acc(body_mass);
  acc.add(trial, time, predicted.data(), measured.data(), frames);
  m = acc.calc();
  std::vector<double> p(time.size(), kNaN);
  for (int i : frames) p[size_t(i)] = predicted[size_t(i)];
  r = gap::pearson(p, measured);
}

}  // namespace

MuscleChainSetup readMuscleChainSetup(const xml::Node& n, const std::string& dir) {
  xml::checkChildren(n, {"on", "muscle_model_file", "body_map", "reframe_bodies", "exclude_muscles", "force_set_files",
                         "activation_exponent", "use_muscle_physiology", "knee_joint", "reserve_threshold"});
  MuscleChainSetup s;
  s.where = n.where();
  s.on = n.childBool("on", true);
  if (!n.child("muscle_model_file")) n.fail("missing <muscle_model_file> (the model whose muscles are used)");
  s.muscle_model_file = xml::resolvePath(dir, n.childText("muscle_model_file"));
  if (xml::Node b = n.child("body_map"))
    for (const std::string& w : b.toWords()) {
      const size_t colon = w.find(':');
      if (colon == std::string::npos || colon == 0 || colon + 1 == w.size())
        b.fail("expected donor:target body pairs, got '" + w + "'");
      s.body_map.emplace_back(w.substr(0, colon), w.substr(colon + 1));
    }
  if (xml::Node b = n.child("reframe_bodies")) s.reframe_bodies = b.toWords();
  if (xml::Node b = n.child("exclude_muscles")) s.exclude_muscles = b.toWords();
  if (xml::Node b = n.child("force_set_files"))
    for (const std::string& w : b.toWords()) s.force_set_files.push_back(xml::resolvePath(dir, w));
  if (xml::Node e = n.child("activation_exponent")) {
    s.so.activation_exponent = e.toDouble();
    if (!(s.so.activation_exponent >= 1.0) || !std::isfinite(s.so.activation_exponent))
      e.fail("expected an exponent >= 1, got " + e.text());
  }
  s.so.use_muscle_physiology = n.childBool("use_muscle_physiology", true);
  s.knee_joint = n.childText("knee_joint", s.knee_joint);
  if (xml::Node e = n.child("reserve_threshold")) {
    s.reserve_threshold = e.toDouble();
    if (!(s.reserve_threshold > 0) || !std::isfinite(s.reserve_threshold)) e.fail("expected a force > 0, got " + e.text());
  }
  return s;
}

MuscleChainModel buildMuscleChainModel(const MuscleChainSetup& s, const model::ModelPtr& target) {
  if (!pathExists(s.muscle_model_file))
    throw InputError(s.where, "MuscleChain/muscle_model_file: expected an existing model file, got " + s.muscle_model_file);
  const model::ModelPtr donor = model::readOsim(s.muscle_model_file);
  std::vector<muscle::BodyCorrespondence> map;
  for (const auto& [d, t] : s.body_map) map.push_back({d, t, Eigen::Isometry3d::Identity()});
  for (const std::string& b : s.reframe_bodies) map.push_back(muscle::calcDefaultPoseCorrespondence(*target, *donor, b, s.where));
  muscle::AdoptedMuscles a = muscle::adoptMuscles(*target, *donor, map, s.exclude_muscles, s.where);
  MuscleChainModel out;
  out.model = a.model;
  for (const std::string& f : s.force_set_files) {
    if (!pathExists(f)) throw InputError(s.where, "MuscleChain/force_set_files: expected an existing actuator set file, got " + f);
    out.model = model::readOsimActuatorSet(f, out.model, false);
  }
  out.adopted = std::move(a.adopted);
  out.left_out = std::move(a.left_out);
  const model::Model& m = *out.model;
  for (const model::CoordinateActuator& ca : m.actuators) {
    const model::Joint& j = m.joints[size_t(m.coordinates[size_t(ca.coordinate)].joint)];
    if (j.parent_body == 0) out.residuals.push_back(ca.name);
  }
  const int knee = m.findJoint(s.knee_joint);
  if (knee < 0) throw InputError(s.where, "MuscleChain/knee_joint: expected a joint of the model, got '" + s.knee_joint + "'");
  return out;
}

TrialMuscleLoads runTrialMuscleChain(const MuscleChainSetup& setup, const MuscleChainModel& chain,
                                     const std::string& id_setup_file, const io::Storage& motion,
                                     const std::string& motion_file, const SourceLocation& where) {
  const auto wall0 = std::chrono::steady_clock::now();
  if (!pathExists(id_setup_file)) throw InputError(where, "inverse dynamics setup file not found: " + id_setup_file);
  const dynamics::IdSetup id = dynamics::readIdSetup(id_setup_file);
  const model::Model& m = *chain.model;
  TrialMuscleLoads out;
  out.axes = id.knee_axes;
  dynamics::CoordinateSmoothingOptions smoothing;
  smoothing.cutoff_hz = id.cutoff_hz;
  smoothing.in_degrees = id.coordinates_in_degrees >= 0 ? id.coordinates_in_degrees == 1 : dynamics::fileSaysDegrees(motion);
  const dynamics::CoordinateTrajectories traj(m, motion, motion_file, smoothing);
  const std::unique_ptr<dynamics::ExternalLoads> loads = loadGroundReactions(id, m);
  out.time = dynamics::selectFrameTimes(traj.getTimes(), id.time_start, id.time_end, traj.getStartTime(), traj.getEndTime());
  if (out.time.empty()) throw InputError(id.locate("time_range"), "expected a time range overlapping the motion " + motion_file);

  const auto idp = std::make_shared<const dynamics::InverseDynamics>(chain.model);
  const muscle::StaticOptimization so(idp, setup.so);
  auto ws = so.createWorkspace();
  const int n = int(m.coordinates.size()), na = int(so.getActuators().size()), knee = m.findJoint(setup.knee_joint);
  const size_t nf = out.time.size();
  Eigen::VectorXd q(n), qdot(n), qddot(n), mobility(n);
  Eigen::MatrixXd act(nf, na), force(nf, na);
  sim::SpatialColumns F_joint = sim::SpatialColumns::Zero(6, Eigen::Index(m.bodies.size()));
  out.force.resize(Eigen::Index(nf), 3);
  out.moment.resize(Eigen::Index(nf), 3);
  const double cpu0 = cpuSeconds();
  for (size_t f = 0; f < nf; ++f) {
    const double t = out.time[f];
    traj.calcAt(t, q, qdot, qddot);
    const muscle::SoFrameStatus st = so.solveFrame(*ws, t, q, qdot, qddot, loads.get());
    // The dual Newton's stopping test is relative to rounding (1e-10 of the largest generalised
    // force): a frame it calls unconverged within 1e-3 N·m of inverse dynamics is not short.
    if (st.max_violation > 1e-3) {
      ++out.short_frames;
      out.warnings.push_back("t = " + formatSignificant(t, 6) + " s: the actuators fall short of inverse dynamics by " +
                             formatSignificant(st.max_violation, 4) + " on coordinate '" +
                             (st.worst_coordinate >= 0 ? m.coordinates[size_t(st.worst_coordinate)].name : std::string("?")) + "'");
    }
    act.row(Eigen::Index(f)) = ws->getActivations().transpose();
    force.row(Eigen::Index(f)) = ws->getForces().transpose();
    // The reaction with the muscle forces applied: SO met inverse dynamics, so the motion's own
    // accelerations are those forward dynamics would give (OpenSim's JointReaction with SO's
    // forces file).
    dynamics::IdWorkspace& idws = ws->updIdWorkspace();
    mobility.setZero();
    so.addActuatorLoads(*ws, idws.updAppliedForces(), mobility);
    idp->calcJointLoads(idws, ws->getAccelerations(), F_joint);
    const dynamics::JointLoad L = dynamics::expressJointLoad(idp->getSystem(), idws.getSimWorkspace(), knee, F_joint,
                                                             dynamics::LoadOnBody::Child, dynamics::LoadFrame::Child);
    out.force.row(Eigen::Index(f)) = L.force.transpose();
    out.moment.row(Eigen::Index(f)) = (L.moment + L.point.cross(L.force)).transpose();
  }
  out.cpu_ms_per_frame = 1e3 * (cpuSeconds() - cpu0) / double(nf);
  out.activations = muscle::makeActuatorStorage(so, out.time, act);
  out.forces = muscle::makeActuatorStorage(so, out.time, force);

  // Reserves and residuals.
  for (int j = 0; j < na; ++j) {
    const muscle::SoActuator& a = so.getActuators()[size_t(j)];
    if (a.is_muscle) continue;
    ChainReserve r;
    r.name = a.name;
    r.residual = std::find(chain.residuals.begin(), chain.residuals.end(), a.name) != chain.residuals.end();
    for (size_t f = 0; f < nf; ++f) {
      const double v = std::abs(force(Eigen::Index(f), j));
      if (v >= setup.reserve_threshold) ++r.frames_loaded;
      if (v > r.peak) r.peak = v, r.time_of_peak = out.time[f];
    }
    out.reserves.push_back(r);
  }

  // The reaction in clinical terms, per chain frame (moments about the tibial frame's origin).
  const dynamics::KneeAxes& ax = out.axes;
  io::Storage& s = out.reaction;
  s.name = "knee reaction with muscle forces";
  s.labels = {"time", "compressive_force", "ap_force", "ml_force", "moment_anterior", "moment_superior", "moment_medial"};
  s.header = {{"units", "N, N m; on the tibial component, its frame's anatomical axes; moments about its origin"}};
  s.data.resize(Eigen::Index(nf), 7);
  for (size_t f = 0; f < nf; ++f) {
    const Eigen::Vector3d fo = out.force.row(Eigen::Index(f)).transpose(), mo = out.moment.row(Eigen::Index(f)).transpose();
    s.data.row(Eigen::Index(f)) << out.time[f], -fo.dot(ax.superior), fo.dot(ax.anterior), fo.dot(ax.medial),
        mo.dot(ax.anterior), mo.dot(ax.superior), mo.dot(ax.medial);
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  return out;
}

void splitMuscleLoads(TrialMuscleLoads& loads, const std::vector<double>& time, const contact::ContactSeries& contact) {
  const dynamics::KneeAxes& ax = loads.axes;
  // Each compartment's centroid averaged over the frames where it has contact: the fallback.
  Eigen::Vector3d mean_m = Eigen::Vector3d::Zero(), mean_l = Eigen::Vector3d::Zero();
  int nm = 0, nl = 0;
  for (const contact::ContactFrame& c : contact.frames) {
    if (c.centroid_medial.allFinite() && c.S_medial > 0) mean_m += c.centroid_medial, ++nm;
    if (c.centroid_lateral.allFinite() && c.S_lateral > 0) mean_l += c.centroid_lateral, ++nl;
  }
  mean_m /= std::max(1, nm);
  mean_l /= std::max(1, nl);
  std::vector<double> tt = loads.time;
  std::vector<std::vector<double>> cols(6);
  for (int k = 0; k < 3; ++k) {
    for (size_t f = 0; f < tt.size(); ++f) {
      cols[size_t(k)].push_back(loads.force(Eigen::Index(f), k));
      cols[size_t(3 + k)].push_back(loads.moment(Eigen::Index(f), k));
    }
  }
  std::vector<std::vector<double>> at(6);
  for (int k = 0; k < 6; ++k) at[size_t(k)] = gap::interpolate(tt, cols[size_t(k)], time);
  const size_t n = time.size();
  loads.split_time = time;
  loads.total.assign(n, kNaN);
  loads.medial.assign(n, kNaN);
  loads.lateral.assign(n, kNaN);
  loads.frames_without_contact_centroid = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d f(at[0][i], at[1][i], at[2][i]), m0(at[3][i], at[4][i], at[5][i]);
    if (!f.allFinite() || !m0.allFinite()) continue;
    Eigen::Vector3d cm = mean_m, cl = mean_l;
    if (i < contact.frames.size()) {
      const contact::ContactFrame& c = contact.frames[i];
      bool fallback = false;
      if (c.S_medial > 0 && c.centroid_medial.allFinite()) cm = c.centroid_medial; else fallback = true;
      if (c.S_lateral > 0 && c.centroid_lateral.allFinite()) cl = c.centroid_lateral; else fallback = true;
      loads.frames_without_contact_centroid += fallback ? 1 : 0;
    }
    const Eigen::Vector3d O = 0.5 * (cm + cl);
    const double d = (cm - cl).dot(ax.medial);
    const double F = -f.dot(ax.superior);
    const double m_a = (m0 - O.cross(f)).dot(ax.anterior);
    loads.total[i] = F;
    if (std::abs(d) < 1e-4) continue;  // no lever between the compartments
    loads.medial[i] = 0.5 * F - m_a / d;
    loads.lateral[i] = 0.5 * F + m_a / d;
  }
}

void compareMuscleLoads(TrialMuscleLoads& loads, const std::string& trial, const std::vector<double>& time,
                        const io::KneeForces& forces, double window_begin, double window_end,
                        const std::vector<std::pair<std::string, std::pair<double, double>>>& phases,
                        double body_mass) {
  std::vector<std::pair<std::string, std::pair<double, double>>> parts = {
      {"trial", {-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()}},
      {"window", {window_begin, window_end}}};
  parts.insert(parts.end(), phases.begin(), phases.end());
  loads.phases.clear();
  for (const auto& [name, range] : parts) {
    ChainPhase p;
    p.name = name;
    p.begin = range.first;
    p.end = range.second;
    std::vector<int> frames;
    for (size_t i = 0; i < time.size(); ++i)
      if (time[i] >= range.first - 1e-9 && time[i] <= range.second + 1e-9 && std::isfinite(loads.total[i]))
        frames.push_back(int(i));
    if (frames.empty()) continue;
    if (!std::isfinite(p.begin)) p.begin = time[size_t(frames.front())], p.end = time[size_t(frames.back())];
    measure(trial, time, loads.total, forces.total, frames, body_mass, p.total, p.r_total);
    measure(trial, time, loads.medial, forces.medial, frames, body_mass, p.medial, p.r_medial);
    measure(trial, time, loads.lateral, forces.lateral, frames, body_mass, p.lateral, p.r_lateral);
    loads.phases.push_back(p);
  }
}

Plot makeMuscleLoadPlot(const TrialMuscleLoads& loads, const io::KneeForces& forces, const std::vector<double>& hertz,
                        const std::vector<double>& x, const std::string& xlabel, const std::string& trial) {
  Plot p;
  p.title = "Knee contact force, musculoskeletal (static optimization + joint reaction), " + trial;
  for (const ChainPhase& ph : loads.phases)
    if (ph.name == "trial")
      p.title += ": total RMSE " + formatSignificant(ph.total.rmse, 3) + " N, r " + formatSignificant(ph.r_total, 3);
  p.xlabel = xlabel;
  p.ylabel = "force (N)";
  p.series.push_back({"measured total (eKnee)", x, forces.total, "lines", "#000000"});
  p.series.push_back({"measured medial", x, forces.medial, "lines", "#1f77b4", 2, 1.5});
  p.series.push_back({"measured lateral", x, forces.lateral, "lines", "#2ca02c", 2, 1.5});
  p.series.push_back({"muscles: total", x, loads.total, "lines", "#d62728"});
  p.series.push_back({"muscles: medial", x, loads.medial, "lines", "#9467bd", 0, 1.5});
  p.series.push_back({"muscles: lateral", x, loads.lateral, "lines", "#17becf", 0, 1.5});
  if (!hertz.empty()) p.series.push_back({"Hertz law: total", x, hertz, "lines", "#ff7f0e", 3, 1.5});
  return p;
}

io::Storage makeGapLoadTable(const io::Storage& knee_loads, const TrialMuscleLoads& loads) {
  io::Storage s = knee_loads;
  s.name = "knee net loads (inverse dynamics) and the musculoskeletal knee force";
  s.header.emplace_back("knee_muscle_total", "compressive force on the tibial component with muscle forces (N)");
  s.header.emplace_back("knee_muscle_medial", "its medial compartment's share (N), split by the frontal-plane moment");
  s.header.emplace_back("knee_muscle_lateral", "its lateral compartment's share (N)");
  const Eigen::Index rows = s.getNumRows();
  std::vector<double> t(static_cast<size_t>(rows)), total(loads.time.size());
  for (size_t r = 0; r < t.size(); ++r) t[r] = s.data(Eigen::Index(r), 0);
  for (size_t f = 0; f < total.size(); ++f) total[f] = -loads.force.row(Eigen::Index(f)).dot(loads.axes.superior.transpose());
  // The total is held at the end values within half a frame (the two tables share their frames).
  // The compartments are split at the workflow's frames where the reaction is known (where the
  // contact centroids are): held at their end values within one of this table's frames, so that
  // the gap diagnosis, which reads this table at the workflow's frames, finds both neighbours of
  // every frame.
  const double frame = rows > 1 ? (t.back() - t.front()) / double(rows - 1) : 0.0;
  auto split = [&](const std::vector<double>& v) {
    std::vector<double> ts, vs;
    for (size_t i = 0; i < v.size() && i < loads.split_time.size(); ++i)
      if (std::isfinite(v[i])) ts.push_back(loads.split_time[i]), vs.push_back(v[i]);
    return ts.empty() ? std::vector<double>(t.size(), kNaN) : gap::interpolate(ts, vs, t, frame);
  };
  const std::vector<std::vector<double>> cols = {gap::interpolate(loads.time, total, t, 1e-3), split(loads.medial),
                                                 split(loads.lateral)};
  const Eigen::Index first = s.data.cols();
  for (const char* name : {"knee_muscle_total", "knee_muscle_medial", "knee_muscle_lateral"}) s.labels.push_back(name);
  s.data.conservativeResize(Eigen::NoChange, first + 3);
  for (Eigen::Index k = 0; k < 3; ++k)
    for (size_t r = 0; r < t.size(); ++r) s.data(Eigen::Index(r), first + k) = cols[size_t(k)][r];
  return s;
}

nlohmann::json toJson(const TrialMuscleLoads& loads, bool timings) {
  nlohmann::json j;
  j["frames"] = loads.time.size();
  j["units"] = "N (compressive force on the tibial component), body weights where a body mass is given";
  j["frames_short_of_inverse_dynamics"] = loads.short_frames;
  j["frames_with_a_trial_mean_centroid"] = loads.frames_without_contact_centroid;
  if (timings) {
    j["seconds"] = loads.seconds;
    j["cpu_ms_per_frame"] = loads.cpu_ms_per_frame;
  }
  nlohmann::json res = nlohmann::json::array();
  for (const ChainReserve& r : loads.reserves)
    res.push_back({{"name", r.name}, {"residual", r.residual}, {"frames_loaded", r.frames_loaded}, {"peak", r.peak},
                   {"time_of_peak", jsonNumber(r.time_of_peak)}});
  j["reserves"] = res;
  nlohmann::json ph = nlohmann::json::array();
  const auto metrics = [](const identify::FitMetrics& m, double r) {
    return nlohmann::json{{"rmse", jsonNumber(m.rmse)}, {"rmse_bw", jsonNumber(m.rmse_bw)}, {"r2", jsonNumber(m.r2)}, {"r", jsonNumber(r)},
                          {"bias", jsonNumber(m.bias)}, {"peak_measured", jsonNumber(m.peak_measured)}, {"n_frames", m.n_frames}};
  };
  for (const ChainPhase& p : loads.phases)
    ph.push_back({{"name", p.name}, {"begin", jsonNumber(p.begin)}, {"end", jsonNumber(p.end)},
                  {"total", metrics(p.total, p.r_total)}, {"medial", metrics(p.medial, p.r_medial)},
                  {"lateral", metrics(p.lateral, p.r_lateral)}});
  j["phases"] = ph;
  double peak = 0;
  for (double v : loads.total)
    if (std::isfinite(v)) peak = std::max(peak, v);
  j["peak_total"] = peak;
  return j;
}

}  // namespace kneesim::tool
