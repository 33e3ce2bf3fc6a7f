// OpenSim's AnalyzeTool running StaticOptimization: setup, frame loop, result files.
#include "muscle/analyze_tool.hpp"

#include <algorithm>

#include <cmath>
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <set>

#include "core/paths.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "dynamics/coordinate_smoothing.hpp"
#include "dynamics/tool.hpp"
#include "dynamics/trajectory.hpp"
#include "model/osim_forces.hpp"
#include "model/osim_reader.hpp"
#include "muscle/joint_reaction.hpp"

namespace kneesim::muscle {

namespace fs = std::filesystem;

SourceLocation AnalyzeSetup::locate(const std::string& element) const {
  for (const char* key : {element.c_str(), "AnalyzeTool"})
    if (auto it = locations.find(key); it != locations.end()) return it->second;
  return SourceLocation{setup_file, 0, element};
}

namespace {

using dynamics::optionalPath;

double finiteChild(const xml::Node& node, const char* tag, double fallback, const char* expected) {
  if (!node.child(tag) || node.childText(tag).empty()) return fallback;
  const double v = node.childDouble(tag, fallback);
  if (!std::isfinite(v)) node.child(tag).fail(std::string("expected ") + expected + ", got " + node.childText(tag));
  return v;
}

// A count >= 1 that an int holds (converting 1e43 to an int is undefined behaviour).
int countChild(const xml::Node& node, const char* tag, int fallback, const char* expected) {
  const double v = finiteChild(node, tag, fallback, expected);
  if (!(v >= 1 && truncatesToInt(v))) node.child(tag).fail(std::string("expected ") + expected + ", got " + node.childText(tag));
  return int(v);
}

void readStaticOptimization(const xml::Node& so, AnalyzeSetup& s) {
  xml::checkChildren(so, {"on", "start_time", "end_time", "step_interval", "in_degrees", "use_model_force_set",
                          "activation_exponent", "use_muscle_physiology", "optimizer_convergence_criterion",
                          "optimizer_max_iterations", "kneesim_optimizer"});
  for (const xml::Node& c : so.children()) s.locations["StaticOptimization/" + c.name()] = c.where();
  s.so_on = so.childBool("on", true);
  if (!so.nameAttr().empty()) s.so_name = so.nameAttr();
  s.so_start = finiteChild(so, "start_time", s.so_start, "a time in s");
  s.so_end = finiteChild(so, "end_time", s.so_end, "a time in s");
  s.step_interval = countChild(so, "step_interval", 1, "a positive integer");
  if (!so.childBool("use_model_force_set", true))
    so.child("use_model_force_set").fail("expected true (kneesim optimises the model's own actuators), got false");
  s.so.activation_exponent = finiteChild(so, "activation_exponent", 2.0, "an exponent >= 1");
  if (!(s.so.activation_exponent >= 1.0))
    so.child("activation_exponent").fail("expected an exponent >= 1, got " + so.childText("activation_exponent"));
  s.so.use_muscle_physiology = so.childBool("use_muscle_physiology", true);
  s.so.convergence = finiteChild(so, "optimizer_convergence_criterion", 1e-4, "a positive tolerance");
  if (!(s.so.convergence > 0))
    so.child("optimizer_convergence_criterion").fail("expected a positive tolerance, got " + so.childText("optimizer_convergence_criterion"));
  s.so.max_iterations = countChild(so, "optimizer_max_iterations", 100, "a positive count");
  // kneesim's own element: the optimum (exact, the default) or OpenSim's optimizer and its answers.
  const std::string optimizer = so.childText("kneesim_optimizer", "exact");
  if (optimizer != "exact" && optimizer != "opensim")
    so.child("kneesim_optimizer").fail("expected exact or opensim, got '" + optimizer + "'");
  s.so.opensim_optimizer = optimizer == "opensim";
}

void readJointReaction(const xml::Node& jr, const std::string& dir, AnalyzeSetup& s) {
  xml::checkChildren(jr, {"on", "start_time", "end_time", "step_interval", "in_degrees", "forces_file", "joint_names",
                          "apply_on_bodies", "express_in_frame"});
  for (const xml::Node& c : jr.children()) s.locations["JointReaction/" + c.name()] = c.where();
  s.jr_on = jr.childBool("on", true);
  if (!jr.nameAttr().empty()) s.jr_name = jr.nameAttr();
  s.jr_start = finiteChild(jr, "start_time", s.jr_start, "a time in s");
  s.jr_end = finiteChild(jr, "end_time", s.jr_end, "a time in s");
  s.jr_forces_file = optionalPath(jr, "forces_file", dir);
  if (xml::Node n = jr.child("joint_names")) s.jr_joints = n.toWords();
  if (xml::Node n = jr.child("apply_on_bodies")) s.jr_on_bodies = n.toWords();
  if (xml::Node n = jr.child("express_in_frame")) s.jr_frames = n.toWords();
  if (s.jr_on && s.jr_joints.empty()) jr.fail("expected joint names (or All) in <joint_names>, got none");
}

double cpuSeconds() { return double(std::clock()) / CLOCKS_PER_SEC; }

model::ModelPtr loadAnalyzeModel(const AnalyzeSetup& setup) {
  if (!pathExists(setup.model_file)) throw InputError(setup.locate("model_file"), "model file not found: " + setup.model_file);
  model::ModelPtr model = model::readOsim(setup.model_file);
  bool replace = setup.replace_force_set;
  for (const std::string& f : setup.force_set_files) {
    if (!pathExists(f)) throw InputError(setup.locate("force_set_files"), "actuator set file not found: " + f);
    model = model::readOsimActuatorSet(f, model, replace);
    replace = false;
  }
  return model;
}

/// OpenSim's AnalyzeTool states: speeds sampled from the coordinate splines' derivatives at the
/// coordinate times, and accelerations from quintic splines through those speeds.
class AnalyzeTrajectory {
 public:
  explicit AnalyzeTrajectory(const dynamics::CoordinateTrajectories& traj, int n) : traj_(traj) {
    const std::vector<double>& times = traj.getTimes();
    Eigen::VectorXd q(n), qdot(n), qddot(n);
    std::vector<std::vector<double>> speeds(size_t(n), std::vector<double>(times.size()));
    for (size_t r = 0; r < times.size(); ++r) {
      traj.calcAt(times[r], q, qdot, qddot);
      for (int c = 0; c < n; ++c) speeds[c][r] = qdot[c];
    }
    const dynamics::NaturalSplineFitter fitter(times, 5);
    for (int c = 0; c < n; ++c) speed_splines_.push_back(fitter.fit(speeds[c]));
  }
  void calcAt(double t, Eigen::VectorXd& q, Eigen::VectorXd& qdot, Eigen::VectorXd& qddot) const {
    traj_.calcAt(t, q, qdot, qddot);
    for (int c = 0; c < int(speed_splines_.size()); ++c) qddot[c] = speed_splines_[c].calcDerivative(t, 1);
  }

