// The compiled front end of a single impact: stage 1 of the pipeline (J(q) and A(q) with its
// factor, Pinocchio's C++ algorithms on the live pinocchio.Model) and Newton's impact (1.2) on
// them, in one call from Python.
//
// Built at `pip install` (mbimpact/mechanism/native_build.py) against the installed Pinocchio's
// headers; mbimpact/mechanism/front.py loads it only where that Pinocchio is the one running.
// Every function fills caller-owned float64 buffers and returns a status; what it does not
// handle (inputs that need checks with named errors, degenerate impacts) it leaves to the Python
// route, which treats or names it. The results equal the Python route's to rounding.

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <cmath>
#include <cstring>
#include <limits>

#include <boost/python.hpp>

#include "native_common.hpp"

#include "pinocchio/multibody.hpp"
#include "pinocchio/algorithm/cholesky.hpp"
#include "pinocchio/algorithm/crba.hpp"
#include "pinocchio/algorithm/frames.hpp"
#include "pinocchio/algorithm/joint-configuration.hpp"

namespace {

using namespace mbimpact_native;

// q and v of the right lengths, finite, the quaternion blocks normalised: else the checked route.
bool state_valid(Bound& b, const View& q, const View* v) {
  const Model& m = *b.model;
  if (q.rows != m.nq || (v != nullptr && v->rows != m.nv)) return false;
  for (Py_ssize_t i = 0; i < m.nq; ++i) {
    const double x = q(i);
    if (!std::isfinite(x)) return false;
    b.q[i] = x;
  }
  if (v != nullptr)
    for (Py_ssize_t i = 0; i < m.nv; ++i)
      if (!std::isfinite((*v)(i))) return false;
  return m.nq == m.nv || pinocchio::isNormalized(m, b.q, 1e-9);
}

// Stage 1 at b.q: the world-aligned Jacobian (3, nv) of a point at offset `point` (frame axes; null
// for the frame origin) from frame `fid` into J, row-major; A(q), full symmetric, row-major, into
// A; and A's factor A = U D Uᵀ left in the Data (what pin.impulseDynamics solves with). The
// values of Mechanism.frame_jacobian and Mechanism.factor_arrays (to rounding, for an offset point).
void stage_one(Bound& b, pinocchio::FrameIndex fid, const double* point, double* A, double* J) {
  const Model& m = *b.model;
  Data& d = *b.data;
  const Eigen::Index n = m.nv;
  b.J6.setZero();  // the Jacobian pass writes only the columns of the frame's support
  pinocchio::computeFrameJacobian(m, d, b.q, fid, pinocchio::LOCAL_WORLD_ALIGNED, b.J6);
  for (Eigen::Index i = 0; i < 3; ++i)
    for (Eigen::Index k = 0; k < n; ++k) J[i * n + k] = b.J6(i, k);
  if (point != nullptr) {  // J_p = J_lin − [r]ₓ J_ang, r = R p in world axes (common/geometry.py)
    const auto& R = d.oMf[fid].rotation();  // computeFrameJacobian has just placed the frame
    const double x = R(0, 0) * point[0] + R(0, 1) * point[1] + R(0, 2) * point[2];
    const double y = R(1, 0) * point[0] + R(1, 1) * point[1] + R(1, 2) * point[2];
    const double z = R(2, 0) * point[0] + R(2, 1) * point[1] + R(2, 2) * point[2];
    if (x != 0.0 || y != 0.0 || z != 0.0) {
      for (Eigen::Index k = 0; k < n; ++k) {
        const double a0 = b.J6(3, k), a1 = b.J6(4, k), a2 = b.J6(5, k);
        J[k] -= y * a2 - z * a1;
        J[n + k] -= z * a0 - x * a2;
        J[2 * n + k] -= x * a1 - y * a0;
      }
    }
  }
  pinocchio::crba(m, d, Eigen::Ref<const Eigen::VectorXd>(b.q));  // the upper triangle
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index k = 0; k < n; ++k) A[i * n + k] = k >= i ? d.M(i, k) : d.M(k, i);
  pinocchio::cholesky::decompose(m, d);
}

