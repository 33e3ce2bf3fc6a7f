// OpenSim's AnalyzeTool running StaticOptimization: setup, frame loop, result files.
#include "muscle/analyze_tool.hpp"

#include <cmath>
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <set>

#include "core/strings.hpp"
#include "core/xml.hpp"
#include "dynamics/coordinate_smoothing.hpp"
#include "dynamics/tool.hpp"
#include "dynamics/trajectory.hpp"
#include "model/osim_forces.hpp"
#include "model/osim_reader.hpp"

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

void readStaticOptimization(const xml::Node& so, AnalyzeSetup& s) {
  xml::checkChildren(so, {"on", "start_time", "end_time", "step_interval", "in_degrees", "use_model_force_set",
                          "activation_exponent", "use_muscle_physiology", "optimizer_convergence_criterion",
                          "optimizer_max_iterations"});
  for (const xml::Node& c : so.children()) s.locations["StaticOptimization/" + c.name()] = c.where();
  s.so_on = so.childBool("on", true);
  if (!so.nameAttr().empty()) s.so_name = so.nameAttr();
  s.so_start = finiteChild(so, "start_time", s.so_start, "a time in s");
  s.so_end = finiteChild(so, "end_time", s.so_end, "a time in s");
  s.step_interval = int(finiteChild(so, "step_interval", 1, "a positive integer"));
  if (s.step_interval < 1) so.child("step_interval").fail("expected a positive integer, got " + so.childText("step_interval"));
  if (!so.childBool("use_model_force_set", true))
    so.child("use_model_force_set").fail("expected true (kneesim optimises the model's own actuators), got false");
  s.so.activation_exponent = finiteChild(so, "activation_exponent", 2.0, "an exponent >= 1");
  if (!(s.so.activation_exponent >= 1.0))
    so.child("activation_exponent").fail("expected an exponent >= 1, got " + so.childText("activation_exponent"));
  s.so.use_muscle_physiology = so.childBool("use_muscle_physiology", true);
  s.so.convergence = finiteChild(so, "optimizer_convergence_criterion", 1e-4, "a positive tolerance");
  if (!(s.so.convergence > 0))
    so.child("optimizer_convergence_criterion").fail("expected a positive tolerance, got " + so.childText("optimizer_convergence_criterion"));
  s.so.max_iterations = int(finiteChild(so, "optimizer_max_iterations", 100, "a positive count"));
  if (s.so.max_iterations < 1)
    so.child("optimizer_max_iterations").fail("expected a positive count, got " + so.childText("optimizer_max_iterations"));
}

double cpuSeconds() { return double(std::clock()) / CLOCKS_PER_SEC; }

model::ModelPtr loadAnalyzeModel(const AnalyzeSetup& setup) {
  if (!fs::exists(setup.model_file)) throw InputError(setup.locate("model_file"), "model file not found: " + setup.model_file);
  model::ModelPtr model = model::readOsim(setup.model_file);
  bool replace = setup.replace_force_set;
  for (const std::string& f : setup.force_set_files) {
    if (!fs::exists(f)) throw InputError(setup.locate("force_set_files"), "actuator set file not found: " + f);
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

io::Storage makeSoStorage(const StaticOptimization& so, const std::vector<double>& times, const Eigen::MatrixXd& values) {
  io::Storage s;
  s.name = "Static Optimization";
  s.labels.push_back("time");
  for (const SoActuator& a : so.getActuators()) s.labels.push_back(a.name);
  s.data.resize(Eigen::Index(times.size()), Eigen::Index(s.labels.size()));
  for (size_t f = 0; f < times.size(); ++f) {
    s.data(Eigen::Index(f), 0) = times[f];
    s.data.row(Eigen::Index(f)).tail(values.cols()) = values.row(Eigen::Index(f));
  }
  s.header.emplace_back("inDegrees", "no");
  return s;
}

}  // namespace

AnalyzeSetup readAnalyzeSetup(const std::string& path) {
  static const std::set<std::string> elements = {
      "model_file", "replace_force_set", "force_set_files", "results_directory", "output_precision", "initial_time",
      "final_time", "solve_for_equilibrium_for_auxiliary_states", "maximum_number_of_integrator_steps",
      "maximum_integrator_step_size", "minimum_integrator_step_size", "integrator_error_tolerance", "AnalysisSet",
      "ControllerSet", "external_loads_file", "states_file", "coordinates_file", "speeds_file",
      "lowpass_cutoff_frequency_for_coordinates"};
  if (!fs::exists(path)) throw InputError({path, 0, ""}, "setup file not found");
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
  if (!optionalPath(tool, "states_file", dir).empty())
    tool.child("states_file").fail("expected <coordinates_file> instead (kneesim reads coordinates, not states), got a states file");
  if (!optionalPath(tool, "speeds_file", dir).empty())
    tool.child("speeds_file").fail("expected no speeds file (kneesim differentiates the coordinates, as OpenSim does without one)");
  s.external_loads_file = optionalPath(tool, "external_loads_file", dir);
  s.coordinates_file = optionalPath(tool, "coordinates_file", dir);
  if (s.coordinates_file.empty()) tool.fail("missing <coordinates_file> (expected the .mot of the coordinates, e.g. IK's output)");
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
      else
        a.fail("unknown analysis <" + a.name() + "> (expected StaticOptimization)");
    }
  }
  if (!s.so_on) tool.fail("expected an <AnalysisSet> with a StaticOptimization that is <on>, got none");
  return s;
}

