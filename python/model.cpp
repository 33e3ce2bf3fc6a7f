// Python bindings of models: kneesim.load_model, kneesim.Model and its bodies, joints,
// coordinates and markers, and forward kinematics of the markers.

#include "model.hpp"

#include <filesystem>

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "core/strings.hpp"
#include "model/read_model.hpp"

namespace kneesim::python {

const sim::System& ModelHandle::getSystem() const {
  std::call_once(built_, [&] { system_ = std::make_unique<sim::System>(model_); });
  return *system_;
}

model::ModelPtr readModelFile(const std::string& path) { return model::readModel(path); }

namespace {

const char* toString(model::JointType t) {
  switch (t) {
    case model::JointType::Weld: return "weld";
    case model::JointType::Pin: return "pin";
    case model::JointType::Slider: return "slider";
    case model::JointType::Ball: return "ball";
    case model::JointType::Free: return "free";
    case model::JointType::Universal: return "universal";
    case model::JointType::Gimbal: return "gimbal";
    case model::JointType::Custom: return "custom";
    case model::JointType::Ellipsoid: return "ellipsoid";
    case model::JointType::Scapulothoracic: return "scapulothoracic";
  }
  return "?";
}

const char* toString(model::MotionType t) {
  switch (t) {
    case model::MotionType::Rotational: return "rotational";
    case model::MotionType::Translational: return "translational";
    case model::MotionType::Coupled: return "coupled";
  }
  return "?";
}

/// The coordinate vector @p q (one value per model coordinate, SI), checked.
Eigen::VectorXd toCoordinates(const ModelHandle& h, const py::object& q) {
  const int nq = int(h.get().coordinates.size());
  if (q.is_none()) return h.getSystem().getDefaultCoordinates();
  const Array a = Array::ensure(q);
  if (!a) throw InputError({"", 0, "q"}, "expected an array of coordinate values, got " + std::string(py::str(q.get_type())));
  checkShape(a, {nq}, std::to_string(nq) + " coordinates", "q");
  return Eigen::Map<const Eigen::VectorXd>(a.data(), nq);
}

template <class T>
std::vector<std::string> namesOf(const std::vector<T>& items) {
  std::vector<std::string> out;
  for (const T& i : items) out.push_back(i.name);
  return out;
}

}  // namespace

void bindModel(py::module_& m) {
  py::class_<model::MeshRef>(m, "Mesh", "A mesh attached to a body.")
      .def_readonly("file", &model::MeshRef::file, "The file as the model names it.")
      .def_readonly("resolved_path", &model::MeshRef::resolved_path, "Absolute path if found, else ''.")
      .def_property_readonly("scale", [](const model::MeshRef& r) { return Eigen::Vector3d(r.scale); })
      .def_property_readonly("X_BG", [](const model::MeshRef& r) { return toArray(r.X_BG); },
                             "Pose of the geometry frame in the body frame (4 x 4).");

  py::class_<model::Body>(m, "Body", "A rigid body (SI units: kg, m, kg m^2).")
      .def_readonly("name", &model::Body::name)
      .def_readonly("mass", &model::Body::mass)
      .def_property_readonly("mass_center", [](const model::Body& b) { return Eigen::Vector3d(b.mass_center); },
                             "Centre of mass from the body origin, in the body frame (m).")
      .def_property_readonly("inertia", [](const model::Body& b) { return Eigen::Matrix3d(b.inertia); },
                             "Inertia about the centre of mass, in the body frame (kg m^2).")
      .def_readonly("meshes", &model::Body::meshes)
      .def("__repr__", [](const model::Body& b) { return "<kneesim.Body '" + b.name + "'>"; });

  py::class_<model::Joint>(m, "Joint", "A joint between a parent and a child body (indices into Model.bodies).")
      .def_readonly("name", &model::Joint::name)
      .def_property_readonly("type", [](const model::Joint& j) { return toString(j.type); },
                             "'weld', 'pin', 'slider', 'ball', 'free', 'universal', 'gimbal' or 'custom'.")
      .def_readonly("parent_body", &model::Joint::parent_body)
      .def_readonly("child_body", &model::Joint::child_body)
      .def_readonly("coordinates", &model::Joint::coordinates, "Indices into Model.coordinates.")
      .def("__repr__", [](const model::Joint& j) { return "<kneesim.Joint '" + j.name + "'>"; });

  py::class_<model::Coordinate>(m, "Coordinate", "A generalised coordinate (rad or m).")
      .def_readonly("name", &model::Coordinate::name)
      .def_property_readonly("motion_type", [](const model::Coordinate& c) { return toString(c.motion_type); },
                             "'rotational' (rad), 'translational' (m) or 'coupled'.")
      .def_readonly("default_value", &model::Coordinate::default_value)
      .def_property_readonly("range", [](const model::Coordinate& c) { return std::make_pair(c.range_min, c.range_max); })
      .def_readonly("clamped", &model::Coordinate::clamped)
      .def_readonly("locked", &model::Coordinate::locked)
      .def_readonly("joint", &model::Coordinate::joint, "Index into Model.joints.")
      .def("__repr__", [](const model::Coordinate& c) { return "<kneesim.Coordinate '" + c.name + "'>"; });

  py::class_<model::Marker>(m, "Marker", "A marker fixed on a body.")
      .def_readonly("name", &model::Marker::name)
      .def_readonly("body", &model::Marker::body, "Index into Model.bodies.")
      .def_property_readonly("location", [](const model::Marker& k) { return Eigen::Vector3d(k.p_BM); },
                             "Location in the body frame (m).")
      .def_readonly("fixed", &model::Marker::fixed)
      .def("__repr__", [](const model::Marker& k) { return "<kneesim.Marker '" + k.name + "'>"; });

  py::class_<ModelHandle, std::shared_ptr<ModelHandle>>(m, "Model",
                                                       "An immutable musculoskeletal model (load it with load_model).")
      .def_property_readonly("name", [](const ModelHandle& h) { return h.get().name; })
      .def_property_readonly("source_file", [](const ModelHandle& h) { return h.get().source_file; })
      .def_property_readonly("gravity", [](const ModelHandle& h) { return Eigen::Vector3d(h.get().gravity); })
      .def_property_readonly("bodies", [](const ModelHandle& h) { return h.get().bodies; }, "Bodies; [0] is ground.")
      .def_property_readonly("joints", [](const ModelHandle& h) { return h.get().joints; })
      .def_property_readonly("coordinates", [](const ModelHandle& h) { return h.get().coordinates; })
      .def_property_readonly("markers", [](const ModelHandle& h) { return h.get().markers; })
      .def_property_readonly("body_names", [](const ModelHandle& h) { return namesOf(h.get().bodies); })
      .def_property_readonly("coordinate_names", [](const ModelHandle& h) { return namesOf(h.get().coordinates); })
      .def_property_readonly("marker_names", [](const ModelHandle& h) { return namesOf(h.get().markers); })
      .def_property_readonly(
          "ignored",
          [](const ModelHandle& h) {
            std::vector<std::pair<std::string, std::string>> out;
            for (const auto& c : h.get().ignored) out.emplace_back(c.type, c.name);
            return out;
          },
          "Components read past without being simulated, as (type, name).")
      .def_property_readonly("warnings", [](const ModelHandle& h) { return h.get().warnings; })
      .def("find_body", [](const ModelHandle& h, const std::string& n) { return h.get().findBody(n); },
           "Index of the named body, or -1.")
      .def("find_joint", [](const ModelHandle& h, const std::string& n) { return h.get().findJoint(n); })
      .def("find_coordinate", [](const ModelHandle& h, const std::string& n) { return h.get().findCoordinate(n); })
      .def("find_marker", [](const ModelHandle& h, const std::string& n) { return h.get().findMarker(n); })
      .def(
          "get_default_coordinates",
          [](const ModelHandle& h) { return Eigen::VectorXd(h.getSystem().getDefaultCoordinates()); },
          "Default values of all coordinates, model order (rad or m).")
      .def(
          "calc_marker_locations",
          [](const ModelHandle& h, const py::object& q) {
            const Eigen::VectorXd qv = toCoordinates(h, q);
            const sim::System& sys = h.getSystem();
            Eigen::MatrixXd out(h.get().markers.size(), 3);
            {
              py::gil_scoped_release release;
              auto ws = sys.createWorkspace();
              sys.realizePosition(*ws, qv);
              for (size_t i = 0; i < h.get().markers.size(); ++i)
                out.row(Eigen::Index(i)) =
                    sys.findStationLocation(*ws, h.get().markers[i].body, h.get().markers[i].p_BM).transpose();
            }
            return out;
          },
          py::arg("q") = py::none(),
          "Marker locations in ground (markers x 3, m) at coordinates q (default: the defaults).")
      .def(
          "calc_body_pose",
          [](const ModelHandle& h, const std::string& body, const py::object& q) {
            const int b = h.get().findBody(body);
            if (b < 0) throw InputError({h.get().source_file, 0, ""}, "expected a body of the model, got '" + body + "'");
            const Eigen::VectorXd qv = toCoordinates(h, q);
            const sim::System& sys = h.getSystem();
            auto ws = sys.createWorkspace();
            sys.realizePosition(*ws, qv);
            return toArray(sys.getBodyPose(*ws, b));
          },
          py::arg("body"), py::arg("q") = py::none(), "X_GB, the pose of the body in ground (4 x 4) at q.")
      .def("__repr__", [](const ModelHandle& h) {
        const model::Model& mo = h.get();
        return "<kneesim.Model '" + mo.name + "': " + std::to_string(mo.bodies.size()) + " bodies, " +
               std::to_string(mo.coordinates.size()) + " coordinates, " + std::to_string(mo.markers.size()) +
               " markers>";
      });

  m.def(
      "load_model",
      [](const std::string& path) {
        model::ModelPtr mo;
        {
          py::gil_scoped_release release;
          mo = readModelFile(path);
        }
        return std::make_shared<ModelHandle>(std::move(mo));
      },
      py::arg("path"), "Reads an OpenSim .osim or a .urdf model (by extension). Raises InputError on bad input.");
}

}  // namespace kneesim::python
