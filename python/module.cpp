// The Python extension module kneesim._kneesim: the exceptions, the array conversions shared by
// the bindings, and the module's entry point (the bindings themselves are one file per area).

#include <cmath>
#include <cstring>

#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "core/error.hpp"

namespace kneesim::python {

py::array_t<double> toArray(const std::vector<double>& v) {
  py::array_t<double> a(py::ssize_t(v.size()));
  if (!v.empty()) std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(double));
  return a;
}

py::array_t<double> toArray(const std::vector<Eigen::Vector3d>& points, py::ssize_t rows, py::ssize_t cols) {
  KNEESIM_CHECK(size_t(rows * cols) == points.size(), "toArray: point count does not match the shape");
  py::array_t<double> a({rows, cols, py::ssize_t(3)});
  double* out = a.mutable_data();
  for (size_t i = 0; i < points.size(); ++i)
    for (int k = 0; k < 3; ++k) out[3 * i + size_t(k)] = points[i][k];
  return a;
}

py::array_t<double> toArray(const Eigen::MatrixXd& m) {
  py::array_t<double> a({py::ssize_t(m.rows()), py::ssize_t(m.cols())});
  auto out = a.mutable_unchecked<2>();
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) out(r, c) = m(r, c);
  return a;
}

py::array_t<double> toArray(const Eigen::Isometry3d& X) { return toArray(Eigen::MatrixXd(X.matrix())); }

std::string formatShape(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

void checkShape(const py::array& a, const std::vector<py::ssize_t>& shape, const std::string& words,
                const std::string& what) {
  bool ok = a.ndim() == py::ssize_t(shape.size());
  for (size_t i = 0; ok && i < shape.size(); ++i) ok = shape[i] < 0 || a.shape(py::ssize_t(i)) == shape[i];
  if (!ok) throw InputError({"", 0, what}, "expected an array of shape (" + words + "), got " + formatShape(a));
}

std::vector<double> toVector(const Array& a, const std::string& what) {
  checkShape(a, {-1}, "n", what);
  return std::vector<double>(a.data(), a.data() + a.size());
}

Eigen::Isometry3d toPose(const double* m, const std::string& what) {
  Eigen::Matrix4d X;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) X(r, c) = m[4 * r + c];
  const Eigen::Matrix3d R = X.topLeftCorner<3, 3>();
  const bool finite = X.allFinite();
  const bool rigid = finite && (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 &&
                     R.determinant() > 0 && X.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1), 0.0);
  if (!rigid)
    throw InputError({"", 0, what}, finite ? "expected a rigid transform (orthonormal rotation, last row 0 0 0 1), got "
                                             "another 4 x 4 matrix"
                                           : "expected finite values, got NaN or infinity");
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = R;
  pose.translation() = X.topRightCorner<3, 1>();
  return pose;
}

}  // namespace kneesim::python

PYBIND11_MODULE(_kneesim, m) {
  namespace py = pybind11;
  using kneesim::InputError;
  using kneesim::InternalError;
  m.doc() = "kneesim's engine: models, inverse kinematics, file formats, contact area, contact-law "
            "identification and the gap diagnosis.";

  // Bad input is a ValueError carrying the engine's one-line message and its parts (file, line,
  // element, message); a failed internal check is a RuntimeError.
  static py::exception<InputError> input_error(m, "InputError", PyExc_ValueError);
  static py::exception<InternalError> internal_error(m, "InternalError", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InputError& e) {
      py::object error = py::handle(input_error.ptr())(e.what());
      const kneesim::SourceLocation& at = e.getLocation();
      error.attr("file") = at.file.empty() ? py::none() : py::object(py::str(at.file));
      error.attr("line") = at.line > 0 ? py::object(py::int_(at.line)) : py::none();
      error.attr("element") = at.element.empty() ? py::none() : py::object(py::str(at.element));
      error.attr("message") = py::str(e.getMessage());
      PyErr_SetObject(input_error.ptr(), error.ptr());
    } catch (const InternalError& e) {
      internal_error(e.what());
    }
  });
  input_error.attr("__module__") = "kneesim";
  internal_error.attr("__module__") = "kneesim";

  kneesim::python::bindModel(m);
  kneesim::python::bindIo(m);
  kneesim::python::bindIk(m);
  kneesim::python::bindContact(m);
  kneesim::python::bindIdentify(m);
  kneesim::python::bindGap(m);
}