AnalyzeReport runAnalyzeTool(const AnalyzeSetup& setup) {
  AnalyzeReport report;
  const model::ModelPtr model = loadAnalyzeModel(setup);
  for (const model::IgnoredComponent& c : model->ignored)
    if (endsWith(c.type, "Muscle") || endsWith(c.type, "Actuator") || endsWith(c.type, "Force") || endsWith(c.type, "Ligament"))
      report.warnings.push_back(c.type + " " + c.name + " is not simulated: static optimization leaves it out");
  if (!fs::exists(setup.coordinates_file))
    throw InputError(setup.locate("coordinates_file"), "coordinates file not found: " + setup.coordinates_file);
  const io::Storage coords = io::readStorage(setup.coordinates_file);
  dynamics::CoordinateSmoothingOptions smoothing;
  smoothing.cutoff_hz = setup.cutoff_hz;
  smoothing.in_degrees = setup.in_degrees >= 0 ? setup.in_degrees == 1 : dynamics::fileSaysDegrees(coords);
  const dynamics::CoordinateTrajectories traj(*model, coords, setup.coordinates_file, smoothing);
  for (const std::string& c : traj.getMissing())
    report.warnings.push_back("coordinate '" + c + "' is not in the coordinates file: held at its default value");
  const int n = int(model->coordinates.size());
  const AnalyzeTrajectory states(traj, n);

  std::unique_ptr<dynamics::ExternalLoads> loads;
  if (!setup.external_loads_file.empty()) {
    if (!fs::exists(setup.external_loads_file))
      throw InputError(setup.locate("external_loads_file"), "ExternalLoads file not found: " + setup.external_loads_file);
    loads = std::make_unique<dynamics::ExternalLoads>(dynamics::readExternalLoads(setup.external_loads_file), *model);
  }
  const double t0 = std::max(setup.initial_time, setup.so_start), t1 = std::min(setup.final_time, setup.so_end);
  std::vector<double> times = dynamics::selectFrameTimes(traj.getTimes(), t0, t1, traj.getStartTime(), traj.getEndTime());
  if (times.empty())
    throw InputError(setup.locate("initial_time"), "expected a time range overlapping the coordinates (" +
                                                       formatSignificant(traj.getStartTime(), 6) + " to " +
                                                       formatSignificant(traj.getEndTime(), 6) + " s), got " +
                                                       formatSignificant(t0, 6) + " to " + formatSignificant(t1, 6) + " s");
  if (setup.step_interval > 1) {
    std::vector<double> kept;
    for (size_t f = 0; f < times.size(); f += size_t(setup.step_interval)) kept.push_back(times[f]);
    times.swap(kept);
  }

  const auto id = std::make_shared<const dynamics::InverseDynamics>(model);
  const StaticOptimization so(id, setup.so);
  auto ws = so.createWorkspace();
  const int na = int(so.getActuators().size());
  Eigen::MatrixXd activations(times.size(), na), forces(times.size(), na);
  Eigen::VectorXd q(n), qdot(n), qddot(n);
  std::vector<int> reserve_frames(size_t(na), 0);
  const double cpu0 = cpuSeconds();
  for (size_t f = 0; f < times.size(); ++f) {
    states.calcAt(times[f], q, qdot, qddot);
    const SoFrameStatus st = so.solveFrame(*ws, times[f], q, qdot, qddot, loads.get());
    activations.row(Eigen::Index(f)) = ws->getActivations().transpose();
    forces.row(Eigen::Index(f)) = ws->getForces().transpose();
    for (int j = 0; j < na; ++j)
      if (!so.getActuators()[j].is_muscle && std::abs(ws->getActivations()[j]) >= 0.05) ++reserve_frames[j];
    // The equations of motion hold to Ipopt's tolerance, scaled to the moment arms (< 1e-3 N·m).
    if (!st.converged || st.max_violation > 1e-3) {
      ++report.failed_frames;
      report.warnings.push_back(
          "t = " + formatSignificant(times[f], 6) + " s: " + (st.converged ? "" : "the optimizer did not converge; ") +
          "the actuators fall short of inverse dynamics by " + formatSignificant(st.max_violation, 4) + " on coordinate '" +
          (st.worst_coordinate >= 0 ? model->coordinates[st.worst_coordinate].name : std::string("?")) +
          "' (too weak without reserve actuators?)");
    }
  }
  report.seconds_solving = cpuSeconds() - cpu0;
  report.frames = int(times.size());
  for (int j = 0; j < na; ++j)
    if (!so.getActuators()[j].is_muscle) report.reserve_frames.emplace_back(so.getActuators()[j].name, reserve_frames[j]);

  report.activations = makeSoStorage(so, times, activations);
  report.forces = makeSoStorage(so, times, forces);
  AtomicFileSet out;
  const std::string base = xml::resolvePath(setup.results_directory, setup.name + "_" + setup.so_name);
  out.addContents(base + "_activation.sto", io::formatStorage(report.activations));
  out.addContents(base + "_force.sto", io::formatStorage(report.forces));
  out.commit();
  report.outputs = out.getPaths();
  return report;
}

void printAnalyzeSummary(const AnalyzeReport& report, std::ostream& os) {
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
