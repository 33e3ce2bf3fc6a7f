#pragma once
// Shared pieces of the Python bindings (module kneesim._kneesim): one bind function per engine
// area, and the conversions between NumPy arrays and the engine's containers.
//
// NumPy is used only inside functions (pybind11 loads its C API on first use), so `import kneesim`
// works without NumPy installed. Every user mistake in an argument (a wrong shape, a name list of
// the wrong length) is an InputError, which reaches Python as kneesim.InputError (a ValueError).

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "core/error.hpp"

namespace kneesim::python {

namespace py = pybind11;

/// A C-contiguous float64 array, converted from whatever the caller passed (lists, other dtypes).
using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

void bindModel(py::module_& m);
void bindIo(py::module_& m);
void bindIk(py::module_& m);
void bindContact(py::module_& m);
void bindIdentify(py::module_& m);
void bindGap(py::module_& m);

/// A 1-D array holding a copy of @p v.
py::array_t<double> toArray(const std::vector<double>& v);
/// An array of shape (@p rows, @p cols, 3) holding a copy of @p points (row-major, as
/// io::MarkerTable::positions stores them).
py::array_t<double> toArray(const std::vector<Eigen::Vector3d>& points, py::ssize_t rows, py::ssize_t cols);
/// A 2-D array holding a copy of @p m.
py::array_t<double> toArray(const Eigen::MatrixXd& m);
/// A 4 x 4 homogeneous matrix of @p X.
py::array_t<double> toArray(const Eigen::Isometry3d& X);

/// "(3, 4)": the shape of @p a as Python prints it.
std::string formatShape(const py::array& a);
/// Throws InputError at @p what unless @p a has @p shape (-1: any length in that axis), e.g.
/// "solve_ik/markers: expected an array of shape (frames, markers, 3), got (10, 3)"; @p words
/// names the axes in the message ("frames, markers, 3").
void checkShape(const py::array& a, const std::vector<py::ssize_t>& shape, const std::string& words,
                const std::string& what);
/// The values of a 1-D array (any length), checked as such.
std::vector<double> toVector(const Array& a, const std::string& what);
/// A rigid pose from a 4 x 4 homogeneous matrix; InputError at @p what if it is not one (shape,
/// last row, a rotation part that is not orthonormal within 1e-6).
Eigen::Isometry3d toPose(const double* m, const std::string& what);

}  // namespace kneesim::python
