// Persistent-contact steps of a simulation run in one call: the steps of
// mbimpact/simulation/persistent.py (Moreau's scheme on Coulomb cones) for frame contacts on fixed
// planes, the same algorithm on Pinocchio's C++ algorithms.
//
// The call takes the run's state and steps until something needs the Python route: every contact
// about to lift off by itself (`separating`), an open contact crossing its surface, a cone problem
// the solver does not settle, a lift-off or a penetration at a step's end. It then returns with the
// state of its last completed step; the Python route treats that step from there, so that a run
// takes the same steps and events whichever route computes them, and their results agree to
// rounding and to the cone solver's tolerance.
//
// The cone problem of a step is solved by its sticking solution where that holds, else by projected
// Gauss-Seidel with the block update of Pinocchio's PGSConstraintSolver for Coulomb cones
// (pgs-solver.hxx): the library instantiates that solver for its Cholesky Delassus expression only,
// and the step's Delassus matrix is dense.

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <Eigen/Eigenvalues>

#include "native_common.hpp"

#include "pinocchio/algorithm/crba.hpp"
#include "pinocchio/algorithm/jacobian.hpp"
#include "pinocchio/algorithm/joint-configuration.hpp"
#include "pinocchio/algorithm/kinematics.hpp"
#include "pinocchio/algorithm/rnea.hpp"
#include "pinocchio/spatial.hpp"

namespace mbimpact_native {

namespace {

using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

// Why the call returned (persistent.py: COMPILED_REASONS).
enum Reason : long { kBudget = 0, kSeparating = 1, kCrossing = 2, kSolver = 3, kLift = 4, kFull = 5, kInvalid = 6 };

// Slots of the parameter vector `par` (persistent.py: CompiledSteps).
enum Par : int { kT = 0, kStep, kDuration, kBand, kTolerance, kFreeFlyer, kKp, kKd, kHasPd, kDamping, kHasDamper,
                 kMaxSteps, kNextSample, kStepsDone, kRowsWritten, kPgsTol, kPgsIterations, kReason, kProjections, kParSize };

// Columns of a contact's row: its joint, the point in the joint's frame, the plane (normal, origin), its
// local frame (t1, t2, n as columns, row-major), μ, and its mode.
enum Col : int { kJoint = 0, kLocal = 1, kNormal = 4, kOrigin = 7, kFrame = 10, kMu = 19, kActive = 20, kArmed = 21,
                 kPushing = 22, kCols = 23 };

struct Contact {
  int joint;
  Vec3 local, normal, origin;
  Mat3 frame;
  double mu;
  bool active, armed, pushing;
};

struct Run {
  const Model& m;
  Data& d;
  std::vector<Contact> c;
  Vec tau0, damper, q_ref, mask;
  double band, tolerance, kp, kd, damping;
  bool free_flyer, has_pd, has_damper;
  Data::Matrix6x J6;
  Vec torques, bias;  // work arrays of free_velocity, reused every step
  Mat K;

  Vec3 point(const Contact& k) const {
    const auto& M = d.oMi[k.joint];
    return M.translation() + M.rotation() * k.local;
  }

  // gaps of every contact at q
  void gaps(const Vec& q, Vec& out) {
    pinocchio::forwardKinematics(m, d, q);
    for (size_t i = 0; i < c.size(); ++i) out[i] = c[i].normal.dot(point(c[i]) - c[i].origin);
  }

  // the joint acceleration of the step's path q ⊕ s v (RunState.step_configuration): zero, but a free flyer's
  // origin on a straight line, a + ω × v = 0
  void path_acceleration(const Vec& v, Vec& a0) const {
    a0.setZero();
    if (free_flyer) a0.head<3>() = Vec3(v.head<3>()).cross(Vec3(v.segment<3>(3)));
  }