 private:
  const dynamics::CoordinateTrajectories& traj_;
  std::vector<dynamics::NaturalSpline> speed_splines_;
};

}  // namespace

AnalyzeSetup readAnalyzeSetup(const std::string& path) {
  static const std::set<std::string> elements = {
      "model_file", "replace_force_set", "force_set_files", "results_directory", "output_precision", "initial_time",
      "final_time", "solve_for_equilibrium_for_auxiliary_states", "maximum_number_of_integrator_steps",
      "maximum_integrator_step_size", "minimum_integrator_step_size", "integrator_error_tolerance", "AnalysisSet",
      "ControllerSet", "external_loads_file", "states_file", "coordinates_file", "speeds_file",
      "lowpass_cutoff_frequency_for_coordinates"};
  if (!pathExists(path)) throw InputError({path, 0, ""}, "setup file not found");
  auto doc = xml::Document::load(path);
  const xml::Node tool = xml::requireSetupElement(*doc, "AnalyzeTool");
  xml::checkChildren(tool, elements);
  const std::string dir = fs::path(path).parent_path().string();
  AnalyzeSetup s;
  s.setup_file = path;
  s.name = tool.nameAttr();
  s.model_file = optionalPath(tool, "model_file", dir);
  s.locations["AnalyzeTool"] = tool.where();
  for (const xml::Node& c : tool.children()) s.locations[c.name()] = c.where();
  if (s.model_file.empty()) tool.fail("missing <model_file>");
  s.replace_force_set = tool.childBool("replace_force_set", false);
  if (xml::Node f = tool.child("force_set_files"))
    for (const std::string& w : f.toWords()) s.force_set_files.push_back(xml::resolvePath(dir, w));
  s.states_file = optionalPath(tool, "states_file", dir);
  if (!optionalPath(tool, "speeds_file", dir).empty())
    tool.child("speeds_file").fail("expected no speeds file (kneesim differentiates the coordinates, as OpenSim does without one)");
  s.external_loads_file = optionalPath(tool, "external_loads_file", dir);
  s.coordinates_file = optionalPath(tool, "coordinates_file", dir);
  if (s.coordinates_file.empty() && s.states_file.empty())
    tool.fail("missing <coordinates_file> (expected the .mot of the coordinates, e.g. IK's output)");
  // OpenSim writes into the setup's folder when results_directory is empty.
  const std::string results = optionalPath(tool, "results_directory", dir);
  s.results_directory = results.empty() ? xml::resolvePath(dir, ".") : results;
  s.cutoff_hz = finiteChild(tool, "lowpass_cutoff_frequency_for_coordinates", -1.0, "a number of Hz (negative for none)");
  s.initial_time = finiteChild(tool, "initial_time", s.initial_time, "a time in s");
  s.final_time = finiteChild(tool, "final_time", s.final_time, "a time in s");
  if (xml::Node set = tool.child("AnalysisSet")) {
    xml::Node objects = set.child("objects");
    for (const xml::Node& a : objects ? objects.children() : std::vector<xml::Node>{}) {
      if (a.name() == "StaticOptimization")
        readStaticOptimization(a, s);
      else if (a.name() == "JointReaction")
        readJointReaction(a, dir, s);
      else
        a.fail("unknown analysis <" + a.name() + "> (expected StaticOptimization or JointReaction)");
    }
  }
  if (!s.so_on && !s.jr_on)
    tool.fail("expected an <AnalysisSet> with a StaticOptimization or a JointReaction that is <on>, got none");
  if (s.so_on && s.coordinates_file.empty())
    tool.fail("static optimization needs a <coordinates_file> (a states file gives no accelerations to kneesim)");
  return s;
}

namespace {

/// The motion an AnalyzeTool analyses: a coordinate file splined as OpenSim does, or a states file
/// read row by row.
class AnalyzeMotion {
 public:
  AnalyzeMotion(const AnalyzeSetup& setup, const model::Model& model, std::vector<std::string>& warnings)
      : n_(int(model.coordinates.size())) {
    const bool use_states = setup.coordinates_file.empty();
    const std::string file = use_states ? setup.states_file : setup.coordinates_file;
    if (!pathExists(file))
      throw InputError(setup.locate(use_states ? "states_file" : "coordinates_file"), "file not found: " + file);
    if (!use_states) {
      const io::Storage coords = io::readStorage(file);
      dynamics::CoordinateSmoothingOptions smoothing;
      smoothing.cutoff_hz = setup.cutoff_hz;
      smoothing.in_degrees = setup.in_degrees >= 0 ? setup.in_degrees == 1 : dynamics::fileSaysDegrees(coords);
      traj_ = std::make_unique<dynamics::CoordinateTrajectories>(model, coords, file, smoothing);
      for (const std::string& c : traj_->getMissing())
        warnings.push_back("coordinate '" + c + "' is not in the coordinates file: held at its default value");
      splined_ = std::make_unique<AnalyzeTrajectory>(*traj_, n_);
      return;
    }
    states_ = io::readStorage(file);
    const int time = states_.findColumn("time");
    if (time < 0 || states_.getNumRows() < 1) throw InputError({file, 0, "time"}, "expected a time column and rows, got none");
    for (int r = 0; r < states_.getNumRows(); ++r) times_.push_back(states_.data(r, time));
    for (const model::Coordinate& c : model.coordinates) {
      q_col_.push_back(dynamics::findCoordinateColumn(states_, c.name));
      int u = states_.findColumn(c.name + "_u");
      for (size_t k = 0; u < 0 && k < states_.labels.size(); ++k)
        if (endsWith(states_.labels[k], "/" + c.name + "/speed")) u = int(k);
      u_col_.push_back(u);
      defaults_.push_back(c.default_value);
      to_si_.push_back(states_.in_degrees && c.motion_type == model::MotionType::Rotational ? M_PI / 180.0 : 1.0);
      if (q_col_.back() < 0) warnings.push_back("coordinate '" + c.name + "' is not in the states file: held at its default value");
    }
    for (int r = 0; r < states_.getNumRows(); ++r)
      for (int k = 1; k < int(states_.labels.size()); ++k)
        if (!std::isfinite(states_.data(r, k)))
          throw InputError({file, 0, states_.labels[k]}, "expected a finite value at t = " + formatSignificant(times_[r], 6) + " s, got NaN");
  }

