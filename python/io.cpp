// Python bindings of the file formats: OpenSim storage (.mot/.sto), TRC and C3D marker files, as
// kneesim.Storage, kneesim.MarkerTable and kneesim.C3d with NumPy arrays. Objects are built
// whole by their constructors (which check that the arrays agree) and read-only afterwards:
// arrays come out as read-only copies, so an in-place edit cannot be silently lost.

#include <cmath>
#include <filesystem>

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "io/c3d.hpp"
#include "io/marker_table.hpp"
#include "io/storage.hpp"
#include "io/trc.hpp"

namespace kneesim::python {

namespace {

/// @p a marked read-only: it is a copy, and writing to it would change nothing.
template <class A>
A frozen(A a) {
  a.attr("flags").attr("writeable") = false;
  return a;
}

/// A marker table from NumPy positions (frames x markers x 3, m), checked.
io::MarkerTable makeMarkerTable(const Array& positions, const std::vector<std::string>& labels,
                                const py::object& time, const py::object& rate, const py::object& frame_numbers) {
  const std::string what = "MarkerTable";
  checkShape(positions, {-1, py::ssize_t(labels.size()), 3}, "frames, " + std::to_string(labels.size()) + " markers, 3",
             what + "/positions");
  const int nf = int(positions.shape(0));
  io::MarkerTable t;
  t.labels = labels;
  t.original_units = "m";
  t.positions.resize(size_t(nf) * labels.size());
  const double* p = positions.data();
  for (size_t i = 0; i < t.positions.size(); ++i) t.positions[i] = Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
  if (!time.is_none()) {
    t.time = toVector(Array::ensure(time), what + "/time");
    if (int(t.time.size()) != nf)
      throw InputError({"", 0, what + "/time"}, "expected one time per frame (" + std::to_string(nf) + "), got " +
                                                    std::to_string(t.time.size()));
    for (size_t f = 1; f < t.time.size(); ++f)
      if (!(t.time[f] > t.time[f - 1]))
        throw InputError({"", 0, what + "/time"}, "expected strictly increasing finite times, got " +
                                                      std::to_string(t.time[f - 1]) + " then " + std::to_string(t.time[f]));
  }
  if (!rate.is_none()) {
    t.rate = rate.cast<double>();
    if (!(t.rate > 0) || !std::isfinite(t.rate))
      throw InputError({"", 0, what + "/rate"}, "expected a rate > 0 Hz, got " + std::string(py::str(rate)));
  }
  if (time.is_none()) {
    if (rate.is_none()) throw InputError({"", 0, what}, "expected time or rate, got neither");
    for (int f = 0; f < nf; ++f) t.time.push_back(f / t.rate);
  } else if (rate.is_none()) {
    t.rate = nf > 1 ? (nf - 1) / (t.time.back() - t.time.front()) : 0.0;
  }
  if (frame_numbers.is_none()) {
    for (int f = 0; f < nf; ++f) t.frame_numbers.push_back(f + 1);
  } else {
    t.frame_numbers = frame_numbers.cast<std::vector<int>>();
    if (int(t.frame_numbers.size()) != nf)
      throw InputError({"", 0, what + "/frame_numbers"}, "expected one frame number per frame (" + std::to_string(nf) +
                                                             "), got " + std::to_string(t.frame_numbers.size()));
  }
  return t;
}

io::Storage makeStorage(const std::vector<std::string>& labels, const Array& data, const std::string& name,
                        bool in_degrees, const std::vector<std::pair<std::string, std::string>>& header) {
  if (labels.empty() || labels[0] != "time")
    throw InputError({"", 0, "Storage/labels"}, "expected 'time' as the first label, got " +
                                                    (labels.empty() ? std::string("no labels") : "'" + labels[0] + "'"));
  checkShape(data, {-1, py::ssize_t(labels.size())}, "rows, " + std::to_string(labels.size()) + " labels",
             "Storage/data");
  io::Storage s;
  s.name = name;
  s.labels = labels;
  s.in_degrees = in_degrees;
  s.header = header;
  s.data = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      data.data(), data.shape(0), data.shape(1));
  return s;
}

/// A C3D file of @p markers and, optionally, analog channels sampled an integer number of times
/// per marker frame.
io::C3dFile makeC3d(const io::MarkerTable& markers, const py::object& analog, std::vector<std::string> labels,
                    std::vector<std::string> units, std::vector<std::string> descriptions, const py::object& rate) {
  io::C3dFile c;
  c.markers = markers;
  c.header.frame_rate = markers.rate;
  c.first_frame = markers.frame_numbers.empty() ? 1 : markers.frame_numbers.front();
  c.last_frame = c.first_frame + markers.getNumFrames() - 1;
  if (!(markers.rate > 0)) throw InputError({"", 0, "C3d/markers"}, "expected a marker rate > 0 Hz, got 0");
  if (analog.is_none()) return c;
  const Array a = Array::ensure(analog);
  if (!a) throw InputError({"", 0, "C3d/analog"}, "expected an array of shape (samples, channels)");
  checkShape(a, {-1, -1}, "samples, channels", "C3d/analog");
  const py::ssize_t nf = markers.getNumFrames(), ns = a.shape(0), nc = a.shape(1);
  if (nf == 0 || ns % nf != 0)
    throw InputError({"", 0, "C3d/analog"}, "expected a whole number of samples per marker frame (" +
                                                std::to_string(nf) + " frames), got " + std::to_string(ns) + " samples");
  if (labels.empty())
    for (py::ssize_t i = 0; i < nc; ++i) labels.push_back("A" + std::to_string(i + 1));
  units.resize(size_t(nc));
  descriptions.resize(size_t(nc));
  if (py::ssize_t(labels.size()) != nc)
    throw InputError({"", 0, "C3d/analog_labels"}, "expected one label per channel (" + std::to_string(nc) + "), got " +
                                                       std::to_string(labels.size()));
  io::AnalogTable& t = c.analog;
  t.labels = labels;
  t.units = units;
  t.descriptions = descriptions;
  t.samples_per_frame = int(ns / nf);
  t.rate = rate.is_none() ? markers.rate * t.samples_per_frame : rate.cast<double>();
  if (std::abs(t.rate - markers.rate * t.samples_per_frame) > 1e-9 * t.rate)
    throw InputError({"", 0, "C3d/analog_rate"}, "expected " + std::to_string(t.samples_per_frame) +
                                                     " x the marker rate, got " + std::to_string(t.rate) + " Hz");
  t.data = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(a.data(), ns, nc);
  const double t0 = markers.time.empty() ? 0.0 : markers.time.front();
  for (py::ssize_t s = 0; s < ns; ++s) t.time.push_back(t0 + double(s) / t.rate);
  return c;
}

py::array_t<double> residualArray(const io::C3dFile& c) {
  const auto nf = py::ssize_t(c.markers.getNumFrames()), nm = py::ssize_t(c.markers.getNumMarkers());
  py::array_t<double> a({nf, nm});
  double* out = a.mutable_data();
  for (size_t i = 0; i < size_t(nf * nm); ++i) out[i] = i < c.residuals.size() ? c.residuals[i] : NAN;
  return frozen(a);
}

template <class F>
auto released(F&& f) {
  py::gil_scoped_release release;
  return f();
}

}  // namespace

