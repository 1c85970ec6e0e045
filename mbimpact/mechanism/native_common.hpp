// What the compiled front end's sources share: the bound Pinocchio model, views of numpy buffers and
// the argument check (native.cpp, native_contact.cpp; one extension, mbimpact.mechanism.native).

#pragma once

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <cstring>

#include <boost/python.hpp>

#include "pinocchio/multibody.hpp"

namespace mbimpact_native {

namespace bp = boost::python;
using Model = pinocchio::Model;
using Data = pinocchio::Data;

inline const char* const kCapsule = "mbimpact.mechanism.native.Bound";

// Status codes (front.py names them).
enum Status : long { kDone = 0, kChecks = 1, kGeneral = 2 };

// A Pinocchio model and one of its Data, with the work arrays of the calls. The argument types of
// the Pinocchio calls below are those of the library's explicit instantiations
// (PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION): the same machine code as the Python bindings run.
struct Bound {
  PyObject* model_object;  // owned references: the C++ objects live as long as the capsule
  PyObject* data_object;
  Model* model;
  Data* data;
  Eigen::VectorXd q;
  Data::Matrix6x J6;
};

inline void release(PyObject* capsule) {
  auto* b = static_cast<Bound*>(PyCapsule_GetPointer(capsule, kCapsule));
  if (b == nullptr) {
    PyErr_Clear();
    return;
  }
  Py_XDECREF(b->model_object);
  Py_XDECREF(b->data_object);
  delete b;
}

inline Bound* bound_of(PyObject* capsule) {
  return static_cast<Bound*>(PyCapsule_GetPointer(capsule, kCapsule));
}

// A read-only view of a 1-D or 2-D float64 buffer of any strides.
struct View {
  Py_buffer buffer{};
  bool held = false;
  const char* base = nullptr;
  Py_ssize_t stride0 = 0, stride1 = 0, rows = 0, cols = 1;

  ~View() {
    if (held) PyBuffer_Release(&buffer);
  }
  // false (with no Python error set) for anything but a float64 numpy.ndarray of the given dimension
  // (what the Python route would take as it is; it converts the rest)
  bool take(PyObject* object, int ndim) {
    if (std::strcmp(Py_TYPE(object)->tp_name, "numpy.ndarray") != 0) return false;
    if (PyObject_GetBuffer(object, &buffer, PyBUF_RECORDS_RO) < 0) {
      PyErr_Clear();
      return false;
    }
    held = true;
    const char* f = buffer.format;
    if (f != nullptr && (*f == '@' || *f == '=' || *f == '<')) ++f;
    if (f == nullptr || std::strcmp(f, "d") != 0 || buffer.itemsize != 8 || buffer.ndim != ndim) return false;
    base = static_cast<const char*>(buffer.buf);
    rows = buffer.shape[0];
    stride0 = buffer.strides[0];
    if (ndim == 2) {
      cols = buffer.shape[1];
      stride1 = buffer.strides[1];
    }
    return true;
  }
  double operator()(Py_ssize_t i) const { return *reinterpret_cast<const double*>(base + i * stride0); }
  double operator()(Py_ssize_t i, Py_ssize_t j) const {
    return *reinterpret_cast<const double*>(base + i * stride0 + j * stride1);
  }
};

// An output buffer: writable, C-contiguous float64, at least `size` long (a ValueError if not: the
// caller's mistake, not the input's); released with the object.
struct Output {
  Py_buffer buffer{};
  bool held = false;

  ~Output() {
    if (held) PyBuffer_Release(&buffer);
  }
  // the buffer's data, or null with a Python error set
  double* take(PyObject* object, Py_ssize_t size) {
    if (PyObject_GetBuffer(object, &buffer, PyBUF_C_CONTIGUOUS | PyBUF_WRITABLE | PyBUF_FORMAT) < 0) return nullptr;
    held = true;
    const char* f = buffer.format;
    if (f != nullptr && (*f == '@' || *f == '=' || *f == '<')) ++f;
    if (f == nullptr || std::strcmp(f, "d") != 0 || buffer.len < size * 8) {
      PyErr_Format(PyExc_ValueError, "out must be a writable contiguous float64 buffer of at least %zd entries", size);
      return nullptr;
    }
    return static_cast<double*>(buffer.buf);
  }
};

inline bool nargs_ok(Py_ssize_t got, Py_ssize_t want, const char* name) {
  if (got == want) return true;
  PyErr_Format(PyExc_TypeError, "%s takes %zd arguments, got %zd", name, want, got);
  return false;
}

// contact_steps(...) -> status: persistent-contact steps of a run (native_contact.cpp).
PyObject* contact_steps(PyObject*, PyObject* const* args, Py_ssize_t nargs);

}  // namespace mbimpact_native