  /// The frames OpenSim analyses in [t0, t1], every @p step-th.
  std::vector<double> selectTimes(double t0, double t1, int step, const SourceLocation& where) const {
    const std::vector<double>& all = traj_ ? traj_->getTimes() : times_;
    const double first = traj_ ? traj_->getStartTime() : times_.front(), last = traj_ ? traj_->getEndTime() : times_.back();
    std::vector<double> times = dynamics::selectFrameTimes(all, t0, t1, first, last);
    if (times.empty())
      throw InputError(where, "expected a time range overlapping the motion (" + formatSignificant(first, 6) + " to " +
                                  formatSignificant(last, 6) + " s), got " + formatSignificant(t0, 6) + " to " +
                                  formatSignificant(t1, 6) + " s");
    std::vector<double> kept;
    for (size_t f = 0; f < times.size(); f += size_t(step)) kept.push_back(times[f]);
    return kept;
  }

  /// q, qdot and (coordinates only) qddot at frame time @p t.
  void calcAt(double t, Eigen::VectorXd& q, Eigen::VectorXd& qdot, Eigen::VectorXd& qddot) const {
    if (splined_) return splined_->calcAt(t, q, qdot, qddot);
    const int r = int(std::lower_bound(times_.begin(), times_.end(), t - 1e-12) - times_.begin());
    for (int c = 0; c < n_; ++c) {
      q[c] = q_col_[c] < 0 ? defaults_[c] : states_.data(r, q_col_[c]) * to_si_[c];
      qdot[c] = u_col_[c] < 0 ? 0.0 : states_.data(r, u_col_[c]) * to_si_[c];
      qddot[c] = 0.0;
    }
  }

