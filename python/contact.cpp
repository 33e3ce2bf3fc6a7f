// Python bindings of the implant contact area (Dao & Pouletaut 2015, section 2.4):
// kneesim.ContactArea (the contact-area tool's computation for one pose or a motion, meshes from
// STL files or arrays) and kneesim.run_contact_area (a ContactAreaTool setup file end to end).

#include <memory>
#include <mutex>

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "contact/contact_area.hpp"
#include "io/stl.hpp"
#include "plugin/registry.hpp"
#include "tool/contact_area_tool.hpp"

namespace kneesim::python {

namespace {

/// kneesim.ContactArea: a calculator with the plugins it uses and one workspace. Calls are
/// serialised (a workspace serves one thread at a time); the GIL is released while computing.
class ContactArea {
 public:
  ContactArea(io::TriangleMesh insert, io::TriangleMesh femur, const contact::ContactAreaOptions& options,
              const std::string& distance, const std::vector<std::string>& plugins) {
    const kneesim_distance_provider* provider = nullptr;
    if (distance != "MeshDistance") {
      registry_ = std::make_unique<plugin::Registry>();
      for (const std::string& p : plugins) registry_->loadPlugin(p, {"", 0, "ContactArea/plugins"});
      provider = &registry_->getDistanceProvider(distance, {"", 0, "ContactArea/distance"});
    }
    calculator_ = std::make_unique<contact::ContactAreaCalculator>(std::move(insert), std::move(femur), options, provider);
    workspace_ = calculator_->createWorkspace();
  }

  /// The calculator of a ContactAreaTool setup: its meshes, options and distance provider.
  static std::unique_ptr<ContactArea> fromSetup(const std::string& path) {
    py::gil_scoped_release release;
    const tool::ContactAreaSetup s = tool::readContactAreaSetup(path);
    tool::ImplantMeshes meshes = tool::readImplantMeshes(s);
    auto out = std::unique_ptr<ContactArea>(new ContactArea());
    out->registry_ = std::make_unique<plugin::Registry>();
    out->calculator_ = tool::makeContactAreaCalculator(s, meshes, *out->registry_);
    out->workspace_ = out->calculator_->createWorkspace();
    return out;
  }

  py::dict calcPose(const Array& X) {
    checkShape(X, {4, 4}, "4, 4", "ContactArea.calc_pose/X_IF");
    const Eigen::Isometry3d pose = toPose(X.data(), "ContactArea.calc_pose/X_IF");
    contact::ContactFrame f;
    {
      py::gil_scoped_release release;
      std::lock_guard<std::mutex> lock(mutex_);
      calculator_->calcFrame(*workspace_, pose, f);
    }
    py::dict d;
    d["S"] = f.S;
    d["S_medial"] = f.S_medial;
    d["S_lateral"] = f.S_lateral;
    d["dmin"] = f.dmin;
    d["dmin_medial"] = f.dmin_medial;
    d["dmin_lateral"] = f.dmin_lateral;
    d["centroid_medial"] = Eigen::Vector3d(f.centroid_medial);
    d["centroid_lateral"] = Eigen::Vector3d(f.centroid_lateral);
    const auto& extra = calculator_->getOptions().extra_thresholds;
    for (size_t k = 0; k < extra.size(); ++k) d[py::str(contact::areaChannelName(extra[k]))] = f.S_extra[k];
    return d;
  }

  py::dict calcMotion(const Array& X, const py::object& time) {
    checkShape(X, {-1, 4, 4}, "frames, 4, 4", "ContactArea.calc_motion/X_IF");
    const auto n = size_t(X.shape(0));
    std::vector<Eigen::Isometry3d> poses;
    for (size_t k = 0; k < n; ++k)
      poses.push_back(toPose(X.data() + 16 * k, "ContactArea.calc_motion/X_IF[" + std::to_string(k) + "]"));
    std::vector<double> t;
    if (time.is_none()) {
      for (size_t k = 0; k < n; ++k) t.push_back(double(k));
    } else {
      t = toVector(Array::ensure(time), "ContactArea.calc_motion/time");
      if (t.size() != n)
        throw InputError({"", 0, "ContactArea.calc_motion/time"}, "expected one time per pose (" + std::to_string(n) +
                                                                      "), got " + std::to_string(t.size()));
    }
    contact::ContactSeries series;
    {
      py::gil_scoped_release release;
      std::lock_guard<std::mutex> lock(mutex_);
      series = contact::calcContactSeries(*calculator_, *workspace_, t, poses);
    }
    py::dict d;
    for (const auto& [name, values] : contact::getContactChannels(series)) d[py::str(name)] = toArray(values);
    return d;
  }

