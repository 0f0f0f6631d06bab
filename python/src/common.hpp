// Shared by the translation units of the Python module: NumPy array checks that never copy
// silently where the docs promise a view, views of C++-owned memory that keep their owner alive,
// and the registration functions each unit provides.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <Eigen/Core>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "imukit/core/error.hpp"
#include "imukit/core/rng.hpp"
#include "imukit/core/time.hpp"

namespace imukit::python {

namespace py = pybind11;

void bind_io(py::module_& m);
void bind_sim(py::module_& m);
void bind_keypoints(py::module_& m);
void bind_hwmodel(py::module_& m);
void bind_augment(py::module_& m);
void bind_identify(py::module_& m);

// "float32", "int64", ... for messages.
inline std::string dtype_name(const py::array& a) { return py::str(a.dtype()).cast<std::string>(); }

// "str", "float", "int64", ... (the object's type) for messages.
inline std::string type_name(py::handle obj) {
  return py::str(py::type::of(obj).attr("__name__")).cast<std::string>();
}

// Scalar arguments converted here rather than by pybind11's casters, whose errors name C++
// types ("Unable to cast ... to C++ type 'std::vector<std::__cxx11::basic_string...'") and
// not the parameter (found in review, 2026-11-26). `what` is the parameter as the message
// names it ("stda: sigma").

// Whether obj is an integer with operator.index semantics: a Python int or a NumPy integer, not
// a bool, Python's or NumPy's (True is not seed 1; NumPy 1.24 still lets np.True_ be an index:
// found in review, 2026-11-26), a float or a str.
inline bool is_index(py::handle obj) {
  if (!PyIndex_Check(obj.ptr()) || PyBool_Check(obj.ptr())) return false;
  return !py::isinstance(obj, py::module_::import("numpy").attr("bool_"));
}

// An integer as is_index takes it; anything else is a TypeError.
inline py::int_ index_argument(py::handle obj, const std::string& what) {
  if (!is_index(obj)) {
    throw py::type_error(what + ": expected an int, got " + type_name(obj));
  }
  auto v = py::reinterpret_steal<py::int_>(PyNumber_Index(obj.ptr()));
  if (!v) throw py::error_already_set();
  return v;
}

// index_argument in [min, max]; outside it an imukit.Error.
inline uint64_t uint_argument(py::handle obj, const std::string& what, uint64_t max,
                              uint64_t min = 0) {
  const py::int_ v = index_argument(obj, what);
  if (v < py::int_(min) || v > py::int_(max)) {
    throw Error(what + ": expected an integer in [" + std::to_string(min) + ", " +
                std::to_string(max) + "], got " + py::repr(v).cast<std::string>());
  }
  return v.cast<uint64_t>();
}

// A seed from Python: an int in [0, kMaxSeed], the range of `imukit simulate --seed`, `imukit
// augment --seed` and a scene file's seeds (core/rng.hpp). As a uint64 argument, 2^63 to 2^64 - 1
// were taken here alone, and -1 was "incompatible function arguments" (found in review,
// 2026-11-26).
inline uint64_t seed_argument(py::handle obj, const std::string& what) {
  return uint_argument(obj, what, kMaxSeed);
}

// The command's ranges for windowing (`imukit augment --window`, `--stride`), so that Python
// takes what the command takes: a window of 2^64 - 1 wrapped the C++ bounds (found in review,
// 2026-11-27).
inline constexpr uint64_t kMaxWindow = 10'000'000;
inline std::size_t window_argument(py::handle obj, const std::string& what) {
  return static_cast<std::size_t>(uint_argument(obj, what, kMaxWindow, 2));
}
inline std::size_t stride_argument(py::handle obj, const std::string& what) {
  return static_cast<std::size_t>(uint_argument(obj, what, kMaxWindow, 1));
}

// index_argument in int64's range (nanoseconds); outside it an imukit.Error.
inline int64_t int64_argument(py::handle obj, const std::string& what) {
  const py::int_ v = index_argument(obj, what);
  constexpr int64_t lo = std::numeric_limits<int64_t>::min(),
                    hi = std::numeric_limits<int64_t>::max();
  if (v < py::int_(lo) || v > py::int_(hi)) {
    throw Error(what + ": expected an integer in [" + std::to_string(lo) + ", " +
                std::to_string(hi) + "], got " + py::repr(v).cast<std::string>());
  }
  return v.cast<int64_t>();
}

// A real number: a Python or NumPy int or float (what float() takes, except a str, which it
// would parse, and a bool).
inline double number_argument(py::handle obj, const std::string& what) {
  if (!PyBool_Check(obj.ptr()) && !PyUnicode_Check(obj.ptr()) && !PyBytes_Check(obj.ptr())) {
    const double v = PyFloat_AsDouble(obj.ptr());
    if (!(v == -1.0 && PyErr_Occurred())) return v;
    PyErr_Clear();
  }
  throw py::type_error(what + ": expected a number, got " + type_name(obj));
}

// A list (or tuple, or other iterable) of str. A str alone is a TypeError: iterating it would
// give its characters ("estimate 'c' is not one of ...", found in review).
inline std::vector<std::string> string_list(py::handle obj, const std::string& what) {
  if (py::isinstance<py::str>(obj) || py::isinstance<py::bytes>(obj) ||
      !py::isinstance<py::iterable>(obj)) {
    throw py::type_error(what + ": expected a list of str, got " + type_name(obj));
  }
  std::vector<std::string> out;
  for (py::handle item : obj) {
    if (!py::isinstance<py::str>(item)) {
      throw py::type_error(what + "[" + std::to_string(out.size()) + "]: expected a str, got " +
                           type_name(item));
    }
    out.push_back(item.cast<std::string>());
  }
  return out;
}

// A few numbers given as a list, tuple or array of any real dtype (converted: these are
// parameters, not data).
inline std::vector<double> numbers(py::handle obj, std::size_t n, const char* what) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  if (!a || a.ndim() != 1 || static_cast<std::size_t>(a.shape(0)) != n) {
    throw py::value_error(std::string(what) + ": expected " + std::to_string(n) + " numbers");
  }
  return {a.data(), a.data() + n};
}

