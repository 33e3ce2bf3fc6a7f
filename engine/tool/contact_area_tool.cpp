#include "tool/contact_area_tool.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include "contact/contact_output.hpp"
#include "contact/cylinder_fit.hpp"
#include "contact/seating.hpp"
#include "core/atomic_file.hpp"
#include "core/paths.hpp"
#include "core/strings.hpp"
#include "core/xml.hpp"
#include "io/knee_forces.hpp"
#include "io/storage.hpp"
#include "model/osim_reader.hpp"
#include "model/urdf.hpp"
#include "sim/system.hpp"

namespace kneesim::tool {

namespace fs = std::filesystem;
using contact::kDegree;

namespace {

std::string formatSeconds(double t) { return formatSignificant(t, 6); }

contact::ComponentDirections readDirections(const xml::Node& node, const contact::ComponentDirections& fallback) {
  if (!node) return fallback;
  xml::checkChildren(node, {"posterior", "superior", "medial"});
  contact::ComponentDirections d;
  d.posterior = node.childVec3("posterior", fallback.posterior);
  d.superior = node.childVec3("superior", fallback.superior);
  d.medial = node.childVec3("medial", fallback.medial);
  d.validate(node.where().file + ":" + std::to_string(node.line()) + ": " + node.path());
  return d;
}

// A length in metres from the text of @p node, which must be finite and >= 0.
double readLength(const xml::Node& node) {
  const double v = node.toDouble();
  if (!std::isfinite(v) || v < 0) node.fail("expected a length >= 0 (m), got " + node.text());
  return v;
}

HingeKinematicsSpec readHinge(const xml::Node& h, const std::string& dir) {
  xml::checkChildren(h, {"flexion_deg", "flexion_range_deg", "time_step", "flexion_file", "flexion_column",
                    "knee_forces_file", "flexion_scale", "flexion_offset_deg", "free_internal_rotation",
                    "seating_grid_deg"});
  HingeKinematicsSpec s;
  s.where = h.where();
  int sources = 0;
  if (xml::Node n = h.child("flexion_deg")) {
    ++sources;
    for (double v : n.toDoubles()) s.flexion.push_back(v * kDegree);
    if (s.flexion.empty()) n.fail("expected flexion angles (degrees), got none");
  }
  if (xml::Node n = h.child("flexion_range_deg")) {
    ++sources;
    for (double v : n.toStepRange(1000000)) s.flexion.push_back(v * kDegree);
  }
  if (xml::Node n = h.child("flexion_file")) {
    ++sources;
    s.source = HingeKinematicsSpec::Source::file_column;
    s.file = xml::resolvePath(dir, n.text());
    s.column = h.childText("flexion_column");
    if (s.column.empty()) h.fail("<flexion_file> needs a <flexion_column> naming the flexion column");
  } else if (h.child("flexion_column")) {
    h.child("flexion_column").fail("<flexion_column> needs a <flexion_file>");
  }
  if (xml::Node n = h.child("knee_forces_file")) {
    ++sources;
    s.source = HingeKinematicsSpec::Source::goniometer;
    s.file = xml::resolvePath(dir, n.text());
  }
  if (sources != 1)
    h.fail("expected exactly one flexion source (flexion_deg, flexion_range_deg, flexion_file or knee_forces_file), "
           "got " + std::to_string(sources));
  if (xml::Node n = h.child("time_step")) {
    s.time_step = n.toDouble();
    if (!(s.time_step > 0) || !std::isfinite(s.time_step)) n.fail("expected a time step > 0 (s), got " + n.text());
  }
  s.scale = h.childDouble("flexion_scale", 1.0);
  s.offset = h.childDouble("flexion_offset_deg", 0.0) * kDegree;
  if (!std::isfinite(s.scale) || !std::isfinite(s.offset)) h.fail("expected finite flexion_scale and flexion_offset_deg");
  s.free_internal_rotation = h.childBool("free_internal_rotation", false);
  if (xml::Node n = h.child("seating_grid_deg")) {
    const double g = n.toDouble();
    if (!(g >= 0 && g <= 30)) n.fail("expected a grid spacing of 0 (seat every frame) to 30 degrees, got " + n.text());
    s.seating_grid = g * kDegree;
  }
  return s;
}

ModelKinematicsSpec readModelSpec(const xml::Node& m, const std::string& dir) {
  xml::checkChildren(m, {"model_file", "motion_file", "femoral_body", "insert_body", "femoral_mesh", "insert_mesh"});
  ModelKinematicsSpec s;
  s.where = m.where();
  s.model_file = xml::resolvePath(dir, m.requireChild("model_file").text());
  s.motion_file = xml::resolvePath(dir, m.requireChild("motion_file").text());
  s.femoral_body = m.requireChild("femoral_body").text();
  s.insert_body = m.requireChild("insert_body").text();
  s.femoral_mesh = m.childText("femoral_mesh");
  s.insert_mesh = m.childText("insert_mesh");
  if (s.model_file.empty() || s.motion_file.empty() || s.femoral_body.empty() || s.insert_body.empty())
    m.fail("expected model_file, motion_file, femoral_body and insert_body to be non-empty");
  return s;
}

// Frames of @p time inside the setup's time range; throws naming @p what if none.
std::vector<int> selectFrames(const ContactAreaSetup& setup, const std::vector<double>& time, const std::string& what) {
  std::vector<int> frames;
  const double eps = 1e-9;
  for (size_t k = 0; k < time.size(); ++k)
    if (time[k] >= setup.time_start - eps && time[k] <= setup.time_end + eps) frames.push_back(int(k));
  if (frames.empty()) {
    std::ostringstream os;
    os << "time range " << setup.time_start << " to " << setup.time_end << " s does not overlap the data of " << what;
    if (!time.empty()) os << " (" << time.front() << " to " << time.back() << " s)";
    throw InputError({setup.setup_file, 0, "ContactAreaTool/time_range"}, os.str());
  }
  return frames;
}

// The flexion series (time, rad) of a hinge source, before the time range.
void readFlexion(const ContactAreaSetup& setup, std::vector<double>& time, std::vector<double>& flexion,
                 std::vector<std::string>& warnings, std::string& description) {
  const HingeKinematicsSpec& h = setup.hinge;
  time.clear();
  flexion.clear();
  const SourceLocation at{h.where.file, h.where.line, h.where.element};
  if (h.source == HingeKinematicsSpec::Source::list) {
    for (size_t k = 0; k < h.flexion.size(); ++k) {
      time.push_back(double(k) * h.time_step);
      flexion.push_back(h.flexion[k]);
    }
    description = "hinge (Dao & Pouletaut 2015): flexion list from the setup, " + std::to_string(flexion.size()) +
                  " frames, time step " + formatSeconds(h.time_step) + " s";
  } else if (h.source == HingeKinematicsSpec::Source::file_column) {
    if (!pathExists(h.file)) throw InputError(at, "flexion file not found: " + h.file);
    const io::Storage st = io::readStorage(h.file);
    const int col = st.findColumn(h.column);
    if (col < 0) {
      std::string labels;
      for (const auto& l : st.labels) labels += (labels.empty() ? "" : ", ") + l;
      throw InputError(at, "column '" + h.column + "' is not in " + h.file + " (columns: " + labels + ")");
    }
    const double unit = st.in_degrees ? kDegree : 1.0;
    for (int r = 0; r < st.getNumRows(); ++r) {
      time.push_back(st.data(r, 0));
      flexion.push_back(st.data(r, col) * unit);
    }
    description = "hinge (Dao & Pouletaut 2015): flexion from column " + h.column + " of " + h.file + " (" +
                  (st.in_degrees ? "degrees" : "radians") + ")";
  } else {
    if (!pathExists(h.file)) throw InputError(at, "knee-force file not found: " + h.file);
    const io::KneeForces kf = io::readKneeForces(h.file);
    bool any = false;
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (double g : kf.goniometer)
      if (std::isfinite(g)) {
        any = true;
        lo = std::min(lo, g);
        hi = std::max(hi, g);
      }
    if (!any) throw InputError(at, "knee-force file " + h.file + " has no goniometer column GON (or no values in it)");
    time = kf.time;
    for (double g : kf.goniometer) flexion.push_back(g * kDegree);
    // ngait_og3's GON spans 2.8..64.7 (degrees of flexion over a gait cycle); chairrise1's and
    // stairupf1's span 5.5..7.8 and 5.3..7.0, which is no flexion range of a chair rise or a stair
    // ascent: those files carry an uncalibrated signal. Say so rather than seat a 2-degree swing.
    if (hi - lo < 10 && h.scale == 1.0)
      warnings.push_back("the goniometer column of " + h.file + " spans only " + formatSeconds(lo) + " to " +
                         formatSeconds(hi) +
                         ": read as degrees of flexion; if it is an uncalibrated signal, give flexion_scale and "
                         "flexion_offset_deg");
    description = "hinge (Dao & Pouletaut 2015): flexion from the goniometer (GON, degrees) of " + h.file;
  }
  for (double& f : flexion) f = h.scale * f + h.offset;
  if (h.scale != 1.0 || h.offset != 0.0)
    description += "; flexion = " + formatSeconds(h.scale) + " * value + " + formatSeconds(h.offset / kDegree) + " deg";
  for (size_t k = 0; k < flexion.size(); ++k)
    if (!std::isfinite(flexion[k]) || !std::isfinite(time[k]))
      throw InputError(at, "expected finite flexion angles and times, got " + formatSeconds(flexion[k]) + " at t = " +
                               formatSeconds(time[k]) + " s");
}

// The model mesh of @p body named @p mesh (by file stem), or nullptr for an empty name.
const model::MeshRef* findMesh(const model::Model& m, int body, const std::string& mesh, const SourceLocation& at) {
  if (mesh.empty()) return nullptr;
  std::string names;
  for (const model::MeshRef& r : m.bodies[size_t(body)].meshes) {
    const std::string stem = fs::path(r.file).stem().string();
    if (stem == mesh || r.file == mesh) return &r;
    names += (names.empty() ? "" : ", ") + r.file;
  }
  throw InputError(at, "body '" + m.bodies[size_t(body)].name + "' has no mesh '" + mesh + "' (meshes: " +
                           (names.empty() ? "none" : names) + ")");
}

int requireBody(const model::Model& m, const std::string& name, const SourceLocation& at) {
  const int b = m.findBody(name);
  if (b >= 0) return b;
  std::string names;
  for (const model::Body& body : m.bodies) names += (names.empty() ? "" : ", ") + body.name;
  throw InputError(at, "no body '" + name + "' in " + m.source_file + " (bodies: " + names + ")");
}

// X_BG of an optional model mesh (identity without one: the STL is in the body frame).
Eigen::Isometry3d meshPose(const model::MeshRef* ref) { return ref ? ref->X_BG : Eigen::Isometry3d::Identity(); }

// Coordinates that move the insert body relative to the femoral body: those of the joints on the
// tree path between the two bodies.
std::vector<bool> findPathCoordinates(const model::Model& m, int a, int b) {
  const auto chain = [&](int body) {
    std::vector<int> joints;
    for (int j = m.findParentJoint(body); j >= 0; j = m.findParentJoint(m.joints[size_t(j)].parent_body))
      joints.push_back(j);
    return joints;
  };
  const std::vector<int> ca = chain(a), cb = chain(b);
  std::vector<bool> on_path(m.coordinates.size(), false);
  for (const std::vector<int>* c : {&ca, &cb}) {
    const std::vector<int>& other = c == &ca ? cb : ca;
    for (int j : *c)
      if (std::find(other.begin(), other.end(), j) == other.end())
        for (int q : m.joints[size_t(j)].coordinates) on_path[size_t(q)] = true;
  }
  return on_path;
}

ContactKinematics calcModelKinematicsFromFiles(const ContactAreaSetup& setup,
                                               const std::function<void(const std::string&, int, int)>& progress) {
  const ModelKinematicsSpec& ms = setup.model;
  const SourceLocation at{ms.where.file, ms.where.line, ms.where.element};
  if (!pathExists(ms.model_file)) throw InputError(at, "model file not found: " + ms.model_file);
  if (!pathExists(ms.motion_file)) throw InputError(at, "motion file not found: " + ms.motion_file);
  const model::ModelPtr m = endsWith(toLower(ms.model_file), ".urdf") ? model::readUrdf(ms.model_file)
                                                                      : model::readOsim(ms.model_file);
  return calcModelKinematics(setup, m, io::readStorage(ms.motion_file), ms.motion_file, progress);
}

ContactKinematics calcHingeKinematicsFromSetup(const ContactAreaSetup& setup, const ImplantMeshes& meshes,
                                               const std::function<void(const std::string&, int, int)>& progress) {
  std::vector<double> time, flexion, t_sel, f_sel;
  std::vector<std::string> warnings;
  std::string description;
  readFlexion(setup, time, flexion, warnings, description);
  const std::string what = setup.hinge.source == HingeKinematicsSpec::Source::list ? "the flexion list" : setup.hinge.file;
  for (int f : selectFrames(setup, time, what)) {
    t_sel.push_back(time[size_t(f)]);
    f_sel.push_back(flexion[size_t(f)]);
  }
  ContactKinematics k = calcHingeKinematics(setup, meshes, t_sel, f_sel, progress);
  k.description = description + "; " + k.description;
  k.warnings.insert(k.warnings.begin(), warnings.begin(), warnings.end());
  return k;
}

}  // namespace

ContactKinematics calcHingeKinematics(const ContactAreaSetup& setup, const ImplantMeshes& meshes,
                                      const std::vector<double>& time, const std::vector<double>& selected,
                                      const std::function<void(const std::string&, int, int)>& progress) {
  KNEESIM_CHECK(time.size() == selected.size(), "hinge kinematics: one flexion angle per time expected");
  for (size_t j = 0; j < selected.size(); ++j)
    if (!std::isfinite(selected[j]) || !std::isfinite(time[j]))
      throw InputError({setup.setup_file, 0, "HingeKinematics"},
                       "expected finite flexion angles and times, got " + formatSeconds(selected[j]) + " at t = " +
                           formatSeconds(time[j]) + " s");
  ContactKinematics k;
  k.time = time;
  if (selected.empty()) return k;
  contact::ArticularSelection sel;
  sel.directions = setup.femur_directions;
  const contact::CondyleFits fits = contact::fitCondyles(meshes.femur, sel);
  contact::SeatingOptions so;
  so.free_internal_rotation = setup.hinge.free_internal_rotation;
  contact::Seater seater(contact::makeSeatingSetup(meshes.femur, meshes.insert, fits.both.cylinder,
                                                   setup.femur_directions, setup.options.insert_directions),
                         so);
  // The angles to seat at: every frame, or the knots of a grid covering the frames' range when
  // that is fewer seatings.
  const double step = setup.hinge.seating_grid;
  std::vector<double> knots;
  if (step > 0 && !selected.empty()) {
    const double lo = *std::min_element(selected.begin(), selected.end());
    const double hi = *std::max_element(selected.begin(), selected.end());
    const long first = long(std::floor(lo / step + 1e-9)), last = long(std::ceil(hi / step - 1e-9));
    if (size_t(last - first + 1) < selected.size())
      for (long i = first; i <= last; ++i) knots.push_back(double(i) * step);
  }
  const bool on_grid = !knots.empty();
  const std::vector<double>& seat_at = on_grid ? knots : selected;
  // Seat one angle after the other (each from the previous seat) to report progress.
  std::vector<contact::SeatingResult> seats;
  seats.reserve(seat_at.size());
  for (size_t j = 0; j < seat_at.size(); ++j) {
    seats.push_back(seats.empty() ? seater.calcSeating(seat_at[j]) : seater.calcSeating(seat_at[j], &seats.back().q));
    if (progress && (j % 10 == 9 || j + 1 == seat_at.size())) progress("seat", int(j + 1), int(seat_at.size()));
  }
  int unconverged = 0;
  for (const contact::SeatingResult& s : seats) unconverged += s.converged ? 0 : 1;
  if (unconverged > 0)
    k.warnings.push_back("seating did not converge at " + std::to_string(unconverged) + " of " +
                         std::to_string(seats.size()) + (on_grid ? " grid knots" : " frames") +
                         " (see hinge_gap_medial/lateral)");
  std::vector<double> gap_m, gap_l;
  if (!on_grid) {
    for (const contact::SeatingResult& s : seats) {
      k.X_IF.push_back(s.X_IF);
      gap_m.push_back(s.gap_medial);
      gap_l.push_back(s.gap_lateral);
    }
  } else {
    // Linear interpolation of the seating coordinates between the two nearest knots; the gaps of
    // the interpolated pose are measured, not assumed (a search radius of 1 mm covers gaps of micrometres).
    double worst = 0;
    for (size_t j = 0; j < selected.size(); ++j) {
      size_t i = 0;
      double a = 0;
      if (knots.size() > 1) {
        const double u = (selected[j] - knots.front()) / step;
        i = std::min(size_t(std::max(0.0, std::floor(u))), knots.size() - 2);
        a = std::clamp(u - double(i), 0.0, 1.0);
      }
      const contact::SeatingCoordinates& q0 = seats[i].q;
      const contact::SeatingCoordinates& q1 = seats[std::min(i + 1, seats.size() - 1)].q;
      contact::SeatingCoordinates q;
      q.p_IH = (1 - a) * q0.p_IH + a * q1.p_IH;
      q.varus = (1 - a) * q0.varus + a * q1.varus;
      q.internal = (1 - a) * q0.internal + a * q1.internal;
      k.X_IF.push_back(seater.calcPose(selected[j], q));
      double gap[2];
      seater.calcGaps(k.X_IF.back(), 1e-3, gap, nullptr);
      gap_m.push_back(gap[0]);
      gap_l.push_back(gap[1]);
      worst = std::max({worst, std::abs(gap[0]), std::abs(gap[1])});
      if (progress && (j % 20 == 19 || j + 1 == selected.size())) progress("pose", int(j + 1), int(selected.size()));
    }
    std::ostringstream os;
    os << "; seated on a " << std::setprecision(4) << step / kDegree << "-degree grid (" << knots.size()
       << " knots, " << knots.front() / kDegree << " to " << knots.back() / kDegree
       << " deg), poses interpolated linearly in the seating coordinates: largest residual gap "
       << std::setprecision(3) << worst * 1e6 << " um";
    k.description += os.str();
  }
  k.columns.emplace_back("flexion", selected);
  k.columns.emplace_back("hinge_gap_medial", gap_m);
  k.columns.emplace_back("hinge_gap_lateral", gap_l);
  {
    std::ostringstream os;
    os << "hinge: cylinder R = " << std::setprecision(5) << fits.both.cylinder.radius * 1e3 << " mm (mean error "
       << fits.both.errors.mean_abs * 1e3 << " mm, " << fits.both.errors.num_points << " points)";
    k.description = os.str() + k.description;
  }
  return k;
}

ContactAreaSetup readContactAreaSetup(const std::string& path) {
  const auto [doc, dir, tool] = xml::openSetupFile(
      path, "ContactAreaTool",
      {"femoral_component_file", "insert_file", "mesh_scale", "threshold", "extra_thresholds", "area_rule",
       "distance_provider", "plugins", "insert_directions", "femur_directions", "max_normal_angle_deg",
       "HingeKinematics", "ModelKinematics", "time_range", "results_directory", "output_file", "write_vtp",
       "vtp_every", "vtp_femur", "hinge_file"});
  ContactAreaSetup s;
  s.setup_file = path;
  if (!tool.nameAttr().empty()) s.name = tool.nameAttr();
  s.femur_file = xml::resolvePath(dir, tool.requireChild("femoral_component_file").text());
  s.insert_file = xml::resolvePath(dir, tool.requireChild("insert_file").text());
  if (s.femur_file.empty() || s.insert_file.empty()) tool.fail("expected femoral_component_file and insert_file");
  if (xml::Node n = tool.child("mesh_scale")) {
    s.mesh_scale = n.toDouble();
    if (!(s.mesh_scale > 0) || !std::isfinite(s.mesh_scale)) n.fail("expected a mesh scale > 0, got " + n.text());
  }
  if (xml::Node n = tool.child("threshold")) s.options.threshold = readLength(n);
  if (xml::Node n = tool.child("extra_thresholds")) {
    for (double t : n.toDoubles()) {
      if (!std::isfinite(t) || t < 0) n.fail("expected lengths >= 0 (m), got " + n.text());
      s.options.extra_thresholds.push_back(t);
    }
  }
  if (xml::Node n = tool.child("area_rule")) s.options.rule = contact::parseAreaRule(n.text(), n.where());
  s.options.insert_directions = readDirections(tool.child("insert_directions"), {});
  s.femur_directions = readDirections(tool.child("femur_directions"), {});
  if (xml::Node n = tool.child("max_normal_angle_deg")) {
    const double a = n.toDouble();
    if (!(a > 0 && a < 90)) n.fail("expected an angle between 0 and 90 degrees, got " + n.text());
    s.options.max_normal_angle = a * kDegree;
  }
  readDistanceProvider(tool, s);

  const xml::Node hinge = tool.child("HingeKinematics"), model = tool.child("ModelKinematics");
  if (bool(hinge) == bool(model))
    tool.fail(std::string("expected exactly one kinematics source, <HingeKinematics> or <ModelKinematics>, got ") +
              (hinge ? "both" : "neither"));
  if (hinge) s.hinge = readHinge(hinge, dir);
  if (model) {
    s.use_model = true;
    s.model = readModelSpec(model, dir);
  }
  if (xml::Node n = tool.child("time_range")) {
    const auto r = n.toDoubles();
    if (r.size() != 2 || !(r[0] <= r[1])) n.fail("expected 'start end' in seconds with start <= end, got '" + n.text() + "'");
    s.time_start = r[0];
    s.time_end = r[1];
  }
  std::string results = tool.childText("results_directory");
  if (results.empty()) results = ".";
  s.results_directory = xml::resolvePath(dir, results);
  std::string out = tool.childText("output_file");
  if (out.empty()) out = s.name + "_contact_area.sto";
  s.output_file = xml::resolvePath(s.results_directory, out);
  s.write_vtp = tool.childBool("write_vtp", false);
  if (xml::Node n = tool.child("vtp_every")) {
    s.vtp_every = n.toIntIn(1);
  }
  s.vtp_femur = tool.childBool("vtp_femur", true);
  if (xml::Node n = tool.child("hinge_file")) s.hinge_file = xml::resolvePath(s.results_directory, n.text());
  return s;
}

void readDistanceProvider(const xml::Node& tool, ContactAreaSetup& s) {
  s.distance_provider = tool.childText("distance_provider", "fcl");
  if (xml::Node n = tool.child("plugins"))
    s.plugins = n.toWords();
  else if (startsWith(s.distance_provider, "fcl"))
    s.plugins.push_back("distance_fcl");
}

ImplantMeshes readImplantMeshes(const ContactAreaSetup& setup) {
  io::StlOptions o;
  o.scale = setup.mesh_scale;
  o.require_closed = true;
  o.min_extent = 0.01;  // a knee implant component is 1..50 cm across
  o.max_extent = 0.5;
  for (const std::string* f : {&setup.femur_file, &setup.insert_file})
    if (!pathExists(*f)) throw InputError({setup.setup_file, 0, "ContactAreaTool"}, "STL file not found: " + *f);
  ImplantMeshes m;
  m.femur = io::readStl(setup.femur_file, o);
  m.insert = io::readStl(setup.insert_file, o);
  return m;
}

ContactKinematics calcContactKinematics(const ContactAreaSetup& setup, const ImplantMeshes& meshes,
                                        const std::function<void(const std::string&, int, int)>& progress) {
  return setup.use_model ? calcModelKinematicsFromFiles(setup, progress)
                         : calcHingeKinematicsFromSetup(setup, meshes, progress);
}

ContactKinematics calcModelKinematics(const ContactAreaSetup& setup, const model::ModelPtr& model,
                                      const io::Storage& mot, const std::string& motion_name,
                                      const std::function<void(const std::string&, int, int)>& progress) {
  const ModelKinematicsSpec& ms = setup.model;
  const model::Model& m = *model;
  const SourceLocation at{ms.where.file.empty() ? setup.setup_file : ms.where.file, ms.where.line,
                          ms.where.element.empty() ? "ModelKinematics" : ms.where.element};
  const int fb = requireBody(m, ms.femoral_body, at), ib = requireBody(m, ms.insert_body, at);
  const model::MeshRef* fmesh = findMesh(m, fb, ms.femoral_mesh, at);
  const model::MeshRef* imesh = findMesh(m, ib, ms.insert_mesh, at);
  for (const model::MeshRef* r : {fmesh, imesh})
    if (r && (r->scale - Eigen::Vector3d::Ones()).cwiseAbs().maxCoeff() > 1e-12)
      throw InputError(at, "mesh '" + r->file + "' is scaled by the model (" + formatSeconds(r->scale.x()) + " " +
                               formatSeconds(r->scale.y()) + " " + formatSeconds(r->scale.z()) +
                               "): expected unscaled implant meshes");
  std::vector<int> coupler_of(m.coordinates.size(), -1);
  for (size_t c = 0; c < m.couplers.size(); ++c) coupler_of[size_t(m.couplers[c].dependent)] = int(c);
  std::vector<bool> on_path = findPathCoordinates(m, fb, ib);
  // The independents of a coupler driving a coordinate on the path move the components too.
  for (size_t pass = 0; pass < m.couplers.size(); ++pass)
    for (const model::CoordinateCoupler& cp : m.couplers)
      if (on_path[size_t(cp.dependent)])
        for (int i : cp.independents) on_path[size_t(i)] = true;
  std::vector<int> column(m.coordinates.size(), -1);
  for (size_t c = 0; c < m.coordinates.size(); ++c) {
    const model::Coordinate& coord = m.coordinates[c];
    column[c] = mot.findColumn(coord.name);
    if (column[c] < 0 && on_path[c] && !coord.locked && coupler_of[c] < 0)
      throw InputError(at, "motion file " + motion_name + " has no column for coordinate '" + coord.name + "' of " +
                               (m.source_file.empty() ? m.name : m.source_file) + " (it moves " + ms.femoral_body +
                               " relative to " + ms.insert_body + ")");
  }
  if (mot.getNumRows() > 0 && (mot.labels.empty() || mot.labels[0] != "time"))
    throw InputError(at, "motion file " + motion_name + ": expected 'time' as the first column");
  std::vector<double> all_time(size_t(mot.getNumRows()));
  for (int r = 0; r < mot.getNumRows(); ++r) all_time[size_t(r)] = mot.data(r, 0);
  const std::vector<int> frames = selectFrames(setup, all_time, motion_name);

  sim::System system(model);
  auto ws = system.createWorkspace();
  const Eigen::Isometry3d X_BG_f = meshPose(fmesh), X_BG_i = meshPose(imesh);
  ContactKinematics k;
  Eigen::VectorXd q = system.getDefaultCoordinates();
  std::vector<double> args;
  for (size_t j = 0; j < frames.size(); ++j) {
    const int r = frames[j];
    for (size_t c = 0; c < m.coordinates.size(); ++c) {
      if (column[c] < 0) continue;  // locked, coupled or off the path: default or coupler value below
      double v = mot.data(r, column[c]);
      if (mot.in_degrees && m.coordinates[c].motion_type == model::MotionType::Rotational) v *= kDegree;
      if (!std::isfinite(v))
        throw InputError(at, "motion file " + motion_name + ": coordinate '" + m.coordinates[c].name +
                                 "' is not finite at t = " + formatSeconds(all_time[size_t(r)]) + " s");
      q[Eigen::Index(c)] = v;
    }
    // Dependents the motion lacks follow their couplers (in as many passes as a chain needs).
    for (size_t pass = 0; pass < m.couplers.size(); ++pass)
      for (const model::CoordinateCoupler& cp : m.couplers) {
        if (column[size_t(cp.dependent)] >= 0) continue;
        args.clear();
        for (int i : cp.independents) args.push_back(q[i]);
        q[cp.dependent] = cp.scale_factor * cp.function->calcValue(args.data());
      }
    system.realizePosition(*ws, q);
    const Eigen::Isometry3d X_GF = system.getBodyPose(*ws, fb) * X_BG_f;
    const Eigen::Isometry3d X_GI = system.getBodyPose(*ws, ib) * X_BG_i;
    k.time.push_back(all_time[size_t(r)]);
    k.X_IF.push_back(X_GI.inverse(Eigen::Isometry) * X_GF);
    if (progress && (j % 20 == 19 || j + 1 == frames.size())) progress("pose", int(j + 1), int(frames.size()));
  }
  k.description = "model " + (m.source_file.empty() ? m.name : m.source_file) + " with motion " + motion_name +
                  ": femoral component on body " + ms.femoral_body + (fmesh ? " (mesh " + fmesh->file + ")" : "") +
                  ", insert on body " + ms.insert_body + (imesh ? " (mesh " + imesh->file + ")" : "");
  for (const std::string& w : system.getWarnings()) k.warnings.push_back(w);
  return k;
}

std::unique_ptr<contact::ContactAreaCalculator> makeContactAreaCalculator(const ContactAreaSetup& setup,
                                                                          const ImplantMeshes& meshes,
                                                                          plugin::Registry& registry) {
  const SourceLocation at{setup.setup_file, 0, "ContactAreaTool/distance_provider"};
  const kneesim_distance_provider* provider = nullptr;
  if (setup.distance_provider != "MeshDistance") {
    for (const std::string& p : setup.plugins) registry.loadPlugin(p, {setup.setup_file, 0, "ContactAreaTool/plugins"});
    provider = &registry.getDistanceProvider(setup.distance_provider, at);
  }
  return std::make_unique<contact::ContactAreaCalculator>(meshes.insert, meshes.femur, setup.options, provider);
}

ContactAreaReport runContactArea(const ContactAreaSetup& setup, const ContactAreaRunOptions& options) {
  using Clock = std::chrono::steady_clock;
  ContactAreaReport report;
  const ImplantMeshes meshes = readImplantMeshes(setup);
  plugin::Registry registry;
  const auto calculator = makeContactAreaCalculator(setup, meshes, registry);
  auto ws = calculator->createWorkspace();  // builds the provider's trees: setup, not per-frame time

  const auto t0 = Clock::now();
  report.kinematics = calcContactKinematics(setup, meshes, options.progress);
  const auto t1 = Clock::now();
  const ContactKinematics& k = report.kinematics;

  // Distance maps of the frames that get a .vtp, kept until everything is computed.
  std::vector<contact::DistanceMapFrame> maps;
  std::function<void(int, int)> progress;
  if (options.progress) progress = [&](int d, int t) { options.progress("area", d, t); };
  report.series = contact::calcContactSeries(*calculator, *ws, k.time, k.X_IF, progress,
                                             [&](int f, const contact::ContactAreaWorkspace& w) {
                                               if (setup.write_vtp && f % setup.vtp_every == 0)
                                                 maps.push_back({k.time[size_t(f)], k.X_IF[size_t(f)], w.getDistances()});
                                             });
  const auto t2 = Clock::now();
  report.seconds_kinematics = std::chrono::duration<double>(t1 - t0).count();
  report.seconds_area = std::chrono::duration<double>(t2 - t1).count();
  report.distance_method = calculator->getDistanceMethod();
  report.articular_area = calculator->getArticularArea();
  report.search_radius = calculator->getSearchRadius();
  report.warnings = k.warnings;

  // Outputs, all computation done.
  std::vector<std::pair<std::string, std::string>> header = {
      {"setup_file", setup.setup_file}, {"kinematics", k.description}};
  const io::Storage st = contact::makeContactStorage(report.series, *calculator, setup.name + "_contact_area",
                                                     k.columns, header);
  io::writeStorage(setup.output_file, st);
  report.outputs.push_back(setup.output_file);
  if (setup.write_vtp) {
    const std::string folder = setup.name + "_distance_maps";
    const fs::path dir = fs::path(setup.results_directory) / folder;
    const contact::MeshDistance femur_distance(meshes.femur);
    std::vector<contact::PvdEntry> entries;
    for (size_t j = 0; j < maps.size(); ++j) {
      char name[64];
      std::snprintf(name, sizeof name, "%05zu", j * size_t(setup.vtp_every));
      const std::string insert_file = folder + "/insert_" + name + ".vtp";
      contact::writeInsertVtp((fs::path(setup.results_directory) / insert_file).string(), *calculator, maps[j],
                              &femur_distance);
      entries.push_back({maps[j].time, 0, insert_file});
      if (setup.vtp_femur) {
        const std::string femur_file = folder + "/femur_" + name + ".vtp";
        contact::writeMeshVtp((fs::path(setup.results_directory) / femur_file).string(), meshes.femur, maps[j].X_IF);
        entries.push_back({maps[j].time, 1, femur_file});
      }
      if (options.progress) options.progress("vtp", int(j + 1), int(maps.size()));
    }
    const std::string pvd = (fs::path(setup.results_directory) / (setup.name + "_distance_maps.pvd")).string();
    contact::writePvd(pvd, entries);
    report.outputs.push_back(pvd);
    report.outputs.push_back(dir.string() + "/ (" + std::to_string(entries.size()) + " .vtp files)");
  }
  if (!setup.hinge_file.empty()) {
    if (setup.use_model) {
      report.warnings.push_back("hinge_file ignored: the kinematics come from a model");
    } else {
      // The seated poses as a table: time, flexion, X_IF.
      writeFileAtomically(setup.hinge_file, [&](std::ostream& os) {
        os << "time_s,flexion_deg";
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 4; ++c) os << ",X_IF_" << r << c;
        os << "\n" << std::setprecision(10);
        for (size_t j = 0; j < k.time.size(); ++j) {
          os << k.time[j] << "," << k.columns[0].second[j] / kDegree;
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c) os << "," << k.X_IF[j].matrix()(r, c);
          os << "\n";
        }
      });
      report.outputs.push_back(setup.hinge_file);
    }
  }
  return report;
}