  const contact::ContactAreaCalculator& get() const { return *calculator_; }

 private:
  ContactArea() = default;
  std::unique_ptr<plugin::Registry> registry_;  // outlives the calculator, which uses its provider
  std::unique_ptr<contact::ContactAreaCalculator> calculator_;
  std::unique_ptr<contact::ContactAreaWorkspace> workspace_;
  std::mutex mutex_;
};

/// A direction given by the caller, or @p fallback for None.
Eigen::Vector3d toDirection(const py::object& d, const Eigen::Vector3d& fallback, const std::string& what) {
  if (d.is_none()) return fallback;
  const Array a = Array::ensure(d);
  if (!a) throw InputError({"", 0, what}, "expected a direction of 3 values");
  checkShape(a, {3}, "3", what);
  return Eigen::Map<const Eigen::Vector3d>(a.data());
}

/// A mesh from an STL path (read as the contact-area tool reads implant components) or from a
/// (vertices, triangles) pair, which must bound a solid (closed, outward-oriented).
io::TriangleMesh toMesh(const py::object& mesh, double scale, const std::string& what) {
  if (py::isinstance<py::str>(mesh)) {
    io::StlOptions o;
    o.scale = scale;
    o.require_closed = true;
    o.min_extent = 0.01;  // a knee implant component is 1..50 cm across, as the tool checks
    o.max_extent = 0.5;
    const std::string path = mesh.cast<std::string>();
    py::gil_scoped_release release;
    return io::readStl(path, o);
  }
  const auto pair = mesh.cast<std::pair<py::object, py::object>>();
  const Array v = Array::ensure(pair.first);
  const auto t = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(pair.second);
  if (!v || !t) throw InputError({"", 0, what}, "expected an STL path or (vertices, triangles) arrays");
  checkShape(v, {-1, 3}, "vertices, 3", what + "/vertices");
  checkShape(t, {-1, 3}, "triangles, 3", what + "/triangles");
  io::TriangleMesh m;
  m.source_file = what;
  for (py::ssize_t i = 0; i < v.shape(0); ++i) m.vertices.push_back(scale * Eigen::Map<const Eigen::Vector3d>(v.data() + 3 * i));
  for (py::ssize_t i = 0; i < t.shape(0); ++i) {
    const long long* r = t.data() + 3 * i;
    for (int k = 0; k < 3; ++k)
      if (r[k] < 0 || r[k] >= v.shape(0))
        throw InputError({"", 0, what + "/triangles"}, "expected vertex indices 0.." + std::to_string(v.shape(0) - 1) +
                                                           ", got " + std::to_string(r[k]) + " in triangle " +
                                                           std::to_string(i));
    m.triangles.emplace_back(int(r[0]), int(r[1]), int(r[2]));
  }
  const io::TriangleMesh::EdgeReport e = m.calcEdgeReport();
  if (e.open > 0 || !(m.calcVolume() > 0))
    throw InputError({"", 0, what}, "expected a closed, outward-oriented surface, got " + std::to_string(e.open) +
                                        " open edges and a signed volume of " + std::to_string(m.calcVolume()) + " m^3");
  return m;
}

std::unique_ptr<ContactArea> makeContactArea(const py::object& insert, const py::object& femur, double threshold,
                                             const std::vector<double>& extra_thresholds, const std::string& rule,
                                             const std::string& distance, const py::object& plugins, double mesh_scale,
                                             const py::object& superior, const py::object& medial,
                                             const py::object& posterior, double max_normal_angle_deg) {
  contact::ContactAreaOptions o;
  o.threshold = threshold;
  o.extra_thresholds = extra_thresholds;
  o.rule = contact::parseAreaRule(rule, {"", 0, "ContactArea/rule"});
  contact::ComponentDirections& dir = o.insert_directions;
  dir.superior = toDirection(superior, dir.superior, "ContactArea/superior");
  dir.medial = toDirection(medial, dir.medial, "ContactArea/medial");
  dir.posterior = toDirection(posterior, dir.posterior, "ContactArea/posterior");
  o.insert_directions.validate("ContactArea");
  o.max_normal_angle = max_normal_angle_deg * contact::kDegree;
  // As the tool: an fcl* provider comes from the distance_fcl plugin unless plugins are named.
  std::vector<std::string> names;
  if (!plugins.is_none())
    names = plugins.cast<std::vector<std::string>>();
  else if (distance.rfind("fcl", 0) == 0)
    names = {"distance_fcl"};
  io::TriangleMesh in = toMesh(insert, mesh_scale, "ContactArea/insert");
  io::TriangleMesh fe = toMesh(femur, mesh_scale, "ContactArea/femur");
  py::gil_scoped_release release;
  return std::make_unique<ContactArea>(std::move(in), std::move(fe), o, distance, names);
}

py::dict runContactAreaSetup(const std::string& path) {
  tool::ContactAreaReport r;
  {
    py::gil_scoped_release release;
    r = tool::runContactArea(tool::readContactAreaSetup(path));
  }
  py::dict channels;
  for (const auto& [name, values] : contact::getContactChannels(r.series)) channels[py::str(name)] = toArray(values);
  for (const auto& [name, values] : r.kinematics.columns) channels[py::str(name)] = toArray(values);
  const auto n = py::ssize_t(r.kinematics.X_IF.size());
  py::array_t<double> X({n, py::ssize_t(4), py::ssize_t(4)});
  for (py::ssize_t k = 0; k < n; ++k) {
    const Eigen::Matrix4d M = r.kinematics.X_IF[size_t(k)].matrix();
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) X.mutable_at(k, i, j) = M(i, j);
  }
  py::dict d;
  d["channels"] = channels;
  d["X_IF"] = X;
  d["kinematics"] = r.kinematics.description;
  d["distance_method"] = r.distance_method;
  d["articular_area"] = r.articular_area;
  d["outputs"] = r.outputs;
  d["warnings"] = r.warnings;
  return d;
}

}  // namespace