// y ← A⁻¹ y with the factor A = U D Uᵀ of the Data (U unit upper triangular): U z = y, z / D, Uᵀ x = z.
// The loops of mbimpact.metric.kernels._solve.
void solve(const Data& d, double* y, Eigen::Index n) {
  const auto& U = d.U;
  const auto& D = d.D;
  for (Eigen::Index i = n - 1; i >= 0; --i) {
    double s = y[i];
    for (Eigen::Index k = i + 1; k < n; ++k) s -= U(i, k) * y[k];
    y[i] = s;
  }
  for (Eigen::Index i = 0; i < n; ++i) y[i] /= D[i];
  for (Eigen::Index i = 0; i < n; ++i) {
    double s = y[i];
    for (Eigen::Index k = 0; k < i; ++k) s -= U(k, i) * y[k];
    y[i] = s;
  }
}

// Newton's impact (1.2) on the factor: mbimpact.metric.kernels.newton, operation by operation, for
// d = 3. Fills buf[0:3n+12] (v₋, v₊, Δv, P, u₋, u₊, n⁰); false for what the general route treats.
bool newton_kernel(const Data& d, const double* J, const View& v, const View& R, double e, double* buf,
                   Eigen::Index n) {
  constexpr Eigen::Index dd = 3;
  for (Eigen::Index i = 0; i < n; ++i)
    if (!(d.D[i] > 0.0 && d.D[i] < std::numeric_limits<double>::infinity())) return false;
  const Eigen::Index o = 3 * n;
  double* jn = buf + n;
  double* y = buf + 2 * n;
  double jj = 0.0, un = 0.0, jnjn = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) {
    double s = 0.0;
    for (Eigen::Index i = 0; i < dd; ++i) {
      const double x = J[i * n + k];
      jj += x * x;
      s += R(i, dd - 1) * x;
    }
    jn[k] = s;
    y[k] = s;
    un += s * v(k);
    jnjn += s * s;
  }
  if (!(un < 0.0 && jj < std::numeric_limits<double>::infinity() && jnjn > 1e-8 * jj)) return false;
  solve(d, y, n);
  double wnn = 0.0;
  for (Eigen::Index k = 0; k < n; ++k) wnn += jn[k] * y[k];
  if (!(wnn > 0.0)) return false;
  const double Pn = -(1.0 + e) * un / wnn;
  double total = Pn;
  for (Eigen::Index k = 0; k < n; ++k) {
    const double x = Pn * y[k];
    y[k] = x;
    buf[k] = v(k);
    buf[n + k] = v(k) + x;
    total += buf[n + k];
  }
  for (Eigen::Index i = 0; i < dd; ++i) {
    const double ni = R(i, dd - 1);
    buf[o + i] = Pn * ni;
    buf[o + 3 * dd + i] = ni;
    double s = 0.0, t = 0.0;
    for (Eigen::Index k = 0; k < n; ++k) {
      s += J[i * n + k] * v(k);
      t += J[i * n + k] * y[k];
    }
    buf[o + dd + i] = s;
    buf[o + 2 * dd + i] = s + t;
    total += s + t;
  }
  return std::isfinite(total);
}

// Where the contact point is: a frame index of the model and an offset from the frame origin (frame
// axes; all zeros for the origin itself).
struct ContactPoint {
  View view;
  double offset[3] = {0.0, 0.0, 0.0};
  bool has_offset = false;
  pinocchio::FrameIndex fid = 0;

  // false (with no Python error set) for a frame index out of range or a point not a (3,) float64 array
  bool take(PyObject* frame, PyObject* point, const Model& m) {
    const long long f = PyLong_AsLongLong(frame);
    if (f == -1 && PyErr_Occurred()) {
      PyErr_Clear();
      return false;
    }
    if (f < 0 || f >= static_cast<long long>(m.nframes)) return false;
    fid = static_cast<pinocchio::FrameIndex>(f);
    if (!view.take(point, 1) || view.rows != 3) return false;
    for (int i = 0; i < 3; ++i) offset[i] = view(i);
    has_offset = offset[0] != 0.0 || offset[1] != 0.0 || offset[2] != 0.0;
    return true;
  }
  const double* point() const { return has_offset ? offset : nullptr; }
};