inline Eigen::Vector3d vector3(py::handle obj, const char* what) {
  const std::vector<double> v = numbers(obj, 3, what);
  return {v[0], v[1], v[2]};
}

// Throws imukit::Error at the first NaN or infinity of an (n, columns) C-order array, naming
// it as what[sample, k] with its column's name (DESIGN.md: never a silent NaN).
inline void require_finite(const double* values, py::ssize_t n, int columns,
                           const std::string& what, std::span<const char* const> column_names,
                           const std::string& why) {
  for (py::ssize_t i = 0; i < n; ++i) {
    for (int k = 0; k < columns; ++k) {
      const double v = values[i * columns + k];
      if (std::isfinite(v)) continue;
      const std::string value = std::isnan(v) ? "nan" : v > 0 ? "inf" : "-inf";
      throw Error(what + "[" + std::to_string(i) + ", " + std::to_string(k) + "] is " + value +
                  " (sample " + std::to_string(i) + ", column " +
                  column_names[static_cast<std::size_t>(k)] + ")" + why);
    }
  }
}

// Whether a's elements are of NumPy kind `kind` ('f', 'i', 'b') and `size` bytes, in this
// machine's byte order. Compared by value: an array that went through pickle (multiprocessing,
// DataLoader workers) has a float32 dtype equal to NumPy's usual one but another object, and an
// identity test took it for float64, so STDA wrote twice the buffer (found in review,
// 2026-11-27: heap corruption; int64 was refused as "expected int64, got int64").
inline bool has_type(const py::array& a, char kind, py::ssize_t size) {
  const py::dtype d = a.dtype();
  const char order = d.byteorder();  // '=' native, '|' not applicable, '<' or '>' explicit
  const char native = std::endian::native == std::endian::little ? '<' : '>';
  return d.kind() == kind && d.itemsize() == size &&
         (order == '=' || order == '|' || order == native);
}
inline bool is_f32(const py::array& a) { return has_type(a, 'f', 4); }
inline bool is_f64(const py::array& a) { return has_type(a, 'f', 8); }
inline bool is_i64(const py::array& a) { return has_type(a, 'i', 8); }
inline bool is_bool(const py::array& a) { return has_type(a, 'b', 1); }
inline bool is_c_contiguous(const py::array& a) { return (a.flags() & py::array::c_style) != 0; }

// The argument as an array without conversion; anything that is not a NumPy array is a
// TypeError (lists would be copied, which the zero-copy paths must not do behind the caller's
// back).
inline py::array as_array(py::handle obj, const char* what) {
  if (!py::isinstance<py::array>(obj)) {
    throw py::type_error(std::string(what) + ": expected a numpy.ndarray, got " +
                         py::str(py::type::of(obj).attr("__name__")).cast<std::string>());
  }
  return py::reinterpret_borrow<py::array>(obj);
}

// a itself when it is native float32 or float64; the same values in native byte order when it
// is a big-endian (or other non-native) float32 or float64, as .npy and MATLAB files can hold
// (found in review: they were refused as "expected float32 or float64, got >f8"). Anything
// else is a TypeError.
inline py::array native_float(const py::array& a, const char* what) {
  if (is_f32(a) || is_f64(a)) return a;
  const py::dtype d = a.dtype();
  if (d.kind() == 'f' && d.itemsize() == 4)
    return py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(a);
  if (d.kind() == 'f' && d.itemsize() == 8)
    return py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  throw py::type_error(std::string(what) + ": expected float32 or float64, got " + dtype_name(a));
}

