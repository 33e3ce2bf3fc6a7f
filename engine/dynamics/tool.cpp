#include "dynamics/tool.hpp"

#include <ctime>
#include <filesystem>
#include <iomanip>
#include <set>

#include "core/paths.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "model/read_model.hpp"

namespace kneesim::dynamics {

namespace fs = std::filesystem;

SourceLocation IdSetup::locate(const std::string& element) const {
  auto it = locations.find(element);
  if (it != locations.end()) return it->second;
  auto tool = locations.find("InverseDynamicsTool");
  return tool != locations.end() ? tool->second : SourceLocation{setup_file, 0, element};
}

std::string optionalPath(const xml::Node& tool, const char* tag, const std::string& dir) {
  const std::string v = tool.childText(tag);
  if (v.empty() || v == "Unassigned") return "";
  return xml::resolvePath(dir, v);
}

bool fileSaysDegrees(const io::Storage& s) {
  if (s.in_degrees) return true;
  for (const auto& [k, v] : s.header)
    if (equalsIgnoreCase(k, "Angles") && startsWith(toLower(v), "are in degrees")) return true;
  return false;
}

namespace {

/// results_directory/name, with ".sto" added when the name has no .sto or .mot extension.
std::string outputPath(const std::string& results_dir, std::string name) {
  const std::string low = toLower(name);
  if (!endsWith(low, ".sto") && !endsWith(low, ".mot")) name += ".sto";
  return xml::resolvePath(results_dir, name);
}

/// <ForcePlates> of an InverseDynamicsTool setup.
void readForcePlates(const xml::Node& fp, const std::string& dir, IdSetup& s) {
  xml::checkChildren(fp, {"c3d_file", "threshold", "lowpass_cutoff_frequency", "marker_rotation", "Foot", "output_grf_file"});
  if (!s.external_loads_file.empty()) fp.fail("expected either <external_loads_file> or <ForcePlates>, got both");
  s.locations["ForcePlates"] = fp.where();
  s.plates_c3d_file = optionalPath(fp, "c3d_file", dir);
  if (s.plates_c3d_file.empty()) fp.fail("missing <c3d_file>");
  s.plates.threshold_n = fp.childDouble("threshold", 20.0);
  if (!(s.plates.threshold_n > 0)) fp.child("threshold").fail("expected a threshold > 0 N, got " + fp.childText("threshold"));
  s.plates.cutoff_hz = fp.childDouble("lowpass_cutoff_frequency", 30.0);
  s.plates.rotation_deg = fp.childVec3("marker_rotation", Eigen::Vector3d::Zero());
  for (const xml::Node& f : fp.children("Foot")) {
    xml::checkChildren(f, {"body", "markers"});
    FootSpec foot;
    foot.name = f.nameAttr();
    if (foot.name.empty()) f.fail("expected a name attribute (the prefix of the foot's GRF columns), got none");
    foot.body = f.childText("body");
    foot.markers = f.child("markers") ? f.child("markers").toWords() : std::vector<std::string>{};
    if (foot.markers.empty()) f.fail("expected <markers> over the foot (e.g. RHeel RToe), got none");
    foot.where = f.where();
    s.plates.feet.push_back(foot);
  }
  if (s.plates.feet.empty()) fp.fail("expected at least one <Foot>, got none");
  std::string grf = fp.childText("output_grf_file");
  if (grf.empty()) grf = (s.name.empty() ? std::string("inverse_dynamics") : s.name) + "_grf.mot";
  s.output_grf_file = outputPath(s.results_directory, grf);
}

}  // namespace

IdSetup readIdSetup(const std::string& path) {
  if (!pathExists(path)) throw InputError({path, 0, ""}, "setup file not found");
  auto doc = xml::Document::load(path);
  const xml::Node tool = xml::requireSetupElement(*doc, "InverseDynamicsTool");
  IdSetup s;
  s.setup_file = path;
  s.name = tool.nameAttr();
  s.locations["InverseDynamicsTool"] = tool.where();
  xml::checkChildren(tool, {"model_file", "coordinates_file", "external_loads_file", "lowpass_cutoff_frequency_for_coordinates",
                            "time_range", "forces_to_exclude", "results_directory", "output_gen_force_file",
                            "coordinates_in_degrees", "joints_to_report_body_forces", "output_body_forces_file",
                            "joint_loads", "joint_loads_on", "joint_loads_expressed_in", "output_joint_loads_file",
                            "ForcePlates", "KneeLoads"});
  for (const xml::Node& c : tool.children()) s.locations[c.name()] = c.where();
  const std::string dir = fs::path(path).parent_path().string();
  s.model_file = optionalPath(tool, "model_file", dir);
  if (s.model_file.empty()) tool.fail("missing <model_file>");
  s.coordinates_file = optionalPath(tool, "coordinates_file", dir);
  if (s.coordinates_file.empty()) tool.fail("missing <coordinates_file> (expected the .mot of the coordinates, e.g. IK's output)");
  s.external_loads_file = optionalPath(tool, "external_loads_file", dir);
  std::string results = tool.childText("results_directory");
  if (results.empty() || results == "Unassigned") results = ".";
  s.results_directory = xml::resolvePath(dir, results);
  std::string out = tool.childText("output_gen_force_file");
  if (out.empty() || out == "Unassigned") out = "inverse_dynamics.sto";
  s.output_gen_force_file = outputPath(s.results_directory, out);
  std::string jl = tool.childText("output_joint_loads_file");
  if (jl.empty() || jl == "Unassigned") jl = (s.name.empty() ? std::string("inverse_dynamics") : s.name) + "_joint_loads.sto";
  s.output_joint_loads_file = outputPath(s.results_directory, jl);
  s.cutoff_hz = tool.childDouble("lowpass_cutoff_frequency_for_coordinates", -1.0);
  if (!std::isfinite(s.cutoff_hz))
    tool.child("lowpass_cutoff_frequency_for_coordinates").fail("expected a number of Hz (negative for none), got " +
                                                                tool.childText("lowpass_cutoff_frequency_for_coordinates"));
  if (xml::Node tr = tool.child("time_range"); tr && !tr.text().empty()) {
    const auto v = tr.toDoubles();
    if (v.size() != 2) tr.fail("expected 2 numbers (start end), got " + std::to_string(v.size()));
    if (!(v[0] <= v[1])) tr.fail("expected start <= end, got " + tr.text());
    s.time_start = v[0];
    s.time_end = v[1];
  }
  if (xml::Node d = tool.child("coordinates_in_degrees"); d && !d.text().empty()) s.coordinates_in_degrees = d.toBool() ? 1 : 0;
  s.forces_to_exclude = tool.child("forces_to_exclude") ? tool.child("forces_to_exclude").toWords() : std::vector<std::string>{};
  if (xml::Node j = tool.child("joints_to_report_body_forces")) s.joints_to_report_body_forces = j.toWords();
  if (xml::Node j = tool.child("joint_loads")) s.joint_loads = j.toWords();
  try {
    if (xml::Node n = tool.child("joint_loads_on"); n && !n.text().empty()) s.joint_loads_on = parseLoadOnBody(n.text());
  } catch (const std::invalid_argument& e) {
    tool.child("joint_loads_on").fail(e.what());
  }
  try {
    if (xml::Node n = tool.child("joint_loads_expressed_in"); n && !n.text().empty())
      s.joint_loads_frame = parseLoadFrame(n.text());
  } catch (const std::invalid_argument& e) {
    tool.child("joint_loads_expressed_in").fail(e.what());
  }
  if (const xml::Node fp = tool.child("ForcePlates")) readForcePlates(fp, dir, s);
  if (const xml::Node k = tool.child("KneeLoads")) {
    xml::checkChildren(k, {"joint", "axes", "output_file"});
    s.locations["KneeLoads"] = k.where();
    s.knee_joint = k.childText("joint");
    if (s.knee_joint.empty()) k.fail("missing <joint> (the knee joint, whose child is the tibial body)");
    try {
      s.knee_axes = parseKneeAxes(k.childText("axes", "posterior superior medial"));
    } catch (const std::invalid_argument& e) {
      (k.child("axes") ? k.child("axes") : k).fail(e.what());
    }
    std::string f = k.childText("output_file");
    if (f.empty()) f = (s.name.empty() ? std::string("inverse_dynamics") : s.name) + "_knee_loads.sto";
    s.output_knee_loads_file = outputPath(s.results_directory, f);
  }
  return s;
}

namespace {

double cpuSeconds() { return double(std::clock()) / CLOCKS_PER_SEC; }

model::ModelPtr loadModel(const IdSetup& setup) {
  if (!pathExists(setup.model_file)) throw InputError(setup.locate("model_file"), "model file not found: " + setup.model_file);
  return model::readModel(setup.model_file);
}

/// Whether an ignored model component is a force OpenSim would apply in inverse dynamics.
bool isForceType(const std::string& type) {
  return endsWith(type, "Muscle") || endsWith(type, "Actuator") || endsWith(type, "Force") || endsWith(type, "Ligament") ||
         endsWith(type, "Spring") || endsWith(type, "Damper") || endsWith(type, "Bushing") || type == "Blankevoort1991Ligament";
}

/// The model forces OpenSim would apply that forces_to_exclude does not exclude.
std::vector<std::string> forcesNotExcluded(const model::Model& m, const std::vector<std::string>& exclude) {
  std::set<std::string> ex;
  for (const std::string& e : exclude) ex.insert(toLower(e));
  if (ex.count("all")) return {};
  std::vector<std::string> out;
  // Muscles and coordinate actuators the model keeps (for static optimisation) count as well.
  std::vector<model::IgnoredComponent> forces = m.ignored;
  for (const model::Muscle& mu : m.muscles)
    if (mu.enabled) forces.push_back({mu.type, mu.name});
  for (const model::CoordinateActuator& a : m.actuators)
    if (a.enabled) forces.push_back({"CoordinateActuator", a.name});
  for (const model::IgnoredComponent& c : forces) {
    if (!isForceType(c.type)) continue;
    const bool muscle = endsWith(c.type, "Muscle");
    const bool actuator = muscle || endsWith(c.type, "Actuator");
    if (ex.count(toLower(c.name)) || (muscle && ex.count("muscles")) || (actuator && ex.count("actuators"))) continue;
    out.push_back(c.type + " " + c.name);
  }
  return out;
}

std::vector<JointLoadRequest> resolveJointLoads(const IdSetup& setup, const model::Model& m) {
  std::vector<JointLoadRequest> out;
  for (const std::string& name : setup.joint_loads) {
    if (equalsIgnoreCase(name, "all")) {
      out.clear();
      for (size_t j = 0; j < m.joints.size(); ++j) out.push_back({int(j), setup.joint_loads_on, setup.joint_loads_frame});
      return out;
    }
    const int j = m.findJoint(name);
    if (j < 0) throw InputError(setup.locate("joint_loads"), "expected a joint of " + setup.model_file + ", got '" + name + "'");
    out.push_back({j, setup.joint_loads_on, setup.joint_loads_frame});
  }
  return out;
}

/// The external loads the setup names: the ground reactions of its force plates (kept in
/// @p plates for their outputs) or an ExternalLoads file; none when it names neither.
std::unique_ptr<ExternalLoads> readLoads(const IdSetup& setup, const model::Model& m,
                                         std::unique_ptr<GroundReactions>& plates, IdReport& report) {
  if (!setup.plates_c3d_file.empty()) {
    if (!pathExists(setup.plates_c3d_file))
      throw InputError(setup.locate("ForcePlates"), "C3D file not found: " + setup.plates_c3d_file);
    plates = std::make_unique<GroundReactions>(calcGroundReactions(io::readC3d(setup.plates_c3d_file), setup.plates));
    return std::make_unique<ExternalLoads>(plates->loads, m, plates->grf);
  }
  if (setup.external_loads_file.empty()) return nullptr;
  if (!pathExists(setup.external_loads_file))
    throw InputError(setup.locate("external_loads_file"), "ExternalLoads file not found: " + setup.external_loads_file);
  auto loads = std::make_unique<ExternalLoads>(readExternalLoads(setup.external_loads_file), m);
  if (!loads->getSpec().kinematics_file.empty())
    report.warnings.push_back("external_loads_model_kinematics_file is not used (as in OpenSim 4's InverseDynamicsTool)");
  return loads;
}

/// Throws InputError when the force data miss the analysed times altogether; warns when they
/// cover them only in part.
void checkLoadTimes(const IdSetup& setup, const ExternalLoads& loads, const std::vector<double>& times, IdReport& report) {
  // Within a microsecond: the analysed frames sit on OpenSim's resampled grid, which may start a
  // rounding error before the data's first row.
  const double a = times.front(), b = times.back(), eps = 1e-6;
  if (b < loads.getStartTime() - eps || a > loads.getEndTime() + eps)
    throw InputError(setup.locate(setup.plates_c3d_file.empty() ? "external_loads_file" : "ForcePlates"),
                     "expected force data overlapping the analysed times " + formatSignificant(a, 6) + " to " +
                         formatSignificant(b, 6) + " s, got " + formatSignificant(loads.getStartTime(), 6) + " to " +
                         formatSignificant(loads.getEndTime(), 6) + " s in " + loads.getSpec().datafile);
  if (a < loads.getStartTime() - eps || b > loads.getEndTime() + eps)
    report.warnings.push_back("the force data (" + formatSignificant(loads.getStartTime(), 6) + " to " +
                              formatSignificant(loads.getEndTime(), 6) +
                              " s) do not cover every analysed frame: their splines are extrapolated there");
}

/// Which foot each force plate's load went to (a note each), and a warning where the nearest
/// foot was far from the centre of pressure.
void reportAssignments(const GroundReactions& plates, IdReport& report) {
  for (const PlateAssignment& a : plates.assignments)
    report.notes.push_back("force plate " + std::to_string(a.plate + 1) + " loaded " + formatSignificant(a.start, 4) + "-" +
                           formatSignificant(a.end, 4) + " s: foot '" + a.foot + "' (its markers " +
                           formatSignificant(1e3 * a.distance_m, 3) + " mm from the centre of pressure)");
  for (const PlateAssignment& a : plates.assignments)
    if (a.distance_m > 0.2)
      report.warnings.push_back("force plate " + std::to_string(a.plate + 1) + " at " + formatSignificant(a.start, 4) +
                                "-" + formatSignificant(a.end, 4) + " s: the nearest foot's markers are " +
                                formatSignificant(1e3 * a.distance_m, 3) +
                                " mm from the centre of pressure (both feet on the plate?); all of it went to foot '" +
                                a.foot + "'");
}

}  // namespace

IdReport runInverseDynamicsTool(const IdSetup& setup, const IdRunOptions& options) {
  const double cpu0 = cpuSeconds();
  IdReport report;
  const model::ModelPtr model = loadModel(setup);
  for (const std::string& f : forcesNotExcluded(*model, setup.forces_to_exclude))
    report.warnings.push_back("OpenSim would apply " + f + " (not in forces_to_exclude); kneesim does not simulate it");
  if (!setup.joints_to_report_body_forces.empty())
    report.warnings.push_back("joints_to_report_body_forces is not written; joint_loads gives the net joint loads");

  if (!options.coordinates && !pathExists(setup.coordinates_file))
    throw InputError(setup.locate("coordinates_file"), "coordinates file not found: " + setup.coordinates_file);
  const io::Storage coords = options.coordinates ? *options.coordinates : io::readStorage(setup.coordinates_file);
  CoordinateSmoothingOptions so;
  so.cutoff_hz = setup.cutoff_hz;
  so.in_degrees = setup.coordinates_in_degrees >= 0 ? setup.coordinates_in_degrees == 1 : fileSaysDegrees(coords);
  const CoordinateTrajectories traj(*model, coords, setup.coordinates_file, so);
  for (const std::string& c : traj.getMissing())
    report.warnings.push_back("coordinate '" + c + "' is not in the coordinates file: held at its default value");

  std::unique_ptr<GroundReactions> plates;
  const std::unique_ptr<ExternalLoads> loads = readLoads(setup, *model, plates, report);

  const std::vector<double> times =
      selectFrameTimes(traj.getTimes(), setup.time_start, setup.time_end, traj.getStartTime(), traj.getEndTime());
  if (times.empty())
    throw InputError(setup.locate("time_range"), "expected a time range overlapping the coordinates (" +
                                                     formatSignificant(traj.getStartTime(), 6) + " to " +
                                                     formatSignificant(traj.getEndTime(), 6) + " s), got " +
                                                     formatSignificant(setup.time_start, 6) + " to " +
                                                     formatSignificant(setup.time_end, 6) + " s");
  if (loads) checkLoadTimes(setup, *loads, times, report);
  std::vector<JointLoadRequest> joints = resolveJointLoads(setup, *model);
  const size_t n_requested = joints.size();
  if (!setup.knee_joint.empty()) {
    const int k = model->findJoint(setup.knee_joint);
    if (k < 0)
      throw InputError(setup.locate("KneeLoads"), "expected a joint of " + setup.model_file + ", got '" + setup.knee_joint + "'");
    joints.push_back({k, LoadOnBody::Child, LoadFrame::Child});  // the last 9 columns
  }

  const InverseDynamics id(model);
  const double cpu1 = cpuSeconds();
  const TrajectoryResult result = calcInverseDynamicsTrajectory(id, traj, loads.get(), times, joints);
  report.seconds_solving = cpuSeconds() - cpu1;
  report.frames = int(times.size());
  report.generalized_forces = makeGeneralizedForceStorage(id.getSystem(), result);
  report.generalized_forces.header.emplace_back("inDegrees", "no");

  AtomicFileSet own;
  AtomicFileSet& out = options.stage ? *options.stage : own;
  const size_t before = out.getPaths().size();
  out.addContents(setup.output_gen_force_file, io::formatStorage(report.generalized_forces));
  if (plates) {
    stageGroundReactions(*plates, setup.output_grf_file, fs::path(setup.output_grf_file).replace_extension(".xml").string(), out);
    reportAssignments(*plates, report);
  }
  if (n_requested > 0) {
    const std::vector<JointLoadRequest> requested(joints.begin(), joints.begin() + long(n_requested));
    TrajectoryResult shown = result;
    shown.joint_loads = result.joint_loads.leftCols(9 * long(n_requested));
    report.joint_loads = makeJointLoadStorage(*model, requested, shown);
    out.addContents(setup.output_joint_loads_file, io::formatStorage(report.joint_loads));
  }
  if (!setup.knee_joint.empty()) {
    const Eigen::MatrixX3d F = result.joint_loads.rightCols(9).leftCols(3), M = result.joint_loads.rightCols(6).leftCols(3);
    report.knee_loads = makeKneeLoadTable(result.time, F, M, setup.knee_axes);
    out.addContents(setup.output_knee_loads_file, io::formatStorage(report.knee_loads));
  }
  if (!options.stage) own.commit();
  const auto paths = out.getPaths();
  report.outputs.assign(paths.begin() + long(before), paths.end());
  report.seconds_total = cpuSeconds() - cpu0;
  return report;
}

void printIdSummary(const IdReport& report, std::ostream& os) {
  const io::Storage& g = report.generalized_forces;
  os << "Inverse dynamics: " << report.frames << " frames";
  if (report.frames > 0)
    os << " (" << formatSignificant(g.data(0, 0), 6) << " to " << formatSignificant(g.data(g.getNumRows() - 1, 0), 6) << " s)";
  os << ", " << std::fixed << std::setprecision(1) << 1e6 * report.seconds_solving / std::max(1, report.frames)
     << " us per frame, " << std::setprecision(3) << report.seconds_total << " s in all (CPU)\n";
  os.unsetf(std::ios::floatfield);
  if (report.frames > 0) os << "  largest magnitude per coordinate:\n";
  for (size_t c = 1; report.frames > 0 && c < g.labels.size(); ++c)
    os << "    " << std::left << std::setw(28) << g.labels[c] << std::right << formatSignificant(g.data.col(c).cwiseAbs().maxCoeff(), 4)
       << "\n";
  for (const std::string& n : report.notes) os << "  " << n << "\n";
  for (const std::string& w : report.warnings) os << "  warning: " << w << "\n";
  for (const std::string& f : report.outputs) os << "  wrote " << f << "\n";
}

}  // namespace kneesim::dynamics