void bindIo(py::module_& m) {
  py::class_<io::Storage>(m, "Storage",
                          "An OpenSim storage table (.mot, .sto): labels ('time' first) and rows of values.")
      .def(py::init(&makeStorage), py::arg("labels"), py::arg("data"), py::arg("name") = "",
           py::arg("in_degrees") = false, py::arg("header") = std::vector<std::pair<std::string, std::string>>{},
           "A table of rows x len(labels) values; labels[0] must be 'time'.")
      .def_readonly("name", &io::Storage::name)
      .def_readonly("labels", &io::Storage::labels)
      .def_property_readonly("data", [](const io::Storage& s) { return frozen(toArray(s.data)); },
                             "Rows x columns (a read-only copy); angles in the file's unit (see in_degrees).")
      .def_readonly("in_degrees", &io::Storage::in_degrees)
      .def_readonly("header", &io::Storage::header, "Other header lines as (key, value).")
      .def("find_column", &io::Storage::findColumn, py::arg("label"), "Index of the column, or -1.")
      .def(
          "column",
          [](const io::Storage& s, const std::string& label) {
            if (s.findColumn(label) < 0)
              throw InputError({"", 0, s.name}, "expected a column of the table, got '" + label + "'");
            const Eigen::VectorXd c = s.getColumn(label);
            return frozen(toArray(std::vector<double>(c.data(), c.data() + c.size())));
          },
          py::arg("label"), "The column's values.")
      .def_property_readonly("num_rows", &io::Storage::getNumRows)
      .def("__repr__", [](const io::Storage& s) {
        return "<kneesim.Storage '" + s.name + "': " + std::to_string(s.getNumRows()) + " rows x " +
               std::to_string(s.labels.size()) + " columns>";
      });

  m.def(
      "read_storage", [](const std::string& path) { return released([&] { return io::readStorage(path); }); },
      py::arg("path"), "Reads a .mot or .sto file.");
  m.def(
      "write_storage",
      [](const std::string& path, const io::Storage& s) { released([&] { io::writeStorage(path, s); }); },
      py::arg("path"), py::arg("storage"), "Writes a .mot or .sto file (OpenSim's format, atomically).");

  py::class_<io::MarkerTable>(m, "MarkerTable", "Marker trajectories: frames x markers x 3, metres, NaN = missing.")
      .def(py::init(&makeMarkerTable), py::arg("positions"), py::arg("labels"), py::arg("time") = py::none(),
           py::arg("rate") = py::none(), py::arg("frame_numbers") = py::none(),
           "positions in metres (frames x len(labels) x 3); time (s) or rate (Hz: time = frame / rate) or both.")
      .def_readonly("labels", &io::MarkerTable::labels)
      .def_property_readonly("positions",
                             [](const io::MarkerTable& t) {
                               return frozen(toArray(t.positions, t.getNumFrames(), t.getNumMarkers()));
                             },
                             "Frames x markers x 3 (m), NaN where a marker is missing.")
      .def_property_readonly("time", [](const io::MarkerTable& t) { return frozen(toArray(t.time)); })
      .def_readonly("frame_numbers", &io::MarkerTable::frame_numbers)
      .def_readonly("rate", &io::MarkerTable::rate, "Sampling rate (Hz).")
      .def_readonly("original_units", &io::MarkerTable::original_units, "Length unit of the file read.")
      .def_readonly("source_file", &io::MarkerTable::source_file)
      .def_property_readonly("num_frames", &io::MarkerTable::getNumFrames)
      .def_property_readonly("num_markers", &io::MarkerTable::getNumMarkers)
      .def("find_marker", &io::MarkerTable::findMarker, py::arg("name"),
           "Index of the marker (exact name, or 'subject:name'), or -1.")
      .def("__repr__", [](const io::MarkerTable& t) {
        return "<kneesim.MarkerTable: " + std::to_string(t.getNumFrames()) + " frames x " +
               std::to_string(t.getNumMarkers()) + " markers>";
      });

  m.def(
      "read_trc", [](const std::string& path) { return released([&] { return io::readTrc(path); }); },
      py::arg("path"), "Reads a TRC file (coordinates converted to metres).");
  m.def(
      "write_trc",
      [](const std::string& path, const io::MarkerTable& t, const std::string& units) {
        released([&] { io::writeTrc(path, t, units); });
      },
      py::arg("path"), py::arg("markers"), py::arg("units") = "mm", "Writes a TRC file in 'mm', 'cm' or 'm'.");
  m.def(
      "read_marker_file", [](const std::string& path) { return released([&] { return io::readMarkerFile(path); }); },
      py::arg("path"), "Reads the markers of a .trc or .c3d file.");

  py::class_<io::AnalogTable>(m, "AnalogTable", "Analog channels: samples x channels, in their units.")
      .def_readonly("labels", &io::AnalogTable::labels)
      .def_readonly("units", &io::AnalogTable::units)
      .def_readonly("descriptions", &io::AnalogTable::descriptions)
      .def_readonly("rate", &io::AnalogTable::rate, "Hz.")
      .def_readonly("samples_per_frame", &io::AnalogTable::samples_per_frame)
      .def_property_readonly("time", [](const io::AnalogTable& t) { return frozen(toArray(t.time)); })
      .def_property_readonly("data", [](const io::AnalogTable& t) { return frozen(toArray(t.data)); })
      .def("find_channel", &io::AnalogTable::findChannel, py::arg("label"));

  py::class_<io::ForcePlate>(m, "ForcePlate", "A force platform as FORCE_PLATFORM describes it.")
      .def_readonly("type", &io::ForcePlate::type)
      .def_property_readonly("corners", [](const io::ForcePlate& p) { return Eigen::MatrixXd(p.corners_m.transpose()); },
                             "Corners 1-4 in the lab frame (4 x 3, m).")
      .def_property_readonly("origin", [](const io::ForcePlate& p) { return Eigen::Vector3d(p.origin_m); })
      .def_readonly("channels", &io::ForcePlate::channels, "0-based analog columns of Fx Fy Fz Mx My Mz.");

  py::class_<io::C3dParameter>(m, "C3dParameter", "One parameter of a C3D file.")
      .def_readonly("group", &io::C3dParameter::group)
      .def_readonly("name", &io::C3dParameter::name)
      .def_readonly("description", &io::C3dParameter::description)
      .def_readonly("type", &io::C3dParameter::type, "-1 char, 1 byte, 2 integer, 4 float.")
      .def_readonly("dims", &io::C3dParameter::dims)
      .def_readonly("values", &io::C3dParameter::values)
      .def_readonly("strings", &io::C3dParameter::strings);

  py::class_<io::C3dFile>(m, "C3d", "A C3D file: points (markers), analog channels, force plates, parameters.")
      .def(py::init(&makeC3d), py::arg("markers"), py::arg("analog") = py::none(),
           py::arg("analog_labels") = std::vector<std::string>{}, py::arg("analog_units") = std::vector<std::string>{},
           py::arg("analog_descriptions") = std::vector<std::string>{}, py::arg("analog_rate") = py::none(),
           "A file to write: markers (a MarkerTable with a rate) and analog samples x channels, a whole number of "
           "samples per marker frame.")
      .def_readonly("path", &io::C3dFile::path)
      .def_readonly("processor", &io::C3dFile::processor)
      .def_readonly("markers", &io::C3dFile::markers)
      .def_readonly("analog", &io::C3dFile::analog)
      .def_readonly("plates", &io::C3dFile::plates)
      .def_readonly("parameters", &io::C3dFile::parameters)
      .def_readonly("first_frame", &io::C3dFile::first_frame)
      .def_readonly("last_frame", &io::C3dFile::last_frame)
      .def_property_readonly("points",
                             [](const io::C3dFile& c) {
                               return frozen(toArray(c.markers.positions, c.markers.getNumFrames(),
                                                     c.markers.getNumMarkers()));
                             },
                             "Frames x points x 3 (m), NaN where a point is missing.")
      .def_property_readonly("residuals", &residualArray, "Frames x points (m), NaN where a point is missing.")
      .def_property_readonly("point_labels", [](const io::C3dFile& c) { return c.markers.labels; })
      .def_property_readonly("point_rate", [](const io::C3dFile& c) { return c.markers.rate; }, "Hz.")
      .def_property_readonly("analog_labels", [](const io::C3dFile& c) { return c.analog.labels; })
      .def_property_readonly("analog_units", [](const io::C3dFile& c) { return c.analog.units; })
      .def_property_readonly("analog_rate", [](const io::C3dFile& c) { return c.analog.rate; }, "Hz.")
      .def_property_readonly("analog_data", [](const io::C3dFile& c) { return frozen(toArray(c.analog.data)); },
                             "Samples x channels, scaled to the channels' units.")
      .def(
          "find_parameter",
          [](const io::C3dFile& c, const std::string& group, const std::string& name) -> py::object {
            const io::C3dParameter* p = c.findParameter(group, name);
            return p ? py::cast(*p) : py::none();
          },
          py::arg("group"), py::arg("name"), "The parameter GROUP:NAME (any case), or None.")
      .def(
          "calc_plate_wrench",
          [](const io::C3dFile& c, int plate, double min_normal_force) {
            if (plate < 0 || plate >= int(c.plates.size()))
              throw InputError({c.path, 0, "FORCE_PLATFORM"}, "expected a plate 0.." + std::to_string(int(c.plates.size()) - 1) +
                                                                  ", got " + std::to_string(plate));
            const io::PlateWrench w = io::calcPlateWrench(c, plate, min_normal_force);
            const auto n = py::ssize_t(w.force.size());
            py::dict out;
            out["force"] = toArray(w.force, n, 1).attr("reshape")(n, 3);
            out["cop"] = toArray(w.cop, n, 1).attr("reshape")(n, 3);
            out["free_moment"] = toArray(w.free_moment, n, 1).attr("reshape")(n, 3);
            return out;
          },
          py::arg("plate"), py::arg("min_normal_force") = 10.0,
          "Force (N), centre of pressure (m) and free moment (N m) of a plate per analog sample, lab frame.")
      .def("__repr__", [](const io::C3dFile& c) {
        return "<kneesim.C3d: " + std::to_string(c.markers.getNumFrames()) + " frames x " +
               std::to_string(c.markers.getNumMarkers()) + " points, " + std::to_string(c.analog.getNumChannels()) +
               " analog channels>";
      });

  m.def(
      "read_c3d", [](const std::string& path) { return released([&] { return io::readC3d(path); }); },
      py::arg("path"), "Reads a C3D file (points in metres, analog channels in their units).");
  m.def(
      "write_c3d",
      [](const std::string& path, const io::C3dFile& c, const std::string& processor, bool float_format,
         const std::string& units, double point_scale) {
        io::C3dWriteOptions o;
        o.processor = processor;
        o.float_format = float_format;
        o.units = units;
        o.point_scale = point_scale;
        if (!(point_scale > 0)) throw InputError({path, 0, "point_scale"}, "expected a scale > 0");
        released([&] { io::writeC3d(path, c, o); });
      },
      py::arg("path"), py::arg("c3d"), py::arg("processor") = "Intel", py::arg("float_format") = true,
      py::arg("units") = "mm", py::arg("point_scale") = 0.1,
      "Writes a C3D file ('Intel', 'DEC' or 'MIPS'; floats or 16-bit integers).");
}

}  // namespace kneesim::python