// Float input that is only read: float64 C-contiguous arrays are used in place; float32 (or a
// non-contiguous float64 view, or another byte order) is converted to a contiguous float64
// copy, which the docs state for these functions. Integer or object arrays are a TypeError.
inline py::array_t<double, py::array::c_style> read_f64(py::handle obj, const char* what) {
  const py::array a = native_float(as_array(obj, what), what);
  if (is_f64(a) && is_c_contiguous(a)) return py::reinterpret_borrow<py::array_t<double>>(a);
  return py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
}

// One-dimensional int64 input (sample times in nanoseconds, window starts, labels; `meaning`
// says which in the message), used in place when native and C-contiguous; any 8-byte signed
// integer dtype is taken (np.longlong, another byte order: converted to native order, as
// native_float does for floats).
inline py::array_t<int64_t, py::array::c_style> read_int64(py::handle obj, const char* what,
                                                           const char* meaning) {
  const py::array a = as_array(obj, what);
  if (a.dtype().kind() != 'i' || a.dtype().itemsize() != 8) {
    throw py::type_error(std::string(what) + ": expected int64 " + meaning + ", got " +
                         dtype_name(a));
  }
  if (a.ndim() != 1) {
    throw py::value_error(std::string(what) + ": expected a 1-d array, got " +
                          std::to_string(a.ndim()) + " dimensions");
  }
  return py::array_t<int64_t, py::array::c_style | py::array::forcecast>::ensure(a);
}

// Sample times: int64 nanoseconds.
inline py::array_t<int64_t, py::array::c_style> read_times(py::handle obj, const char* what) {
  return read_int64(obj, what, "nanoseconds");
}

// A shape as "(256, 200, 6)" for messages.
inline std::string shape_string(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) {
    s += (d ? ", " : "") + std::to_string(a.shape(d));
  }
  return s + (a.ndim() == 1 ? ",)" : ")");
}

// (n, 3) C-contiguous float64 memory is an Eigen 3 x n column-major matrix, sample after sample:
// the layout of ImuSeries' channels, so it maps without copying.
inline Eigen::Map<const Eigen::Matrix3Xd> map_triad(
    const py::array_t<double, py::array::c_style>& a, py::ssize_t n, const char* what) {
  if (a.ndim() != 2 || a.shape(1) != 3 || a.shape(0) != n) {
    throw py::value_error(std::string(what) + ": expected shape (" + std::to_string(n) +
                          ", 3), got " + shape_string(a));
  }
  return {a.data(), 3, static_cast<Eigen::Index>(n)};
}

// A view of memory owned by `owner` (a Python object that keeps it alive): NumPy holds a
// reference to owner as the array's base.
template <class T>
py::array view_of(const T* data, std::vector<py::ssize_t> shape, std::vector<py::ssize_t> strides,
                  py::handle owner) {
  return py::array_t<T>(std::move(shape), std::move(strides), data, owner);
}

// The same view, read-only (NumPy refuses writes through it): for objects whose samples were
// checked when they were made (a Series is finite and in time order; C++ relies on both).
inline py::object read_only(py::object view) {
  if (!view.is_none()) view.attr("setflags")(py::arg("write") = false);
  return view;
}

// Eigen 3 x n column-major as a (n, 3) view.
inline py::object triad_view(const Eigen::Matrix3Xd& m, py::handle owner) {
  if (m.cols() == 0) return py::none();
  return view_of(m.data(), {m.cols(), 3}, {3 * sizeof(double), sizeof(double)}, owner);
}

// Eigen column-major rows x cols as a (rows, cols) view (Fortran order).
template <class Scalar>
py::array matrix_view(const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>& m,
                      py::handle owner) {
  return view_of(m.data(), {m.rows(), m.cols()},
                 {static_cast<py::ssize_t>(sizeof(Scalar)),
                  static_cast<py::ssize_t>(sizeof(Scalar)) * m.rows()},
                 owner);
}

template <class T>
py::array vector_view(const std::vector<T>& v, py::handle owner) {
  return view_of(v.data(), {static_cast<py::ssize_t>(v.size())}, {sizeof(T)}, owner);
}

// A C++ vector moved into a new NumPy array's ownership (no copy of the elements).
template <class T>
py::array_t<T> adopt(std::vector<T>&& v) {
  auto* heap = new std::vector<T>(std::move(v));
  py::capsule owner(heap, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>({static_cast<py::ssize_t>(heap->size())}, {sizeof(T)}, heap->data(), owner);
}

}  // namespace imukit::python