 private:
  int n_;
  std::unique_ptr<dynamics::CoordinateTrajectories> traj_;
  std::unique_ptr<AnalyzeTrajectory> splined_;
  io::Storage states_;
  std::vector<double> times_, defaults_, to_si_;
  std::vector<int> q_col_, u_col_;
};

void runStaticOptimization(const AnalyzeSetup& setup, const std::shared_ptr<const dynamics::InverseDynamics>& id,
                           const AnalyzeMotion& motion, const dynamics::ExternalLoads* loads, AnalyzeReport& report,
                           AtomicFileSet& out) {
  const model::Model& model = id->getModel();
  const int n = int(model.coordinates.size());
  const double t0 = std::max(setup.initial_time, setup.so_start), t1 = std::min(setup.final_time, setup.so_end);
  const std::vector<double> times = motion.selectTimes(t0, t1, setup.step_interval, setup.locate("initial_time"));
  const StaticOptimization so(id, setup.so);
  auto ws = so.createWorkspace();
  const int na = int(so.getActuators().size());
  Eigen::MatrixXd activations(times.size(), na), forces(times.size(), na);
  Eigen::VectorXd q(n), qdot(n), qddot(n);
  std::vector<int> reserve_frames(size_t(na), 0);
  const double cpu0 = cpuSeconds();
  for (size_t f = 0; f < times.size(); ++f) {
    motion.calcAt(times[f], q, qdot, qddot);
    const SoFrameStatus st = so.solveFrame(*ws, times[f], q, qdot, qddot, loads);
    activations.row(Eigen::Index(f)) = ws->getActivations().transpose();
    forces.row(Eigen::Index(f)) = ws->getForces().transpose();
    for (int j = 0; j < na; ++j)
      if (!so.getActuators()[j].is_muscle && std::abs(ws->getActivations()[j]) >= 0.05) ++reserve_frames[j];
    // The equations of motion hold to the solver's tolerance (< 1e-3 N·m).
    if (!st.converged || st.max_violation > 1e-3) {
      ++report.failed_frames;
      report.warnings.push_back(
          "t = " + formatSignificant(times[f], 6) + " s: " + (st.converged ? "" : "the optimizer did not converge; ") +
          "the actuators fall short of inverse dynamics by " + formatSignificant(st.max_violation, 4) + " on coordinate '" +
          (st.worst_coordinate >= 0 ? model.coordinates[st.worst_coordinate].name : std::string("?")) +
          "' (too weak without reserve actuators?)");
    }
  }
  report.seconds_solving = cpuSeconds() - cpu0;
  report.frames = int(times.size());
  for (int j = 0; j < na; ++j)
    if (!so.getActuators()[j].is_muscle) report.reserve_frames.emplace_back(so.getActuators()[j].name, reserve_frames[j]);
  report.activations = makeActuatorStorage(so, times, activations);
  report.forces = makeActuatorStorage(so, times, forces);
  const std::string base = xml::resolvePath(setup.results_directory, setup.name + "_" + setup.so_name);
  out.addContents(base + "_activation.sto", io::formatStorage(report.activations));
  out.addContents(base + "_force.sto", io::formatStorage(report.forces));
}

/// The actuator forces of a forces file at time t, linearly interpolated (held beyond its ends).
class ActuatorForces {
 public:
  ActuatorForces(const model::Model& model, const std::string& file, std::vector<std::string>& warnings) {
    if (file.empty()) return;
    table_ = io::readStorage(file);
    time_ = table_.findColumn("time");
    if (time_ < 0 || table_.getNumRows() < 1) throw InputError({file, 0, "time"}, "expected a time column and rows, got none");
    auto add = [&](const std::string& name, bool muscle, int index) {
      const int col = table_.findColumn(name);
      if (col < 0) warnings.push_back("actuator '" + name + "' is not in the forces file: no force");
      else columns_.push_back({col, muscle, index});
    };
    for (size_t i = 0; i < model.muscles.size(); ++i)
      if (model.muscles[i].enabled) add(model.muscles[i].name, true, int(i));
    for (size_t i = 0; i < model.actuators.size(); ++i)
      if (model.actuators[i].enabled) add(model.actuators[i].name, false, int(i));
  }
  /// Adds the forces at @p t: muscles along their paths (realised in @p pws) into @p F and @p
  /// mobility, coordinate actuators into @p mobility.
  void addLoads(double t, const model::Model& model, const PathSet& paths, const PathWorkspace& pws,
                sim::SpatialColumns& F, Eigen::VectorXd& mobility) const {
    if (columns_.empty()) return;
    const int rows = table_.getNumRows();
    int r = 0;
    while (r + 1 < rows && table_.data(r + 1, time_) <= t) ++r;
    const int r1 = std::min(r + 1, rows - 1);
    const double span = table_.data(r1, time_) - table_.data(r, time_);
    const double w = span > 0 ? std::clamp((t - table_.data(r, time_)) / span, 0.0, 1.0) : 0.0;
    for (const Column& c : columns_) {
      const double f = (1 - w) * table_.data(r, c.col) + w * table_.data(r1, c.col);
      if (c.muscle)
        paths.addLoads(pws, c.index, f, F, mobility);
      else
        mobility[model.actuators[c.index].coordinate] += f;
    }
  }