// ----------------------------------------------------------------------------- Python functions

PyObject* bind(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
  if (!nargs_ok(nargs, 2, "bind")) return nullptr;
  Model* model = nullptr;
  Data* data = nullptr;
  try {
    bp::object m{bp::handle<>(bp::borrowed(args[0]))};
    bp::object d{bp::handle<>(bp::borrowed(args[1]))};
    bp::extract<Model&> em(m);
    bp::extract<Data&> ed(d);
    if (!em.check() || !ed.check()) {
      PyErr_SetString(PyExc_TypeError, "bind takes a pinocchio.Model and a pinocchio.Data of it");
      return nullptr;
    }
    model = &em();
    data = &ed();
  } catch (const bp::error_already_set&) {
    return nullptr;
  }
  if (data->oMf.size() != model->frames.size() || data->M.rows() != model->nv) {
    PyErr_SetString(PyExc_ValueError, "the pinocchio.Data was not made by this model (model.createData())");
    return nullptr;
  }
  auto* b = new Bound{args[0], args[1], model, data, Eigen::VectorXd(model->nq), Data::Matrix6x(6, model->nv)};
  Py_INCREF(args[0]);
  Py_INCREF(args[1]);
  PyObject* capsule = PyCapsule_New(b, kCapsule, release);
  if (capsule == nullptr) {
    Py_DECREF(args[0]);
    Py_DECREF(args[1]);
    delete b;
  }
  return capsule;
}

// newton(bound, q, v, fid, point, R, e, out) -> status. out: v₋, v₊, Δv, P, u₋, u₊, n⁰ (3n + 12),
// then A (n n) and J (3 n), row-major.
PyObject* newton(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
  if (!nargs_ok(nargs, 8, "newton")) return nullptr;
  Bound* b = bound_of(args[0]);
  if (b == nullptr) return nullptr;
  const double e = PyFloat_AsDouble(args[6]);
  if (e == -1.0 && PyErr_Occurred()) return nullptr;
  const Model& m = *b->model;
  const Eigen::Index n = m.nv;
  Output out_buffer;
  double* out = out_buffer.take(args[7], 6 * n + 12 + n * n);
  if (out == nullptr) return nullptr;
  View q, v, R;
  ContactPoint at;
  long status = kChecks;
  if (q.take(args[1], 1) && v.take(args[2], 1) && at.take(args[3], args[4], m) && R.take(args[5], 2) && R.rows == 3
      && R.cols == 3 && state_valid(*b, q, &v)) {
    double* A = out + 3 * n + 12;
    double* J = A + n * n;
    stage_one(*b, at.fid, at.point(), A, J);
    status = newton_kernel(*b->data, J, v, R, e, out, n) ? kDone : kGeneral;
  }
  return PyLong_FromLong(status);
}

// stage_one(bound, q, v, fid, point, A, J) -> status: A (n, n) and J (3, n), C-contiguous, filled; the
// factor of A stays in the Data.
PyObject* stage_one_py(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
  if (!nargs_ok(nargs, 7, "stage_one")) return nullptr;
  Bound* b = bound_of(args[0]);
  if (b == nullptr) return nullptr;
  const Model& m = *b->model;
  const Eigen::Index n = m.nv;
  Output a_buffer, j_buffer;
  double* A = a_buffer.take(args[5], n * n);
  double* J = A == nullptr ? nullptr : j_buffer.take(args[6], 3 * n);
  if (J == nullptr) return nullptr;
  View q, v;
  ContactPoint at;
  long status = kChecks;
  if (q.take(args[1], 1) && v.take(args[2], 1) && at.take(args[3], args[4], m) && state_valid(*b, q, &v)) {
    stage_one(*b, at.fid, at.point(), A, J);
    status = kDone;
  }
  return PyLong_FromLong(status);
}

