// The compiled part of the `imukit` Python package (python/imukit/__init__.py re-exports it):
// module definition and the translation of imukit::Error into imukit.Error.
#include <pybind11/pybind11.h>

#include "common.hpp"
#include "imukit/core/error.hpp"
#include "imukit/core/units.hpp"

namespace imukit::python {
namespace {

// imukit.Error, a ValueError: almost every imukit::Error is bad input (a file, a JSON path, an
// argument). The message is the C++ what() unchanged, so Python and the CLI print the same line;
// the parts are attributes for programs that want them.
PyObject* error_type = nullptr;

void raise_error(const Error& e) {
  py::object type = py::reinterpret_borrow<py::object>(error_type);
  py::object instance = type(e.what());
  instance.attr("reason") = e.reason();
  if (e.where()) {
    const InputLocation& w = *e.where();
    instance.attr("file") = w.file.empty() ? py::object(py::none()) : py::str(w.file);
    instance.attr("line") = w.line ? py::object(py::int_(*w.line)) : py::object(py::none());
    instance.attr("column") = w.column ? py::object(py::int_(*w.column)) : py::object(py::none());
    instance.attr("byte_offset") =
        w.byte_offset ? py::object(py::int_(*w.byte_offset)) : py::object(py::none());
  }
  PyErr_SetObject(error_type, instance.ptr());
}

}  // namespace
}  // namespace imukit::python

PYBIND11_MODULE(_imukit, m) {
  namespace py = pybind11;
  using namespace imukit::python;
  m.doc() = "imukit: capture, characterize, simulate and augment wearable IMUs (docs/python.md)";
  m.attr("__version__") = IMUKIT_VERSION;
  // Standard gravity g_n in m/s^2 (core/units.hpp): the unit "g" and the default |gravity|.
  m.attr("STANDARD_GRAVITY") = imukit::kStandardGravity;

  // Created once per interpreter and never freed: the translator may run until exit.
  error_type = PyErr_NewExceptionWithDoc(
      "imukit.Error",
      "Bad input or a failed operation in imukit; str(e) is the C++ library's message.\n"
      "Attributes: reason (the message without the location), file, line, column,\n"
      "byte_offset (None when not known).",
      PyExc_ValueError, nullptr);
  if (error_type == nullptr) throw py::error_already_set();
  py::handle type(error_type);
  for (const char* name : {"reason", "file", "line", "column", "byte_offset"}) {
    type.attr(name) = py::none();
  }
  m.attr("Error") = py::reinterpret_borrow<py::object>(type);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const imukit::Error& e) {
      raise_error(e);
    }
  });

  bind_io(m);
  bind_sim(m);
  bind_keypoints(m);
  bind_hwmodel(m);
  bind_augment(m);
  bind_identify(m);
}