 private:
  struct Column {
    int col;
    bool muscle;
    int index;
  };
  io::Storage table_;
  int time_ = -1;
  std::vector<Column> columns_;
};

void runJointReaction(const AnalyzeSetup& setup, const std::shared_ptr<const dynamics::InverseDynamics>& id,
                      const AnalyzeMotion& motion, const dynamics::ExternalLoads* loads, AnalyzeReport& report,
                      AtomicFileSet& out) {
  const model::Model& model = id->getModel();
  const sim::System& system = id->getSystem();
  const int n = int(model.coordinates.size());
  const std::vector<ReactionRequest> requests =
      resolveReactions(model, setup.jr_joints, setup.jr_on_bodies, setup.jr_frames, setup.locate("JointReaction/joint_names"));
  if (!setup.jr_forces_file.empty() && !pathExists(setup.jr_forces_file))
    throw InputError(setup.locate("JointReaction/forces_file"), "forces file not found: " + setup.jr_forces_file);
  const ActuatorForces forces(model, setup.jr_forces_file, report.warnings);
  const double t0 = std::max(setup.initial_time, setup.jr_start), t1 = std::min(setup.final_time, setup.jr_end);
  const std::vector<double> times = motion.selectTimes(t0, t1, 1, setup.locate("initial_time"));
  const PathSet paths(system);
  auto pws = paths.createWorkspace();
  auto ws = id->createWorkspace();
  ForwardAccelerations forward(*id);
  Eigen::VectorXd q(n), qdot(n), qddot(n), mobility(n);
  sim::SpatialColumns F_joint = sim::SpatialColumns::Zero(6, Eigen::Index(model.bodies.size()));
  io::Storage& s = report.reactions;
  s.name = "Joint Reaction Loads";
  s.labels = {"time"};
  for (const std::string& l : reactionLabels(model, requests)) s.labels.push_back(l);
  s.data.resize(Eigen::Index(times.size()), Eigen::Index(s.labels.size()));
  for (size_t f = 0; f < times.size(); ++f) {
    motion.calcAt(times[f], q, qdot, qddot);
    id->setState(*ws, q, qdot);
    if (loads) loads->addBodyForces(system, ws->getSimWorkspace(), times[f], ws->updAppliedForces());
    mobility.setZero();
    paths.realize(ws->getSimWorkspace(), q, *pws);
    forces.addLoads(times[f], model, paths, *pws, ws->updAppliedForces(), mobility);
    forward.calc(*ws, q, qdot, mobility, qddot);
    id->calcJointLoads(*ws, qddot, F_joint);
    s.data(Eigen::Index(f), 0) = times[f];
    for (size_t k = 0; k < requests.size(); ++k) {
      double v[9];
      calcReaction(system, ws->getSimWorkspace(), F_joint, requests[k], v);
      for (int i = 0; i < 9; ++i) s.data(Eigen::Index(f), Eigen::Index(1 + 9 * k + i)) = v[i];
    }
  }
  s.header.emplace_back("inDegrees", "no");
  report.reaction_frames = int(times.size());
  out.addContents(xml::resolvePath(setup.results_directory, setup.name + "_" + setup.jr_name + "_ReactionLoads.sto"),
                  io::formatStorage(s));
}

}  // namespace

AnalyzeReport runAnalyzeTool(const AnalyzeSetup& setup) {
  AnalyzeReport report;
  const model::ModelPtr model = loadAnalyzeModel(setup);
  for (const model::IgnoredComponent& c : model->ignored)
    if (endsWith(c.type, "Muscle") || endsWith(c.type, "Actuator") || endsWith(c.type, "Force") || endsWith(c.type, "Ligament"))
      report.warnings.push_back(c.type + " " + c.name + " is not simulated: the analyses leave it out");
  const AnalyzeMotion motion(setup, *model, report.warnings);
  std::unique_ptr<dynamics::ExternalLoads> loads;
  if (!setup.external_loads_file.empty()) {
    if (!pathExists(setup.external_loads_file))
      throw InputError(setup.locate("external_loads_file"), "ExternalLoads file not found: " + setup.external_loads_file);
    loads = std::make_unique<dynamics::ExternalLoads>(dynamics::readExternalLoads(setup.external_loads_file), *model);
  }
  const auto id = std::make_shared<const dynamics::InverseDynamics>(model);
  AtomicFileSet out;
  if (setup.so_on) runStaticOptimization(setup, id, motion, loads.get(), report, out);
  if (setup.jr_on) runJointReaction(setup, id, motion, loads.get(), report, out);
  out.commit();
  report.outputs = out.getPaths();
  return report;
}

void printAnalyzeSummary(const AnalyzeReport& report, std::ostream& os) {
  if (report.reaction_frames > 0) os << "Joint reaction: " << report.reaction_frames << " frames\n";
  if (report.frames == 0) {
    for (const std::string& w : report.warnings) os << "  warning: " << w << "\n";
    for (const std::string& f : report.outputs) os << "  wrote " << f << "\n";
    return;
  }
  os << "Static optimization: " << report.frames << " frames, " << std::fixed << std::setprecision(2)
     << 1e3 * report.seconds_solving / std::max(1, report.frames) << " ms per frame (CPU)";
  os.unsetf(std::ios::floatfield);
  if (report.failed_frames > 0) os << ", " << report.failed_frames << " frames short of inverse dynamics";
  os << "\n";
  for (const auto& [name, frames] : report.reserve_frames)
    if (frames > 0) os << "  reserve " << name << " carries >= 5 % of its optimal force in " << frames << " frames\n";
  const size_t shown = std::min<size_t>(report.warnings.size(), 20);
  for (size_t i = 0; i < shown; ++i) os << "  warning: " << report.warnings[i] << "\n";
  if (shown < report.warnings.size()) os << "  (" << report.warnings.size() - shown << " more warnings)\n";
  for (const std::string& f : report.outputs) os << "  wrote " << f << "\n";
}

}  // namespace kneesim::muscle