  // gaps and normal velocities at (q, v): points.py PointKinematics.rates; with `a0`, the kinematics of the
  // step's path at (q, v) are left in the Data for the next step's J̇v
  void rates(const Vec& q, const Vec& v, Vec& g, Vec& r, Vec* a0 = nullptr) {
    if (a0 != nullptr) {
      path_acceleration(v, *a0);
      pinocchio::forwardKinematics(m, d, q, v, *a0);
    } else {
      pinocchio::forwardKinematics(m, d, q, v);
    }
    for (size_t i = 0; i < c.size(); ++i) {
      const auto& M = d.oMi[c[i].joint];
      const auto& vel = d.v[c[i].joint];
      g[i] = c[i].normal.dot(M.translation() + M.rotation() * c[i].local - c[i].origin);
      const Vec3 w = vel.angular();
      r[i] = c[i].normal.dot(M.rotation() * (vel.linear() + w.cross(c[i].local)));
    }
  }

  // persistent.py RunState.torque
  void torque(const Vec& q, const Vec& v, bool damped, Vec& tau) {
    tau = tau0;
    if (damping != 0.0 && damped) tau -= damping * v;
    if (has_pd) {
      Vec err(m.nv);
      pinocchio::difference(m, q, q_ref, err);
      if (damped)
        tau += mask.cwiseProduct(kp * err - kd * v);
      else
        tau += mask.cwiseProduct(kp * err);
    }
  }

  // Persistent.free_velocity: v + h a_free (Persistent.step_acceleration: a free flyer's linear part the
  // classical acceleration of its origin), the velocity-proportional torques implicit, (A + h D) v⁺ =
  // A (v + h a₀); a_free = A⁻¹ (τ − nle) on the factor of A itself (or none: A v + h (τ − nle) is what the
  // damped step needs). A = crba(q) and its factor (of A + h D with damping) are left in `A` and `llt`.
  bool free_velocity(const Vec& q, const Vec& v, double h, Mat& A, Eigen::LLT<Mat>& llt, Vec& vfree) {
    pinocchio::crba(m, d, q);
    A = d.M.selfadjointView<Eigen::Upper>();
    torque(q, v, !has_damper, torques);
    torques -= pinocchio::nonLinearEffects(m, d, q, v);
    bias.setZero();
    if (free_flyer) bias.head<3>() = Vec3(v.segment<3>(3)).cross(Vec3(v.head<3>()));
    if (has_damper) {
      K = A;
      K.diagonal() += h * damper;
      llt.compute(K);
      vfree = llt.solve(A * (v + h * bias) + h * torques);
    } else {
      llt.compute(A);
      vfree = v + h * (llt.solve(torques) + bias);
    }
    return llt.info() == Eigen::Success && vfree.allFinite();
  }

  // RunState.step_configuration: a free flyer's origin along a straight line, its rotation normalised
  void step_configuration(const Vec& q, const Vec& dq, Vec& out) {
    pinocchio::integrate(m, q, dq, out);
    if (!free_flyer) return;
    const Eigen::Quaterniond quat(q[6], q[3], q[4], q[5]);
    const Mat3 R = quat.toRotationMatrix();
    out.head<3>() = q.head<3>() + R * dq.head<3>();
    const Vec3 omega = dq.segment<3>(3);
    Eigen::Quaterniond turned(Mat3(R * pinocchio::exp3(omega)));
    const Eigen::Vector4d coeffs = turned.coeffs() / turned.coeffs().norm();
    out.segment<4>(3) = coeffs;
  }

  // the world-aligned Jacobian (3, nv) of contact k's point (joint Jacobians computed at the placement)
  Eigen::Matrix<double, 3, Eigen::Dynamic> point_jacobian(const Contact& k) {
    J6.setZero();
    pinocchio::getJointJacobian(m, d, k.joint, pinocchio::LOCAL_WORLD_ALIGNED, J6);
    const Vec3 r = d.oMi[k.joint].rotation() * k.local;
    Eigen::Matrix<double, 3, Eigen::Dynamic> Jp = J6.topRows<3>();
    for (Eigen::Index col = 0; col < m.nv; ++col) {
      const Vec3 ang = J6.block<3, 1>(3, col);
      Jp.col(col) -= r.cross(ang);
    }
    return Jp;
  }