// stage_rows(bound, Q, fid, point, A, J, U, D) -> rows: stage_one for the rows of Q (B, nq), finite, in
// order, into A (B, n, n), J (B, 3, n) and, unless None, the factor into U (B, n, n) and D (B, n);
// stops at the first row whose quaternion blocks are not normalised (the rows done are returned).
PyObject* stage_rows(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
  if (!nargs_ok(nargs, 8, "stage_rows")) return nullptr;
  Bound* b = bound_of(args[0]);
  if (b == nullptr) return nullptr;
  const Model& m = *b->model;
  Data& d = *b->data;
  const Eigen::Index n = m.nv;
  View Q;
  ContactPoint at;
  if (!(Q.take(args[1], 2) && Q.cols == m.nq && at.take(args[2], args[3], m))) {
    PyErr_SetString(PyExc_ValueError, "stage_rows takes Q, a float64 array (B, nq), a frame index and a point (3,)");
    return nullptr;
  }
  const Py_ssize_t rows = Q.rows;
  const bool factor = args[6] != Py_None && args[7] != Py_None;
  Output a_buffer, j_buffer, u_buffer, d_buffer;
  double* A = a_buffer.take(args[4], rows * n * n);
  double* J = A == nullptr ? nullptr : j_buffer.take(args[5], rows * 3 * n);
  if (J == nullptr) return nullptr;
  double* U = nullptr;
  double* D = nullptr;
  if (factor) {
    U = u_buffer.take(args[6], rows * n * n);
    D = U == nullptr ? nullptr : d_buffer.take(args[7], rows * n);
    if (D == nullptr) return nullptr;
  }
  Py_ssize_t done = 0;
  for (; done < rows; ++done) {
    bool finite = true;
    for (Eigen::Index k = 0; k < m.nq; ++k) {
      b->q[k] = Q(done, k);
      finite = finite && std::isfinite(b->q[k]);
    }
    if (!finite || (m.nq != m.nv && !pinocchio::isNormalized(m, b->q, 1e-9))) break;
    stage_one(*b, at.fid, at.point(), A + done * n * n, J + done * 3 * n);
    if (factor) {
      double* u = U + done * n * n;
      for (Eigen::Index r = 0; r < n; ++r) {
        for (Eigen::Index c = 0; c < n; ++c) u[r * n + c] = d.U(r, c);
        D[done * n + r] = d.D[r];
      }
    }
  }
  return PyLong_FromSsize_t(done);
}

PyMethodDef kMethods[] = {
    {"bind", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(bind)), METH_FASTCALL,
     "bind(model, data) -> capsule: a pinocchio.Model and a Data of it, for the calls below."},
    {"newton", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(newton)), METH_FASTCALL,
     "newton(bound, q, v, fid, point, R, e, out) -> status (0 done, 1 checks, 2 general route)."},
    {"stage_one", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(stage_one_py)), METH_FASTCALL,
     "stage_one(bound, q, v, fid, point, A, J) -> status (0 done, 1 checks): A(q), J(q), A's factor."},
    {"stage_rows", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(stage_rows)), METH_FASTCALL,
     "stage_rows(bound, Q, fid, point, A, J, U, D) -> rows: stage_one for each row of Q, in order."},
    {"contact_steps", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(contact_steps)), METH_FASTCALL,
     "contact_steps(bound, q, v, par, contacts, tau0, damper, q_ref, mask, gaps, rates, lam, forces, grid, rows) "
     "-> reason: persistent-contact steps (native_contact.cpp)."},
    {nullptr, nullptr, 0, nullptr}};

PyModuleDef kModule = {PyModuleDef_HEAD_INIT, "native", "mbimpact's compiled front end (see front.py).", -1,
                       kMethods, nullptr, nullptr, nullptr, nullptr};

}  // namespace

PyMODINIT_FUNC PyInit_native(void) {
  PyObject* module = PyModule_Create(&kModule);
  if (module == nullptr) return nullptr;
  if (PyModule_AddStringConstant(module, "PINOCCHIO_VERSION", PINOCCHIO_VERSION) < 0
      || PyModule_AddIntConstant(module, "DONE", kDone) < 0 || PyModule_AddIntConstant(module, "CHECKS", kChecks) < 0
      || PyModule_AddIntConstant(module, "GENERAL", kGeneral) < 0) {
    Py_DECREF(module);
    return nullptr;
  }
  return module;
}
