// One trial of the knee contact workflow: its knee forces, its kinematics source (IK, a motion or
// the goniometer), its gait events, the components' poses, the contact areas (and their
// derivatives) at the frames the forces cover, and the identification's view of it.

#include <algorithm>
#include <filesystem>

#include "contact/contact_output.hpp"
#include "core/paths.hpp"
#include "ik/tool.hpp"
#include "io/c3d.hpp"
#include "tool/workflow_detail.hpp"

namespace kneesim::tool::detail {

namespace fs = std::filesystem;

namespace {

// Linear interpolation of column @p col of @p st at time @p t (held at the ends).
// Linear interpolation of column @p col of @p st at time @p t (held at the ends).
double interpolateColumn(const io::Storage& st, int col, double t) {
  const int n = st.getNumRows();
  if (n == 0) return kNaN;
  if (t <= st.data(0, 0)) return st.data(0, col);
  if (t >= st.data(n - 1, 0)) return st.data(n - 1, col);
  int hi = 1;
  while (st.data(hi, 0) < t) ++hi;
  const double a = (t - st.data(hi - 1, 0)) / (st.data(hi, 0) - st.data(hi - 1, 0));
  return (1 - a) * st.data(hi - 1, col) + a * st.data(hi, col);
}

io::KneeForces subsetForces(const io::KneeForces& f, const std::vector<int>& keep) {
  io::KneeForces o = f;
  for (auto* v : {&o.time, &o.am, &o.pm, &o.al, &o.pl, &o.medial, &o.lateral, &o.total, &o.goniometer, &o.grfz})
    if (v->size() == f.time.size()) *v = subset(*v, keep);
  return o;
}

// Flexion from the goniometer (io/goniometer.hpp) as the trial's motion: volts to goniometer
// degrees when the file is in volts, then the line to the model's flexion, as given or fitted on
// other trials.
void readGoniometerMotion(const WorkflowSetup& setup, const WorkflowInputs& in, const std::vector<TrialState>& states,
                          TrialState& st, const io::KneeForces& forces, AtomicFileSet& outputs) {
  const WorkflowTrialSpec& spec = st.spec;
  WorkflowTrialResult& r = st.result;
  const std::string who = "trial '" + spec.name + "': ";
  // Flexion from the goniometer (io/goniometer.hpp): volts to goniometer degrees when the file
  // is in volts, then the line to the model's flexion, as given or fitted on other trials.
  io::GoniometerCalibration cal = spec.goniometer;
  if (!spec.calibrate_on.empty()) {
    std::vector<io::GoniometerPairs> pairs;
    for (const std::string& ref_name : spec.calibrate_on) {
      const auto it = std::find_if(states.begin(), states.end(),
                                   [&](const TrialState& o) { return o.spec.name == ref_name; });
      const WorkflowTrialResult& ref = it->result;
      io::GoniometerPairs p;
      p.trial = ref_name;
      p.goniometer = ref.forces.goniometer;
      for (double f : ref.flexion) p.flexion_deg.push_back(in.flex_rot ? f / kDeg : f);
      pairs.push_back(std::move(p));
    }
    cal = io::fitGoniometerCalibration(pairs, cal, spec.where);
    if (!(std::abs(cal.r) > 0.9))
      throw InputError(spec.where, who + "the goniometer " + cal.source + " does not follow the " +
                                       setup.flexion_coordinate + " (r = " + fmt(cal.r, 3) + " over " +
                                       std::to_string(cal.frames) + " frames, expected |r| > 0.9): no calibration");
  }
  std::string note;
  const std::vector<double> flex_deg = io::calcKneeFlexionDeg(forces.goniometer, cal, &note);
  r.goniometer = cal;
  r.goniometer_in_volts = io::usesVolts(forces.goniometer, cal);
  r.notes.push_back(note + (spec.calibrate_on.empty() ? "" : "; assumes the same sensor, gain and offset in this trial"));
  st.motion.name = spec.name + " flexion from the goniometer";
  st.motion.in_degrees = true;
  st.motion.labels = {"time", setup.flexion_coordinate};
  std::vector<int> rows;
  for (size_t i = 0; i < forces.time.size(); ++i)
    if (std::isfinite(forces.goniometer[i])) rows.push_back(int(i));
  if (rows.empty()) throw InputError(spec.where, who + "no goniometer values (GON) in " + spec.knee_forces_file);
  st.motion.data.resize(Eigen::Index(rows.size()), 2);
  for (size_t k = 0; k < rows.size(); ++k) {
    st.motion.data(Eigen::Index(k), 0) = forces.time[size_t(rows[k])];
    st.motion.data(Eigen::Index(k), 1) = flex_deg[size_t(rows[k])];
  }
  st.motion_label = spec.name + " goniometer of " + spec.knee_forces_file;
  outputs.addContents((fs::path(trialDirectory(setup, spec.name)) / (spec.name + "_motion.mot")).string(),
                      io::formatStorage(st.motion));
}

// The trial's motion from its kinematics source; an IK run may name the C3D file (@p c3d_file).
void readKinematicsSource(const WorkflowSetup& setup, const WorkflowInputs& in, const std::vector<TrialState>& states,
                          TrialState& st, const io::KneeForces& forces, std::string& c3d_file, AtomicFileSet& outputs,
                          const Progress& progress) {
  const WorkflowTrialSpec& spec = st.spec;
  WorkflowTrialResult& r = st.result;
  const std::string who = "trial '" + spec.name + "': ";
  if (spec.source == WorkflowTrialSpec::Source::ik) {
    if (!pathExists(spec.ik_setup_file)) throw InputError(spec.where, who + "IK setup file not found: " + spec.ik_setup_file);
    ik::IkSetup ik = ik::readIkSetup(spec.ik_setup_file);
    ik.output_motion_file = (fs::path(trialDirectory(setup, spec.name)) / (spec.name + "_ik.mot")).string();
    ik.results_directory = trialDirectory(setup, spec.name);
    ik.time_start = std::max(ik.time_start, spec.time_start);
    ik.time_end = std::min(ik.time_end, spec.time_end);
    if (fs::weakly_canonical(ik.model_file) != fs::weakly_canonical(setup.model_file))
      r.notes.push_back("IK used " + ik.model_file + ", the contact kinematics " + setup.model_file);
    ik::IkRunOptions ro;
    ro.progress = [&](int d, int t) { progress("IK " + spec.name, d, t); };
    ro.stage = &outputs;
    const ik::IkReport rep = ik::runIk(ik, ro);
    st.motion = rep.motion;
    st.motion_label = ik.output_motion_file + " (IK of " + ik.marker_file + ")";
    r.ik_mean_rms = rep.mean_rms;
    if (c3d_file.empty() && endsWith(toLower(ik.marker_file), ".c3d")) c3d_file = ik.marker_file;
    r.notes.push_back("IK of " + ik.marker_file + ": " + std::to_string(rep.frames_solved) + " frames, mean marker RMS " +
                      fmt(rep.mean_rms * 1e3, 3) + " mm");
  } else if (spec.source == WorkflowTrialSpec::Source::motion) {
    if (!pathExists(spec.motion_file)) throw InputError(spec.where, who + "motion file not found: " + spec.motion_file);
    st.motion = io::readStorage(spec.motion_file);
    st.motion_label = spec.motion_file;
  } else {
    readGoniometerMotion(setup, in, states, st, forces, outputs);
  }
}

// The forces on the C3D's clock and the gait events (from the setup, else the force plates).
void readGaitEvents(const WorkflowTrialSpec& spec, const std::string& c3d_file, io::KneeForces& forces,
                    WorkflowTrialResult& r) {
  const std::string who = "trial '" + spec.name + "': ";
  io::C3dFile c3d;
  if (!c3d_file.empty()) {
    if (!pathExists(c3d_file)) throw InputError(spec.where, who + "C3D file not found: " + c3d_file);
    c3d = io::readC3d(c3d_file);
    forces = io::retimeToFrames(forces, c3d.first_frame, c3d.markers.rate);
    io::FootContactOptions fo;
    fo.heel_marker = spec.heel_marker;
    if (spec.gait_events.empty()) r.contacts = io::findFootContacts(c3d, fo);
  }
  if (spec.gait_events.size() == 3) {
    r.cycle.strike = spec.gait_events[0];
    r.cycle.toe_off = spec.gait_events[1];
    r.cycle.next_strike = spec.gait_events[2];
  } else {
    r.cycle = io::findGaitCycle(r.contacts);
  }
}

// The poses of the trial's frames with the flexion shifted by dflex (rad): 0 for the areas,
// +-a step for their derivative along flexion (through the model's couplers or the hinge).
ContactKinematics calcTrialPoses(const WorkflowSetup& setup, const WorkflowInputs& in, const TrialState& st,
                                 const ContactAreaSetup& cs, int motion_flex, double flex_unit, double dflex,
                                 const Progress& progress) {
  const WorkflowTrialSpec& spec = st.spec;
  const std::string who = "trial '" + spec.name + "': ";
  const auto prog = [&](const std::string& w, int d, int t) {
    progress(w + " " + spec.name + (dflex != 0 ? " (flexion step)" : ""), d, t);
  };
  if (setup.kinematics == "model") {
    if (dflex == 0) return calcModelKinematics(cs, in.model, st.motion, st.motion_label, prog);
    io::Storage shifted = st.motion;
    shifted.data.col(motion_flex).array() += dflex / flex_unit;
    return calcModelKinematics(cs, in.model, shifted, st.motion_label, prog);
  }
  std::vector<double> t_all, f_all;
  for (int row = 0; row < st.motion.getNumRows(); ++row) {
    const double t = st.motion.data(row, 0);
    if (t < spec.time_start - 1e-9 || t > spec.time_end + 1e-9) continue;
    t_all.push_back(t);
    f_all.push_back(st.motion.data(row, motion_flex) * flex_unit + dflex);
  }
  if (t_all.empty())
    throw InputError(spec.where, who + "time range " + fmt(spec.time_start) + " to " + fmt(spec.time_end) +
                                     " s does not overlap the motion " + st.motion_label);
  return calcHingeKinematics(cs, in.meshes, t_all, f_all, prog);
}

// The measured force at the motion's frames; frames outside the recording are left out. Fills the
// trial's time, forces, kinematics columns and flexion on the kept frames; returns them.
std::vector<int> keepRecordedFrames(const TrialState& st, const io::KneeForces& forces, const ContactKinematics& k,
                                    int motion_flex, double flex_unit, WorkflowTrialResult& r) {
  const WorkflowTrialSpec& spec = st.spec;
  const std::string who = "trial '" + spec.name + "': ";
  const io::KneeForces at_frames = io::resampleKneeForces(forces, k.time);
  std::vector<int> keep;
  for (size_t i = 0; i < k.time.size(); ++i)
    if (std::isfinite(at_frames.total[i])) keep.push_back(int(i));
  if (keep.size() < 2)
    throw InputError(spec.where, who + "the knee forces of " + spec.knee_forces_file + " (" +
                                     fmt(forces.time.front()) + " to " + fmt(forces.time.back()) +
                                     " s) overlap the kinematics (" + fmt(k.time.front()) + " to " +
                                     fmt(k.time.back()) + " s) in " + std::to_string(keep.size()) +
                                     " frames, expected at least 2");
  if (keep.size() < k.time.size())
    r.notes.push_back(std::to_string(k.time.size() - keep.size()) + " of " + std::to_string(k.time.size()) +
                      " motion frames lie outside the knee-force recording and are left out");
  r.time = subset(k.time, keep);
  r.forces = subsetForces(at_frames, keep);
  for (const auto& [name, v] : k.columns) r.kinematics_columns.emplace_back(name, subset(v, keep));
  for (double t : r.time) r.flexion.push_back(interpolateColumn(st.motion, motion_flex, t) * flex_unit);
  return keep;
}

}  // namespace

void compareTrialMuscleLoads(const WorkflowSetup& setup, TrialState& st) {
  WorkflowTrialResult& r = st.result;
  if (r.muscle_loads.total.empty()) return;
  std::vector<std::pair<std::string, std::pair<double, double>>> phases;
  for (const PhaseError& e : r.phases) phases.push_back({e.name, {e.begin, e.end}});
  const identify::TimeWindow w = resolveWindow(st.spec, r.cycle);
  compareMuscleLoads(r.muscle_loads, r.name, r.time, r.forces, w.begin, w.end, phases, setup.body_mass);
}

std::string trialDirectory(const WorkflowSetup& setup, const std::string& trial) {
  return (fs::path(setup.results_directory) / trial).string();
}

void processTrial(const WorkflowSetup& setup, WorkflowInputs& in, std::vector<TrialState>& states, size_t oi,
                  WorkflowReport& report, AtomicFileSet& outputs, const Progress& progress) {
  TrialState& st = states[oi];
  const WorkflowTrialSpec& spec = st.spec;
  WorkflowTrialResult& r = st.result;
  r.name = spec.name;
  r.fit = spec.fit;
  const std::string who = "trial '" + spec.name + "': ";

  // ---- forces (needed first by the goniometer source)
  if (!pathExists(spec.knee_forces_file)) throw InputError(spec.where, who + "knee-force file not found: " + spec.knee_forces_file);
  io::KneeForces forces = io::readKneeForces(spec.knee_forces_file);
  std::string c3d_file = spec.c3d_file;

  // ---- kinematics source
  auto t0 = Clock::now();
  readKinematicsSource(setup, in, states, st, forces, c3d_file, outputs, progress);
  r.seconds_ik = secondsSince(t0);
  if (!spec.id_setup_file.empty())
    r.knee_loads = runTrialKneeLoads(spec.id_setup_file, st.motion,
                                     spec.source == WorkflowTrialSpec::Source::ik ? st.motion_label : spec.motion_file,
                                     spec.name, trialDirectory(setup, spec.name), spec.where, outputs, r.notes);

  // ---- forces on the C3D's clock, gait events
  readGaitEvents(spec, c3d_file, forces, r);

  // ---- component poses
  t0 = Clock::now();
  ContactAreaSetup cs = setup.contact;
  cs.time_start = spec.time_start;
  cs.time_end = spec.time_end;
  const int motion_flex = st.motion.findColumn(setup.flexion_coordinate);
  if (motion_flex < 0)
    throw InputError(spec.where, who + "the motion " + st.motion_label + " has no column '" + setup.flexion_coordinate + "'");
  const double flex_unit = st.motion.in_degrees && in.flex_rot ? kDeg : 1.0;
  const ContactKinematics k = calcTrialPoses(setup, in, st, cs, motion_flex, flex_unit, 0.0, progress);
  r.seconds_kinematics = secondsSince(t0);
  r.kinematics_description = k.description;
  for (const std::string& w : k.warnings)  // model warnings repeat for every trial: once is enough
    if (std::find(report.warnings.begin(), report.warnings.end(), w) == report.warnings.end())
      report.warnings.push_back(w);

  // ---- measured force at the motion's frames; frames outside the recording are left out
  const std::vector<int> keep = keepRecordedFrames(st, forces, k, motion_flex, flex_unit, r);

  // ---- contact area
  t0 = Clock::now();
  r.contact = calcSeriesInParallel(*in.calculator, in.wss, r.time, subset(k.X_IF, keep),
                                   [&](int d, int t) { progress("area " + spec.name, d, t); });
  r.seconds_area = secondsSince(t0);

  // ---- derivatives of the area along flexion and along an anterior shift of the femur
  if (setup.area_derivatives) {
    t0 = Clock::now();
    r.area_derivatives = calcAreaDerivatives(setup, spec, in.model, in.meshes, st.motion, motion_flex, flex_unit, cs, k,
                                             keep, *in.derivative_calculator, in.derivative_wss, r.notes,
                                             [&](int d, int t) { progress("area derivatives " + spec.name, d, t); });
    r.seconds_area_derivatives = secondsSince(t0);
  }

  // ---- the knee contact force from muscle forces (static optimization, joint reaction)
  if (setup.muscles.on && !spec.id_setup_file.empty()) {
    progress("muscles " + spec.name, 0, 1);
    r.muscle_loads = runTrialMuscleChain(setup.muscles, in.muscle_chain, spec.id_setup_file, st.motion,
                                         spec.source == WorkflowTrialSpec::Source::ik ? st.motion_label : spec.motion_file,
                                         spec.where);
    splitMuscleLoads(r.muscle_loads, r.time, r.contact);
    progress("muscles " + spec.name, 1, 1);
  }

  // ---- the identification's view
  identify::Trial& tr = r.trial;
  tr.name = spec.name;
  tr.source = spec.where;
  tr.time = r.time;
  for (auto& [name, v] : contact::getContactChannels(r.contact))
    if (name != "time") tr.channels[name] = std::move(v);
  tr.channels[setup.flexion_coordinate] = r.flexion;
  tr.measured_force = r.forces.total;
  const identify::TimeWindow w = resolveWindow(spec, r.cycle);
  if (spec.window != "trial") tr.windows.push_back(w);
  if (!spec.id_setup_file.empty()) compareKneeLoads(r.knee_loads, r.time, r.forces, w.begin, w.end);
}

}  // namespace kneesim::tool::detail