  // Persistent.project: the smallest change of q in the kinetic metric that puts the pushing persistent
  // points and every point below its surface at gap 0, up to three times; `at`: the gaps at q, updated
  // and the number of changes of q made (Persistent.project's work["projection"])
  int project(Vec& q, Vec& at) {
    const double below = -0.1 * band;
    int round = 0;
    for (; round < 3; ++round) {
      std::vector<int> held;
      bool any = false;
      for (size_t i = 0; i < c.size(); ++i) any = any || at[i] < below;
      if (!any) return round;
      pinocchio::computeJointJacobians(m, d, q);
      for (size_t i = 0; i < c.size(); ++i)
        if ((c[i].active && c[i].pushing) || at[i] < below) held.push_back(int(i));
      const Eigen::Index r = static_cast<Eigen::Index>(held.size());
      Mat Jn(r, m.nv);
      Vec target(r);
      for (Eigen::Index k = 0; k < r; ++k) {
        const Contact& ck = c[held[k]];
        Jn.row(k) = ck.normal.transpose() * point_jacobian(ck);
        target[k] = ck.normal.dot(point(ck) - ck.origin);
      }
      pinocchio::crba(m, d, q);
      const Mat A = d.M.selfadjointView<Eigen::Upper>();
      const Mat AinvJt = Eigen::LLT<Mat>(A).solve(Jn.transpose());
      const Mat M = Jn * AinvJt;
      Eigen::JacobiSVD<Mat> svd(M, Eigen::ComputeThinU | Eigen::ComputeThinV);
      svd.setThreshold(1e-12);
      const Vec dq = -AinvJt * svd.solve(target);
      Vec out(m.nq);
      pinocchio::integrate(m, q, dq, out);
      q = out;
      this->gaps(q, at);
    }
    return round;
  }