void bindContact(py::module_& m) {
  py::class_<ContactArea>(m, "ContactArea",
                          "Contact area of a tibial insert (frame I) against a femoral component (frame F) at "
                          "poses X_IF, as the contact-area tool computes it (areas m^2, distances m).")
      .def(py::init(&makeContactArea), py::arg("insert"), py::arg("femur"), py::arg("threshold") = 4e-3,
           py::arg("extra_thresholds") = std::vector<double>{}, py::arg("rule") = "partial_triangles",
           py::arg("distance") = "fcl", py::arg("plugins") = py::none(), py::arg("mesh_scale") = 1.0,
           py::arg("superior") = py::none(), py::arg("medial") = py::none(), py::arg("posterior") = py::none(),
           py::arg("max_normal_angle_deg") = 75.0,
           "insert and femur: an STL path (times mesh_scale, in metres) or (vertices, triangles) arrays; the "
           "insert's anatomical directions (default: superior +y, medial +z, posterior +x); distance 'fcl' (plugin) or 'MeshDistance' (exact, slower).")
      .def_static("from_setup", &ContactArea::fromSetup, py::arg("setup_file"),
                  "The meshes, options and distance provider of a ContactAreaTool setup file.")
      .def("calc_pose", &ContactArea::calcPose, py::arg("X_IF"),
           "Contact measures at one pose (4 x 4): S, S_medial, S_lateral, dmin*, centroids, S@<t>mm.")
      .def("calc_motion", &ContactArea::calcMotion, py::arg("X_IF"), py::arg("time") = py::none(),
           "Contact channels over poses (frames x 4 x 4), with time derivatives: name -> array.")
      .def_property_readonly("articular_area", [](const ContactArea& c) { return c.get().getArticularArea(); },
                             "Area of the insert's articular surface (m^2).")
      .def_property_readonly("search_radius", [](const ContactArea& c) { return c.get().getSearchRadius(); })
      .def_property_readonly("distance_method", [](const ContactArea& c) { return c.get().getDistanceMethod(); })
      .def_property_readonly("threshold", [](const ContactArea& c) { return c.get().getOptions().threshold; });

  m.def("run_contact_area", &runContactAreaSetup, py::arg("setup_file"),
        "Runs a ContactAreaTool setup file (writing its outputs); returns channels (name -> array, with the "
        "kinematics' columns), X_IF (frames x 4 x 4), outputs, warnings.");
}

}  // namespace kneesim::python