void printContactAreaSummary(const ContactAreaReport& r, std::ostream& os) {
  const contact::ContactSeries& s = r.series;
  os << "Contact area: " << s.frames.size() << " frames, distances by " << r.distance_method << ", articular surface "
     << std::fixed << std::setprecision(1) << r.articular_area * 1e6 << " mm^2\n";
  os << "  kinematics: " << r.kinematics.description << "\n";
  if (s.frames.empty()) return;
  const auto peak = [&](const char* label, const std::function<double(const contact::ContactFrame&)>& get) {
    size_t best = 0;
    for (size_t i = 1; i < s.frames.size(); ++i)
      if (get(s.frames[i]) > get(s.frames[best])) best = i;
    size_t low = 0;
    for (size_t i = 1; i < s.frames.size(); ++i)
      if (get(s.frames[i]) < get(s.frames[low])) low = i;
    os << "  " << std::left << std::setw(10) << label << std::right << " peak " << std::setw(8) << std::setprecision(1)
       << get(s.frames[best]) * 1e6 << " mm^2 at t = " << std::setprecision(4) << s.time[best] << " s, lowest "
       << std::setprecision(1) << get(s.frames[low]) * 1e6 << " mm^2 at t = " << std::setprecision(4) << s.time[low]
       << " s\n";
  };
  peak("S", [](const contact::ContactFrame& f) { return f.S; });
  peak("S_medial", [](const contact::ContactFrame& f) { return f.S_medial; });
  peak("S_lateral", [](const contact::ContactFrame& f) { return f.S_lateral; });
  for (size_t e = 0; e < s.extra_thresholds.size(); ++e)
    peak(contact::areaChannelName(s.extra_thresholds[e]).c_str(),
         [e](const contact::ContactFrame& f) { return f.S_extra[e]; });
  double dmin = HUGE_VAL;
  for (const auto& f : s.frames) dmin = std::min(dmin, f.dmin);
  os << "  smallest distance " << std::setprecision(4) << dmin * 1e3 << " mm (negative: penetration)\n";
  os << "  time: kinematics " << std::setprecision(2) << r.seconds_kinematics << " s, contact area "
     << r.seconds_area << " s (" << std::setprecision(2) << 1e3 * r.seconds_area / double(s.frames.size())
     << " ms/frame)\n";
  for (const std::string& w : r.warnings) os << "  warning: " << w << "\n";
  for (const std::string& o : r.outputs) os << "  wrote " << o << "\n";
  os.unsetf(std::ios::fixed);
}

}  // namespace kneesim::tool