  // RunState.transport
  void transport(const Vec& q0, const Vec& q1, const Vec& v, Vec& out) const {
    out = v;
    if (!free_flyer) return;
    const Mat3 R0 = Eigen::Quaterniond(q0[6], q0[3], q0[4], q0[5]).toRotationMatrix();
    const Mat3 R1 = Eigen::Quaterniond(q1[6], q1[3], q1[4], q1[5]).toRotationMatrix();
    out.head<3>() = R1.transpose() * (R0 * v.head<3>());
  }
};

bool finite(const Vec& x) { return x.allFinite(); }



// The cone problem (G, g, μ) solved in place of λ (a warm start); false where it is not settled. Every
// contact sticking (σ = Gλ + g = 0 with λ inside its cone) is the solution where it holds, the case of
// a robot standing; otherwise projected Gauss-Seidel on the problem scaled as
// mbimpact.simulation.cones.ConeSolver scales it. A body resting on more than three points has a
// singular G (a sole's four corners; the smallest pivot of its Cholesky factor, squared, below 1e-10 of
// its diagonal): its sticking impulses are then the least-norm ones, −G⁺g, where ADMM started from zero
// converges too (the impulses are not unique there, v⁺ is).
bool cone_solve(const Mat& G, const Vec& g, const std::vector<double>& mus, double tol, int iterations, Vec& lam) {
  const Eigen::Index n = g.size();
  {
    constexpr double kSingular = 1e-10;
    const double top = G.diagonal().cwiseAbs().maxCoeff();
    Vec x(n);
    Eigen::LLT<Mat> stick(G);
    const double pivot = stick.info() == Eigen::Success ? stick.matrixLLT().diagonal().minCoeff() : 0.0;
    if (pivot * pivot > kSingular * top) {
      x = stick.solve(-g);
    } else {
      Eigen::SelfAdjointEigenSolver<Mat> eig(G);
      const Vec& w = eig.eigenvalues();
      const Vec c = eig.eigenvectors().transpose() * g;
      Vec y = Vec::Zero(n);
      for (Eigen::Index k = 0; k < n; ++k)
        if (w[k] > kSingular * w.maxCoeff()) y[k] = -c[k] / w[k];
      x = eig.eigenvectors() * y;
    }
    {
      bool inside = x.allFinite();
      for (Eigen::Index k = 0; k < n / 3 && inside; ++k)
        inside = x[3 * k + 2] > 0.0 && std::hypot(x[3 * k], x[3 * k + 1]) <= mus[k] * x[3 * k + 2];
      if (inside && (G * x + g).lpNorm<Eigen::Infinity>() <= 1e-9 * g.lpNorm<Eigen::Infinity>()) {
        lam = x;
        return true;
      }
    }
  }
  double scale_g = g.cwiseAbs().maxCoeff();
  if (scale_g == 0.0) scale_g = 1.0;
  double scale_G = G.diagonal().cwiseAbs().maxCoeff();
  if (scale_G == 0.0) scale_G = 1.0;
  const Mat Gs = G / scale_G;
  const Vec gs = g / scale_g;
  Vec x = lam * (scale_G / scale_g);
  Vec y(3);
  const double eps = Eigen::NumTraits<double>::dummy_precision();
  bool converged = false;
  for (int it = 0; it <= iterations && !converged; ++it) {
    const double before = x.lpNorm<Eigen::Infinity>();
    double change = 0.0;
    for (Eigen::Index k = 0; k < n / 3; ++k) {
      const Eigen::Index r = 3 * k;
      y = Gs.middleRows(r, 3) * x + gs.segment<3>(r);
      const Eigen::Vector3d old = x.segment<3>(r);
      // Pinocchio's block update (PGSConstraintProjectionStepOnSet<CoulombFrictionCone>::project)
      double& fz = x[r + 2];
      fz -= y[2] / std::max(eps, Gs(r + 2, r + 2));
      fz = std::max(0.0, fz);
      y += Gs.col(r + 2).segment<3>(r) * (fz - old[2]);
      const double min_tangent = std::max(eps, std::min(Gs(r, r), Gs(r + 1, r + 1)));
      Eigen::Vector2d ft = x.segment<2>(r) - y.head<2>() / min_tangent;
      const double norm = ft.norm(), limit = mus[k] * fz;
      if (norm > limit) ft *= limit / norm;
      x.segment<2>(r) = ft;
      change = std::max(change, (x.segment<3>(r) - old).cwiseAbs().maxCoeff());
    }
    converged = change <= tol * std::max(before, x.lpNorm<Eigen::Infinity>());
  }
  if (!converged || !x.allFinite()) return false;
  lam = x * (scale_g / scale_G);
  // ConeSolver's check of a solution: pushing only, no approach, complementary
  const Vec sigma = G * lam + g;
  double bad = 0.0;
  for (Eigen::Index k = 0; k < n / 3; ++k) {
    bad = std::max(bad, -lam[3 * k + 2]);
    bad = std::max(bad, -sigma[3 * k + 2] / scale_g * scale_G);
  }
  double comp = 0.0;
  for (Eigen::Index k = 0; k < n / 3; ++k) comp += lam[3 * k + 2] * sigma[3 * k + 2];
  bad = std::max(bad, std::abs(comp) / (scale_g * scale_g / scale_G));
  return bad <= 1e-6;
}

}  // namespace

// contact_steps(bound, q, v, par, contacts, tau0, damper, q_ref, mask, gaps, rates, lam, forces, grid, rows)
// -> reason. See persistent.py (CompiledSteps) for the layout of every buffer.
PyObject* contact_steps(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
  if (!nargs_ok(nargs, 15, "contact_steps")) return nullptr;
  Bound* b = bound_of(args[0]);
  if (b == nullptr) return nullptr;
  const Model& m = *b->model;
  Data& d = *b->data;
  const Eigen::Index nq = m.nq, nv = m.nv;
  Output bq, bv, bpar, bcon, bgaps, brates, blam, bforces, brows;
  View vtau, vdamper, vqref, vmask, vgrid;
  double* pq = bq.take(args[1], nq);
  double* pv = pq ? bv.take(args[2], nv) : nullptr;
  double* par = pv ? bpar.take(args[3], kParSize) : nullptr;
  if (par == nullptr) return nullptr;
  const Py_ssize_t nc = static_cast<Py_ssize_t>(bcon.take(args[4], 0) ? bcon.buffer.len / 8 / kCols : -1);
  if (nc < 1) {
    PyErr_SetString(PyExc_ValueError, "contact_steps: contacts must be a float64 array (c, 23)");
    return nullptr;
  }
  double* con = static_cast<double*>(bcon.buffer.buf);
  double* pgaps = bgaps.take(args[9], nc);
  double* prates = pgaps ? brates.take(args[10], nc) : nullptr;
  double* plam = prates ? blam.take(args[11], 3 * nc) : nullptr;
  double* pforces = plam ? bforces.take(args[12], 3 * nc) : nullptr;
  double* prows = pforces ? brows.take(args[14], 0) : nullptr;
  if (prows == nullptr) return nullptr;
  if (!(vtau.take(args[5], 1) && vtau.rows == nv && vdamper.take(args[6], 1) && vdamper.rows == nv
        && vqref.take(args[7], 1) && vqref.rows == nq && vmask.take(args[8], 1) && vmask.rows == nv
        && vgrid.take(args[13], 1))) {
    PyErr_SetString(PyExc_ValueError, "contact_steps: tau0, damper, mask (nv,), q_ref (nq,) and grid must be float64");
    return nullptr;
  }
  const Eigen::Index width = 1 + nq + nv + 5 * nc;  // t, q, v, forces, gaps, rates
  const Py_ssize_t capacity = brows.buffer.len / 8 / width;

  Run run{m, d, {}, Vec(nv), Vec(nv), Vec(nq), Vec(nv), par[kBand], par[kTolerance], par[kKp], par[kKd],
          par[kDamping], par[kFreeFlyer] != 0.0, par[kHasPd] != 0.0, par[kHasDamper] != 0.0, Data::Matrix6x(6, nv), Vec(nv), Vec(nv), Mat(nv, nv)};
  for (Eigen::Index i = 0; i < nv; ++i) {
    run.tau0[i] = vtau(i);
    run.damper[i] = vdamper(i);
    run.mask[i] = vmask(i);
  }
  for (Eigen::Index i = 0; i < nq; ++i) run.q_ref[i] = vqref(i);
  for (Py_ssize_t i = 0; i < nc; ++i) {
    const double* row = con + i * kCols;
    Contact k;
    k.joint = static_cast<int>(row[kJoint]);
    if (k.joint < 0 || k.joint >= static_cast<int>(m.njoints)) {
      PyErr_SetString(PyExc_ValueError, "contact_steps: a contact's joint is not in the model");
      return nullptr;
    }
    for (int j = 0; j < 3; ++j) {
      k.local[j] = row[kLocal + j];
      k.normal[j] = row[kNormal + j];
      k.origin[j] = row[kOrigin + j];
      for (int l = 0; l < 3; ++l) k.frame(j, l) = row[kFrame + 3 * j + l];
    }
    k.mu = row[kMu];
    k.active = row[kActive] != 0.0;
    k.armed = row[kArmed] != 0.0;
    k.pushing = row[kPushing] != 0.0;
    run.c.push_back(k);
  }
  std::vector<int> active;
  std::vector<double> mus;
  for (Py_ssize_t i = 0; i < nc; ++i)
    if (run.c[i].active) {
      active.push_back(static_cast<int>(i));
      mus.push_back(run.c[i].mu);
    }
  const Eigen::Index na = static_cast<Eigen::Index>(active.size());
  Vec q = Eigen::Map<Vec>(pq, nq), v = Eigen::Map<Vec>(pv, nv);
  Vec gaps0 = Eigen::Map<Vec>(pgaps, nc), gaps1(nc), rates1 = Vec::Zero(nc), ga(nc), ra(nc), gb(nc);
  Vec lam(3 * na);
  for (Eigen::Index k = 0; k < 3 * na; ++k) lam[k] = plam[k];
  Vec vfree(nv), w(nv), q1(nq), v1(nv), ahead(nq), behind(nq), vt(nv), a0(nv);
  Mat A(nv, nv), Jc(3 * na, nv), AinvJt(nv, 3 * na), G(3 * na, 3 * na);
  Vec gvec(3 * na), second(na);
  std::vector<Vec3> drift(na);
  bool path_ready = false;  // the Data holds the kinematics of (q, v) on the step's path
  Mat forces = Mat::Zero(nc, 3);
  for (Py_ssize_t i = 0; i < nc; ++i)
    for (int j = 0; j < 3; ++j) forces(i, j) = pforces[3 * i + j];
  std::vector<bool> pushing(nc);
  Eigen::LLT<Mat> llt;
  double t = par[kT];
  const double step = par[kStep], duration = par[kDuration];
  const long max_steps = static_cast<long>(par[kMaxSteps]);
  Py_ssize_t next = static_cast<Py_ssize_t>(par[kNextSample]);
  long steps = 0, projections = 0;
  Py_ssize_t rows = 0;
  long reason = kBudget;
  const double rounding = 1e-3 * run.band;

  while (t < duration && steps < max_steps) {
    const double h = std::min(step, duration - t);
    // J̇v of the persistent points on the step's path, for the test below of their free motion, from the
    // kinematics of (q, v) with the path's acceleration: left by the last step, or computed now
    if (!path_ready) {
      run.path_acceleration(v, a0);
      pinocchio::forwardKinematics(m, d, q, v, a0);
    }
    for (Eigen::Index k = 0; k < na; ++k) {
      const Contact& ck = run.c[active[k]];
      const auto& vel = d.v[ck.joint];
      const auto& acc = d.a[ck.joint];
      const Vec3 om = vel.angular();
      drift[k] = d.oMi[ck.joint].rotation()
                 * (acc.linear() + acc.angular().cross(ck.local) + om.cross(vel.linear() + om.cross(ck.local)));
    }
    path_ready = false;
    if (!run.free_velocity(q, v, h, A, llt, vfree)) {
      reason = kInvalid;
      break;
    }
    // Persistent.step_velocity
    pinocchio::computeJointJacobians(m, d, q);
    for (Eigen::Index k = 0; k < na; ++k) {
      const Contact& ck = run.c[active[k]];
      const Eigen::Matrix<double, 3, Eigen::Dynamic> Jp = run.point_jacobian(ck);
      Jc.middleRows<3>(3 * k) = ck.frame.transpose() * Jp;
      const double gap = ck.normal.dot(run.point(ck) - ck.origin);
      gvec.segment<3>(3 * k) = ck.frame.transpose() * (Jp * vfree);
      gvec[3 * k + 2] += gap / h;
      second[k] = ck.normal.dot(Jp * (vfree - v) / h + drift[k]);
    }
    // Persistent.separating: every persistent contact leaving by itself is the Python route's event
    // a persistent point whose free second difference (its Taylor term h² n·(J a + J̇v)) is clearly negative
    // cannot leave: then the full test is not needed
    bool separating = true;
    for (Eigen::Index k = 0; k < na; ++k) {
      const int i = active[k];
      separating = separating && gaps0[i] >= -rounding && h * h * second[k] > -100.0 * rounding;
    }
    if (separating) {
      const Vec half = 0.5 * h * (vfree - v);
      run.step_configuration(q, h * v + half, ahead);
      run.step_configuration(q, -h * v + half, behind);
      separating = finite(ahead) && finite(behind);
      if (separating) {
        run.transport(q, ahead, vfree, vt);
        run.rates(ahead, vt, ga, ra);
        for (int i : active) separating = separating && ra[i] > 0.0;
      }
      if (separating) {
        run.gaps(behind, gb);
        for (int i : active) separating = separating && ga[i] + gb[i] - 2.0 * gaps0[i] > rounding;
      }
    }
    if (separating) {
      reason = kSeparating;
      break;
    }
    AinvJt = llt.solve(Jc.transpose());
    G.noalias() = Jc.lazyProduct(AinvJt);  // small: no blocked product
    G = (0.5 * (G + G.transpose())).eval();
    Vec trial = lam;
    if (!cone_solve(G, gvec, mus, par[kPgsTol], static_cast<int>(par[kPgsIterations]), trial)) {
      reason = kSolver;
      break;
    }
    double scale = 0.0;
    for (Eigen::Index k = 0; k < na; ++k) scale = std::max(scale, std::abs(trial[3 * k + 2]));
    w = vfree + AinvJt * trial;
    run.step_configuration(q, h * w, q1);
    run.transport(q, q1, w, v1);
    run.rates(q1, v1, gaps1, rates1, &a0);
    if (!finite(q1) || !finite(v1)) {
      reason = kInvalid;
      break;
    }
    // Persistent.path_crossing for frame contacts: an open one below its surface at the step's end
    bool crossing = false, below = false;
    for (Py_ssize_t i = 0; i < nc; ++i) {
      Contact& ck = run.c[i];
      if (ck.active) {
        below = below || gaps1[i] < -0.1 * run.band;
        continue;
      }
      if (!ck.armed && gaps0[i] > run.band) ck.armed = true;
      crossing = crossing || gaps1[i] < 0.0;
    }
    if (crossing) {
      reason = kCrossing;
      break;
    }
    // the step is taken (Persistent.contact_phase): its points back on their surfaces first
    for (Eigen::Index k = 0; k < na; ++k) {
      Contact& ck = run.c[active[k]];
      ck.pushing = trial[3 * k + 2] > 1e-9 * scale;
    }
    int rounds = 0;
    if (below) {
      rounds = run.project(q1, gaps1);
      run.rates(q1, v1, gaps1, rates1, &a0);
      // a point still below its surface, or an open contact the projection put there: the Python route's step
      bool left = false;
      for (Py_ssize_t i = 0; i < nc; ++i)
        left = left || gaps1[i] < (run.c[i].active ? -0.1 * run.band : 0.0);
      if (left) {
        reason = kCrossing;
        break;
      }
      projections += rounds;
    }
    path_ready = true;
    t += h;
    q = q1;
    v = v1;
    gaps0 = gaps1;
    lam = trial;
    ++steps;
    forces.setZero();
    for (Eigen::Index k = 0; k < na; ++k) {
      const Contact& ck = run.c[active[k]];
      forces.row(active[k]) = (ck.frame * trial.segment<3>(3 * k) / h).transpose();
    }
    // Persistent.lift_offs: a lift-off or a penetration is the Python route's
    bool lift = false;
    for (int i : active) {
      const Contact& ck = run.c[i];
      lift = lift || (!ck.pushing && gaps1[i] > run.band && rates1[i] > 0.0) || gaps1[i] < -run.tolerance;
    }
    if (lift) {
      reason = kLift;
      break;
    }
    // the output grid's samples up to t
    bool full = false;
    while (next < vgrid.rows && vgrid(next) <= t + 1e-12) {
      if (rows >= capacity) {
        full = true;
        break;
      }
      // Persistent.emit_samples and RunState.emit: one sample at t, the grid times before it passed
      ++next;
      while (next < vgrid.rows && vgrid(next) < t) ++next;
      double* row = prows + rows * width;
      row[0] = t;
      for (Eigen::Index k = 0; k < nq; ++k) row[1 + k] = q[k];
      for (Eigen::Index k = 0; k < nv; ++k) row[1 + nq + k] = v[k];
      for (Py_ssize_t i = 0; i < nc; ++i) {
        for (int j = 0; j < 3; ++j) row[1 + nq + nv + 3 * i + j] = forces(i, j);
        row[1 + nq + nv + 3 * nc + i] = gaps1[i];
        row[1 + nq + nv + 4 * nc + i] = rates1[i];
      }
      ++rows;
    }
    if (full) {
      reason = kFull;
      break;
    }
  }

  for (Eigen::Index k = 0; k < nq; ++k) pq[k] = q[k];
  for (Eigen::Index k = 0; k < nv; ++k) pv[k] = v[k];
  for (Py_ssize_t i = 0; i < nc; ++i) {
    pgaps[i] = gaps0[i];
    prates[i] = rates1[i];
    for (int j = 0; j < 3; ++j) pforces[3 * i + j] = forces(i, j);
    con[i * kCols + kArmed] = run.c[i].armed ? 1.0 : 0.0;
    con[i * kCols + kPushing] = run.c[i].pushing ? 1.0 : 0.0;
  }
  for (Eigen::Index k = 0; k < 3 * na; ++k) plam[k] = lam[k];
  par[kT] = t;
  par[kNextSample] = static_cast<double>(next);
  par[kStepsDone] = static_cast<double>(steps);
  par[kRowsWritten] = static_cast<double>(rows);
  par[kReason] = static_cast<double>(reason);
  par[kProjections] = static_cast<double>(projections);
  return PyLong_FromLong(reason);
}

}  // namespace mbimpact_native
