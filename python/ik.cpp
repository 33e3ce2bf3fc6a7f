// Python bindings of inverse kinematics: kneesim.run_ik (an InverseKinematicsTool setup file, as
// `kneesim run` does) and kneesim.solve_ik (a model and marker arrays in memory, nothing
// written), both returning kneesim.IkResult with the coordinates as a NumPy array.

#include <cmath>
#include <map>

#include <pybind11/stl.h>

#include "bindings.hpp"
#include "ik/tool.hpp"
#include "model.hpp"

namespace kneesim::python {

namespace {

/// What an IK run gives Python.
struct IkResult {
  std::vector<std::string> coordinate_names;
  Eigen::MatrixXd coordinates;  // frames x coordinates, rad or m
  ik::IkReport report;
};

IkResult makeResult(const model::Model& m, ik::IkReport report) {
  IkResult r;
  const io::Storage& mot = report.motion;
  r.coordinates.resize(mot.getNumRows(), Eigen::Index(m.coordinates.size()));
  for (size_t c = 0; c < m.coordinates.size(); ++c) {
    r.coordinate_names.push_back(m.coordinates[c].name);
    const bool deg = mot.in_degrees && m.coordinates[c].motion_type == model::MotionType::Rotational;
    r.coordinates.col(Eigen::Index(c)) = mot.data.col(Eigen::Index(c + 1)) * (deg ? M_PI / 180.0 : 1.0);
  }
  r.report = std::move(report);
  return r;
}

/// One value of every solved frame's FrameResult.
py::array_t<double> perFrame(const IkResult& r, double ik::FrameResult::*value) {
  std::vector<double> v;
  for (const auto& f : r.report.frames) v.push_back(f.*value);
  return toArray(v);
}

IkResult runIkSetup(const std::string& path) {
  py::gil_scoped_release release;
  const ik::IkSetup setup = ik::readIkSetup(path);
  ik::IkReport report = ik::runIk(setup);
  const model::ModelPtr m = report.model;
  return makeResult(*m, std::move(report));
}

IkResult solveIk(const ModelHandle& model, const py::object& markers, const py::object& marker_names,
                 const py::object& time, const py::object& rate, const std::map<std::string, double>& weights,
                 const std::map<std::string, double>& coordinate_weights,
                 const std::map<std::string, double>& coordinate_values, double accuracy, int max_iterations) {
  io::MarkerTable table;
  if (py::isinstance<io::MarkerTable>(markers)) {
    table = markers.cast<io::MarkerTable>();
  } else {
    if (marker_names.is_none())
      throw InputError({"", 0, "solve_ik/marker_names"}, "expected the names of the markers' columns, got None");
    const Array a = Array::ensure(markers);
    if (!a) throw InputError({"", 0, "solve_ik/markers"}, "expected a MarkerTable or an array (frames, markers, 3)");
    const auto names = marker_names.cast<std::vector<std::string>>();
    if (a.ndim() == 3 && a.shape(1) != py::ssize_t(names.size()))
      throw InputError({"", 0, "solve_ik/marker_names"}, "expected one name per marker column (" +
                                                             std::to_string(a.shape(1)) + "), got " +
                                                             std::to_string(names.size()));
    checkShape(a, {-1, py::ssize_t(names.size()), 3}, "frames, markers, 3", "solve_ik/markers");
    table.labels = names;
    table.positions.resize(size_t(a.size() / 3));
    for (size_t i = 0; i < table.positions.size(); ++i)
      table.positions[i] = Eigen::Map<const Eigen::Vector3d>(a.data() + 3 * i);
    const int nf = int(a.shape(0));
    if (!time.is_none()) {
      table.time = toVector(Array::ensure(time), "solve_ik/time");
      if (int(table.time.size()) != nf)
        throw InputError({"", 0, "solve_ik/time"}, "expected one time per frame (" + std::to_string(nf) + "), got " +
                                                       std::to_string(table.time.size()));
    } else {
      const double hz = rate.is_none() ? 1.0 : rate.cast<double>();
      if (!(hz > 0)) throw InputError({"", 0, "solve_ik/rate"}, "expected a rate > 0 Hz");
      for (int f = 0; f < nf; ++f) table.time.push_back(f / hz);
    }
    for (int f = 0; f < nf; ++f) table.frame_numbers.push_back(f + 1);
    table.source_file = "(markers array)";
  }
  ik::IkSetup setup;
  setup.name = "python";
  setup.model_file = model.get().source_file;
  setup.marker_file = table.source_file.empty() ? "(markers)" : table.source_file;
  setup.accuracy = accuracy;
  setup.solver.step_tolerance = accuracy;
  setup.solver.max_iterations = max_iterations;
  for (const auto& [name, w] : weights) {
    ik::TaskSpec t;
    t.name = name;
    t.weight = w;
    t.where = {"", 0, "solve_ik/weights[" + name + "]"};
    // A setup file's task the model lacks is skipped, as OpenSim does; a weight given here by
    // name is a typo to report.
    if (model.get().findMarker(name) < 0)
      throw InputError(t.where, "task names marker '" + name + "' which the model (" + setup.model_file +
                                    ") does not have");
    setup.tasks.push_back(t);
  }
  std::map<std::string, double> coordinate_tasks = coordinate_weights;
  for (const auto& [name, v] : coordinate_values)
    if (!coordinate_tasks.count(name))
      throw InputError({"", 0, "solve_ik/coordinate_values[" + name + "]"},
                       "expected a coordinate also given a weight in coordinate_weights, got none for '" + name + "'");
  for (const auto& [name, w] : coordinate_tasks) {
    ik::TaskSpec t;
    t.kind = ik::TaskSpec::Kind::Coordinate;
    t.name = name;
    t.weight = w;
    t.where = {"", 0, "solve_ik/coordinate_weights[" + name + "]"};
    if (auto it = coordinate_values.find(name); it != coordinate_values.end()) {
      t.value_type = "manual_value";
      t.value = it->second;
    }
    setup.tasks.push_back(t);
  }
  if (!coordinate_tasks.empty() && weights.empty())  // a task set names every marker to track
    for (const model::Marker& k : model.get().markers) {
      ik::TaskSpec t;
      t.name = k.name;
      setup.tasks.push_back(t);
    }
  ik::IkRunOptions options;
  options.write = false;
  py::gil_scoped_release release;
  ik::IkReport report = ik::runIk(setup, model.getPtr(), std::move(table), options);
  return makeResult(model.get(), std::move(report));
}

}  // namespace

void bindIk(py::module_& m) {
  py::class_<IkResult>(m, "IkResult", "The result of an inverse-kinematics run.")
      .def_readonly("coordinate_names", &IkResult::coordinate_names)
      .def_property_readonly("coordinates", [](const IkResult& r) { return toArray(r.coordinates); },
                             "Frames x coordinates, SI units (rad, m), model order.")
      .def_property_readonly("time", [](const IkResult& r) { return toArray(r.report.time); },
                             "Time of each solved frame (s); frames where every marker is missing are skipped.")
      .def_property_readonly("marker_rms", [](const IkResult& r) { return perFrame(r, &ik::FrameResult::rms_error); },
                             "RMS marker error of each frame (m).")
      .def_property_readonly("marker_max", [](const IkResult& r) { return perFrame(r, &ik::FrameResult::max_error); },
                             "Largest marker error of each frame (m).")
      .def_property_readonly("worst_marker", [](const IkResult& r) { return r.report.worst_marker; })
      .def_property_readonly(
          "markers",
          [](const IkResult& r) {
            using namespace pybind11::literals;
            py::list out;
            for (const auto& s : r.report.markers)
              out.append(py::dict("name"_a = s.name, "data_label"_a = s.data_label, "frames"_a = s.frames,
                                  "mean"_a = s.mean, "rms"_a = s.rms, "max"_a = s.max));
            return out;
          },
          "Per tracked marker: name, data_label, frames, mean, rms, max (m).")
      .def_property_readonly("mean_rms", [](const IkResult& r) { return r.report.mean_rms; })
      .def_property_readonly("max_error", [](const IkResult& r) { return r.report.max_error; })
      .def_property_readonly("iterations", [](const IkResult& r) { return r.report.iterations; })
      .def_property_readonly("frames_total", [](const IkResult& r) { return r.report.frames_total; })
      .def_property_readonly("frames_solved", [](const IkResult& r) { return r.report.frames_solved; })
      .def_property_readonly("warnings", [](const IkResult& r) { return r.report.warnings; })
      .def_property_readonly("outputs", [](const IkResult& r) { return r.report.outputs; }, "Files written.")
      .def("__repr__", [](const IkResult& r) {
        return "<kneesim.IkResult: " + std::to_string(r.report.frames_solved) + " frames, mean RMS " +
               std::to_string(r.report.mean_rms * 1e3) + " mm>";
      });

  m.def("run_ik", &runIkSetup, py::arg("setup_file"),
        "Runs an InverseKinematicsTool setup file as `kneesim run` does (writing its outputs).");
  m.def("solve_ik", &solveIk, py::arg("model"), py::arg("markers"), py::arg("marker_names") = py::none(),
        py::arg("time") = py::none(), py::arg("rate") = py::none(),
        py::arg("weights") = std::map<std::string, double>{},
        py::arg("coordinate_weights") = std::map<std::string, double>{},
        py::arg("coordinate_values") = std::map<std::string, double>{}, py::arg("accuracy") = 1e-5,
        py::arg("max_iterations") = 200,
        "Inverse kinematics of a model on markers in memory (a MarkerTable, or an array frames x markers x 3 "
        "in metres with marker_names); nothing is written.");
}

}  // namespace kneesim::python
