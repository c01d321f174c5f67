/* The batched plant's physics steps in C (issue 22): what inkarm.sim.batch.BatchPlant.step does
 * in NumPy between two steps of mujoco.batch, for every member at once, one control period per
 * call (the batch's own step called back through its Python method, ``Batch.step``).
 *
 * Per physics step, in the NumPy path's order (batch.py, the reference: the same bits,
 * tests/sim/test_batch_substeps.py), for members k and joints j:
 *
 *   q_m   = tick rint(q / tick) + sigma_q z           (encoder; the draws of each member's stream)
 *   I     = clip(I + K_i s (q* + qd* s - q_m), +-I_max)          (a command due: set point, s > 0)
 *   u     = K_p q* + ((K_d qd* + tau_ff) + I),  du = K_p h qd*   (native drives: ctrl = u, u += du)
 *   v     = v + alpha ((q_m - q_m,prev) / h - v)     (velocity from differences; else the exact qd)
 *   tau   = min(max(((tau_ff + K_p ((q* + 0) + qd* s - q_m)) + I) + K_d (qd* - v), -lim), lim)
 *   ... mujoco.batch steps (ids) ...
 *   F     = (((0 + n_0) + n_1) + n_2) + n_3           (the contact sensor's normals)
 *   touch = (t, stepped, F, tip before the step);  tip_prev = tip
 *   ring  = (t, q_m, qd (differences / servo units rint), tau, (F + sigma_F z) + b, tip A - o)
 *
 * with numpy's maximum/minimum (NaN stays NaN; of two equal values the second, as x86's
 * maxsd/minsd: setup.py builds this on x86-64 only), np.round as rint (halves to even, the
 * default rounding mode) and -ffp-contract=off. No MuJoCo or NumPy headers: every array comes as
 * a strided float64 buffer (the batch's bound arrays are views of its state rows).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <string.h>

#include "_drive.h"

/* What this module offers, as inkarm.sim.batch_substeps.API expects it */
#define INKARM_BATCH_API 2

/* The arrays a Substeps holds for its life (Python keeps them; it never replaces them). */
enum {
  QPOS, QVEL, CTRL, SENSOR, ACT_FORCE, SITE_XPOS, /* the batch's bound arrays */
  FLOOR, LIMIT, TO_PAGE, OFFSET,                   /* (N, n) motor clip; (N, 3, 3), (N, 3) */
  INTEGRAL, VEL, Q_PREV, SQ_PREV, MOTOR, PEN, TIP_PREV,
  GOAL_Q, GOAL_QD, GOAL_TAU, U, DU,
  RING_Q, RING_QD, RING_TORQUE, RING_FORCE, RING_TIP, RING_TIME,
  GAINS, /* (5, n): the drives' gains, _drive.h's rows */
  NBUF
};
static const char* names[NBUF] = {
    "qpos", "qvel", "ctrl", "sensordata", "actuator_force", "site_xpos", "floor", "limit",
    "to_page", "page_offset", "integral", "v", "q_prev", "sq_prev", "motor", "pen_force",
    "tip_prev", "goal_q", "goal_qd", "goal_tau", "u", "du", "ring_q", "ring_qd",
    "ring_torque", "ring_force", "ring_tip", "ring_time", "gains"};
static const int dims[NBUF] = {2, 2, 2, 2, 2, 3, 2, 2, 3, 2, 2, 2, 2, 2, 2, 1, 2,
                               2, 2, 2, 2, 2, 3, 3, 3, 2, 3, 1, 2};
static const int outputs[NBUF] = {0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1,
                                  1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 0};

typedef struct {
  char* p;
  Py_ssize_t s0, s1, s2;
} View;

#define A1(v, i) (*(double*)((v).p + (i) * (v).s0))
#define A2(v, i, j) (*(double*)((v).p + (i) * (v).s0 + (j) * (v).s1))
#define A3(v, i, j, l) (*(double*)((v).p + (i) * (v).s0 + (j) * (v).s1 + (l) * (v).s2))

typedef struct {
  PyObject_HEAD
  Py_buffer bufs[NBUF];
  View v[NBUF];
  int held;
  int N, n, substeps, native, exact_q, differences, servo, ideal, stage, ring, tip_site;
  int normal_adr, normal_count;
  int *qpos_adr, *dof_adr, *arm;
  double h, alpha, tick, q_noise, force_noise, force_bias, servo_unit;
  double* scratch; /* 3 N n: q_m, the recorded q, qd */
  /* where the last call of period() stopped, whatever ended it (a Ctrl-C in the batch's
   * step, an array refused): the counters of the physics steps it completed and the set
   * points it applied, for progress(); left = 0 where its arguments were not taken */
  double left_since, left_time;
  Py_ssize_t left_steps, left_cursor, left_row, left_events;
  int left_active, left_have_prev, left_have_sq, left;
} Substeps;

/* A strided float64 buffer of `ndim` dimensions (itemsize `size`: 8, or 1 for a bool mask). */
static int get_view(PyObject* obj, Py_buffer* buf, View* view, int ndim, int writable,
                    int size, const char* name) {
  int flags = PyBUF_STRIDES | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
  if (PyObject_GetBuffer(obj, buf, flags) < 0) return -1;
  const char* f = buf->format ? buf->format : "B";
  if (*f == '<' || *f == '=' || *f == '@') f++;
  int ok = buf->ndim == ndim && buf->itemsize == size &&
           (size == 8 ? strcmp(f, "d") == 0 : (strcmp(f, "?") == 0 || strcmp(f, "B") == 0));
  if (!ok) {
    PyErr_Format(PyExc_TypeError, "Substeps: %s must be a %s%d-d %s array", name,
                 writable ? "writable " : "", ndim, size == 8 ? "float64" : "bool");
    PyBuffer_Release(buf);
    return -1;
  }
  view->p = buf->buf;
  view->s0 = buf->strides[0];
  view->s1 = ndim > 1 ? buf->strides[1] : 0;
  view->s2 = ndim > 2 ? buf->strides[2] : 0;
  return 0;
}

static void release(Substeps* self) {
  for (int i = 0; i < self->held; i++) PyBuffer_Release(self->bufs + i);
  self->held = 0;
  PyMem_Free(self->qpos_adr);
  PyMem_Free(self->scratch);
  self->qpos_adr = NULL;
  self->scratch = NULL;
}

static void substeps_dealloc(Substeps* self) {
  release(self);
  Py_TYPE(self)->tp_free((PyObject*)self);
}

/* The largest of n ints, or -1. */
static int largest(const int* x, int n) {
  int top = -1;
  for (int i = 0; i < n; i++) top = x[i] > top ? x[i] : top;
  return top;
}

/* Whether every array the C indexes has the rows and columns it indexes (else ValueError naming
 * the first that does not): the members' rows N, the joints' n, the ring's slots, and the
 * indices into the batch's arrays (qpos, qvel, ctrl, sensordata, site_xpos) within them. */
static int fits(Substeps* self) {
  const Py_buffer* b = self->bufs;
  const int N = self->N, n = self->n, ring = self->ring;
  for (int i = 0; i < NBUF; i++) {
    if (i == GAINS || i == RING_TIME) continue;
    const int ring_array = i >= RING_Q && i <= RING_TIP;
    const Py_ssize_t first = ring_array ? ring : N, second = ring_array ? N : -1;
    if (b[i].shape[0] != first || (second >= 0 && b[i].shape[1] != second)) {
      PyErr_Format(PyExc_ValueError, "Substeps: %s has %zd rows, expected %zd", names[i],
                   b[i].shape[0], first);
      return -1;
    }
  }
  const int ring_n[] = {RING_Q, RING_QD, RING_TORQUE}, ring_3[] = {RING_TIP};
  for (int i = 0; i < 3; i++)
    if (b[ring_n[i]].shape[2] != n) {
      PyErr_Format(PyExc_ValueError, "Substeps: %s must be (ring, N, n)", names[ring_n[i]]);
      return -1;
    }
  if (b[ring_3[0]].shape[2] != 3 || b[TIP_PREV].shape[1] != 3 || b[OFFSET].shape[1] != 3 ||
      b[TO_PAGE].shape[1] != 3 || b[TO_PAGE].shape[2] != 3 || b[SITE_XPOS].shape[2] != 3 ||
      largest(self->qpos_adr, n) >= b[QPOS].shape[1] ||
      largest(self->dof_adr, n) >= b[QVEL].shape[1] ||
      largest(self->arm, n) >= b[CTRL].shape[1] || largest(self->arm, n) >= b[ACT_FORCE].shape[1] ||
      self->tip_site < 0 || self->tip_site >= b[SITE_XPOS].shape[1] || self->normal_adr < 0 ||
      self->normal_count < 0 || self->normal_adr + 3 * self->normal_count > b[SENSOR].shape[1]) {
    PyErr_SetString(PyExc_ValueError,
                    "Substeps: an index past its array (qpos_adr, dof_adr, arm, tip_site or the "
                    "sensor's normals), or a tip, page or frame array not of 3");
    return -1;
  }
  return 0;
}

/* n ints of the sequence `seq` into out. */
static int int_list(PyObject* seq, int n, int* out, const char* name) {
  PyObject* fast = PySequence_Fast(seq, name);
  if (fast == NULL) return -1;
  if (PySequence_Fast_GET_SIZE(fast) != n) {
    PyErr_Format(PyExc_ValueError, "Substeps: %s needs %d indices", name, n);
    Py_DECREF(fast);
    return -1;
  }
  for (int i = 0; i < n; i++) {
    out[i] = (int)PyLong_AsLong(PySequence_Fast_GET_ITEM(fast, i));
    if (out[i] == -1 && PyErr_Occurred()) {
      Py_DECREF(fast);
      return -1;
    }
  }
  Py_DECREF(fast);
  return 0;
}

/* Substeps(arrays, qpos_adr, dof_adr, arm, (normal_adr, normal_count, tip_site),
 *          (N, n, substeps, ring, stage, native, exact_q, differences, servo, ideal),
 *          (h, alpha, tick, q_noise, force_noise, force_bias, servo_unit)) */
static int substeps_init(Substeps* self, PyObject* args, PyObject* kwds) {
  PyObject *arrays, *qpos_adr, *dof_adr, *arm;
  release(self);
  if (!PyArg_ParseTuple(args, "O!OOO(iii)(iiiiiiiiii)(ddddddd)", &PyTuple_Type, &arrays,
                        &qpos_adr, &dof_adr, &arm, &self->normal_adr, &self->normal_count,
                        &self->tip_site, &self->N, &self->n, &self->substeps, &self->ring,
                        &self->stage, &self->native, &self->exact_q, &self->differences,
                        &self->servo, &self->ideal, &self->h, &self->alpha, &self->tick,
                        &self->q_noise, &self->force_noise, &self->force_bias,
                        &self->servo_unit))
    return -1;
  if (PyTuple_GET_SIZE(arrays) != NBUF) {
    PyErr_Format(PyExc_ValueError, "Substeps: %d arrays expected", NBUF);
    return -1;
  }
  for (int i = 0; i < NBUF; i++) {
    if (get_view(PyTuple_GET_ITEM(arrays, i), self->bufs + i, self->v + i, dims[i], outputs[i],
                 8, names[i]) < 0)
      return -1;
    self->held++;
  }
  const int n = self->n, N = self->N;
  for (int i = FLOOR; i <= DU; i++)
    if (dims[i] == 2 && i != OFFSET && i != TIP_PREV &&
        (self->bufs[i].shape[0] != N || self->bufs[i].shape[1] != n)) {
      PyErr_Format(PyExc_ValueError, "Substeps: %s must be (N, n) = (%d, %d)", names[i], N, n);
      return -1;
    }
  if (!PyBuffer_IsContiguous(self->bufs + GAINS, 'C') || self->bufs[GAINS].shape[0] != 5 ||
      self->bufs[GAINS].shape[1] != n || self->bufs[RING_TIME].shape[0] != self->ring) {
    PyErr_SetString(PyExc_ValueError, "Substeps: gains: a contiguous (5, n); ring_time: (ring,)");
    return -1;
  }
  self->qpos_adr = PyMem_Calloc(3 * (size_t)n + 1, sizeof(int));
  self->scratch = PyMem_Calloc(3 * (size_t)N * n + 1, sizeof(double));
  if (self->qpos_adr == NULL || self->scratch == NULL) {
    PyErr_NoMemory();
    return -1;
  }
  self->dof_adr = self->qpos_adr + n;
  self->arm = self->dof_adr + n;
  if (int_list(qpos_adr, n, self->qpos_adr, "qpos_adr") < 0 ||
      int_list(dof_adr, n, self->dof_adr, "dof_adr") < 0 || int_list(arm, n, self->arm, "arm") < 0)
    return -1;
  return fits(self);
}

typedef struct {
  View draws;
  Py_ssize_t cursor, columns;
} Draws;

/* Member k's draw `j` columns past the cursor (checked by the caller's reserve). */
#define DRAW(d, k, j) A2((d).draws, (k), (d).cursor + (j))

/* The encoder's reading of every member's joints into q (N n, row-major). */
static void position(const Substeps* self, Draws* d, double* q) {
  const View* v = self->v;
  const int N = self->N, n = self->n;
  for (int k = 0; k < N; k++)
    for (int j = 0; j < n; j++) {
      double x = A2(v[QPOS], k, self->qpos_adr[j]);
      if (!self->exact_q) {
        if (self->tick != 0.0) x = self->tick * rint(x / self->tick);
        if (self->q_noise != 0.0) x = x + self->q_noise * DRAW(*d, k, j);
      }
      q[k * n + j] = x;
    }
  if (!self->exact_q && self->q_noise != 0.0) d->cursor += n;
}

/* JointDrive.set_point (the goals of `event`, q_link = q_m), then affine_control where native. */
static int set_point(Substeps* self, PyObject* event, const double* q_m, double* since,
                     int active) {
  View* v = self->v;
  const int N = self->N, n = self->n;
  const double* g = (double*)self->bufs[GAINS].buf;
  const double *kp = g + DRIVE_KP * n, *kd = g + DRIVE_KD * n, *ki = g + DRIVE_KI * n;
  const double *kp_h = g + DRIVE_KP_H * n, *limit = g + DRIVE_LIMIT * n;
  if (active && *since > 0.0)
    for (int k = 0; k < N; k++)
      for (int j = 0; j < n; j++)
        A2(v[INTEGRAL], k, j) = drive_integral(A2(v[INTEGRAL], k, j), A2(v[GOAL_Q], k, j),
                                               A2(v[GOAL_QD], k, j), q_m[k * n + j], ki[j],
                                               *since, limit[j]);
  for (int g = 0; g < 3; g++) { /* the goals as given: copied into the drive's */
    Py_buffer buf;
    View given;
    if (get_view(PyTuple_GET_ITEM(event, g + 1), &buf, &given, 2, 0, 8, "a goal") < 0) return -1;
    if (buf.shape[0] != N || buf.shape[1] != n) {
      PyBuffer_Release(&buf);
      PyErr_SetString(PyExc_ValueError, "Substeps: goals must be (N, n)");
      return -1;
    }
    for (int k = 0; k < N; k++)
      for (int j = 0; j < n; j++) A2(v[GOAL_Q + g], k, j) = A2(given, k, j);
    PyBuffer_Release(&buf);
  }
  *since = 0.0;
  if (self->native)
    for (int k = 0; k < N; k++)
      for (int j = 0; j < n; j++)
        drive_affine(kp[j], kd[j], kp_h[j], A2(v[GOAL_Q], k, j), A2(v[GOAL_QD], k, j),
                     A2(v[GOAL_TAU], k, j), A2(v[INTEGRAL], k, j), &A2(v[U], k, j),
                     &A2(v[DU], k, j));
  return 0;
}

/* BatchPlant._actuate: the motor torques (or the native drives' controls) of one step. */
static void torques(Substeps* self, const double* q_m, double* since, int* have_prev) {
  View* v = self->v;
  const int N = self->N, n = self->n;
  const double* g = (double*)self->bufs[GAINS].buf;
  const double *kp = g + DRIVE_KP * n, *kd = g + DRIVE_KD * n;
  if (self->native) {
    for (int k = 0; k < N; k++)
      for (int j = 0; j < n; j++) {
        A2(v[CTRL], k, self->arm[j]) = A2(v[U], k, j);
        A2(v[U], k, j) = A2(v[U], k, j) + A2(v[DU], k, j);
      }
    *since += self->h;
    return;
  }
  if (self->differences) {
    for (int k = 0; k < N; k++)
      for (int j = 0; j < n; j++) {
        const double x = q_m[k * n + j];
        if (*have_prev) {
          double raw = (x - A2(v[Q_PREV], k, j)) / self->h;
          A2(v[VEL], k, j) = A2(v[VEL], k, j) + self->alpha * (raw - A2(v[VEL], k, j));
        }
        A2(v[Q_PREV], k, j) = x;
      }
    *have_prev = 1;
  }
  const double s = *since;
  for (int k = 0; k < N; k++)
    for (int j = 0; j < n; j++) {
      double vel = self->differences ? A2(v[VEL], k, j) : A2(v[QVEL], k, self->dof_adr[j]);
      double qd = A2(v[GOAL_QD], k, j);
      double error = (A2(v[GOAL_Q], k, j) + 0.0) + qd * s; /* (+ the rigid drive's lead, 0) */
      error = error - q_m[k * n + j];
      double tau = A2(v[GOAL_TAU], k, j) + kp[j] * error;
      tau = tau + A2(v[INTEGRAL], k, j);
      tau = tau + kd[j] * (qd - vel);
      double floor = A2(v[FLOOR], k, j), limit = A2(v[LIMIT], k, j);
      tau = (tau > floor || tau != tau) ? tau : floor;
      A2(v[MOTOR], k, j) = (tau < limit || tau != tau) ? tau : limit;
    }
  *since = s + self->h;
}

/* The reading of the step just taken into the ring's `slot` (BatchPlant._record). */
static void record(Substeps* self, Draws* d, Py_ssize_t slot, double time, int* have_sq) {
  View* v = self->v;
  const int N = self->N, n = self->n;
  double *q = self->scratch + (size_t)N * n, *qd = q + (size_t)N * n;
  position(self, d, q);
  for (int k = 0; k < N; k++)
    for (int j = 0; j < n; j++) {
      double x = q[k * n + j], rate;
      if (self->differences) {
        double prev = *have_sq ? A2(v[SQ_PREV], k, j) : x;
        rate = (x - prev) / self->h;
        A2(v[SQ_PREV], k, j) = x;
      } else {
        rate = A2(v[QVEL], k, self->dof_adr[j]);
        if (self->servo) rate = self->servo_unit * rint(rate / self->servo_unit);
      }
      qd[k * n + j] = rate;
    }
  if (self->differences) *have_sq = 1;
  A1(v[RING_TIME], slot) = time;
  for (int k = 0; k < N; k++) {
    for (int j = 0; j < n; j++) {
      A3(v[RING_Q], slot, k, j) = q[k * n + j];
      A3(v[RING_QD], slot, k, j) = qd[k * n + j];
      A3(v[RING_TORQUE], slot, k, j) = A2(v[MOTOR], k, j);
    }
    double force = A1(v[PEN], k);
    if (self->force_noise != 0.0) force = force + self->force_noise * DRAW(*d, k, 0);
    A2(v[RING_FORCE], slot, k) = force + self->force_bias;
    const double x = A3(v[SITE_XPOS], k, self->tip_site, 0);
    const double y = A3(v[SITE_XPOS], k, self->tip_site, 1);
    const double z = A3(v[SITE_XPOS], k, self->tip_site, 2);
    for (int i = 0; i < 3; i++) {
      double p = x * A3(v[TO_PAGE], k, 0, i) + y * A3(v[TO_PAGE], k, 1, i);
      p = p + z * A3(v[TO_PAGE], k, 2, i);
      A3(v[RING_TIP], slot, k, i) = p - A2(v[OFFSET], k, i);
    }
  }
  if (self->force_noise != 0.0) d->cursor += 1;
}

/* period(step, ids, stepped, events, draws, cursor, touch_t, touch_on, touch_force, touch_tip, row,
 *        since, time, steps, active, have_prev, have_sq_prev)
 * One control period: `substeps` physics steps of members `ids` (None: all; `stepped` the (N,)
 * bool mask of them, or None), each by step(ids, 1, stage) (the batch's Batch.step, looked up
 * by the caller at each period), the set points `events` ((substep, q, qd, tau_ff), in order)
 * applied at their steps, normals drawn from column `cursor` of `draws`, touches written from
 * row `row`. Returns None; progress() says where it stopped, whatever ended it: (since, time,
 * steps, cursor, row, active, have_prev, have_sq_prev, set points applied). */
static PyObject* substeps_period(Substeps* self, PyObject* args) {
  PyObject *step, *ids, *stepped_obj, *events, *draws_obj, *t_obj, *on_obj, *f_obj, *tip_obj;
  Py_ssize_t cursor, row, steps;
  double since, time;
  int active, have_prev, have_sq;
  if (self->held != NBUF) {
    PyErr_SetString(PyExc_RuntimeError, "Substeps: not initialised");
    return NULL;
  }
  self->left = 0;
  PyObject* given_events;
  if (!PyArg_ParseTuple(args, "OOOOOnOOOOnddnppp", &step, &ids, &stepped_obj, &given_events,
                        &draws_obj, &cursor, &t_obj, &on_obj, &f_obj, &tip_obj, &row, &since,
                        &time, &steps, &active, &have_prev, &have_sq))
    return NULL;
  /* (a tuple of its own: the step's callback cannot change what is being applied) */
  events = PySequence_Tuple(given_events);
  if (events == NULL) return NULL;
  const int N = self->N, n = self->n, every = stepped_obj == Py_None;
  Py_buffer bufs[6];
  View views[6];
  PyObject* objs[6] = {draws_obj, t_obj, on_obj, f_obj, tip_obj, stepped_obj};
  const int nd[6] = {2, 1, 2, 2, 3, 1}, sizes[6] = {8, 8, 1, 8, 8, 1};
  const char* what[6] = {"draws", "touch_t", "touch_on", "touch_force", "touch_tip", "stepped"};
  int got = 0;
  Py_ssize_t next = 0; /* the set points applied */
  PyObject* result = NULL;
  for (; got < (every ? 5 : 6); got++)
    if (get_view(objs[got], bufs + got, views + got, nd[got], got > 0 && got < 5, sizes[got],
                 what[got]) < 0)
      goto done;
  Draws d = {views[0], cursor, bufs[0].shape[1]};
  const int per_step = (self->exact_q || self->q_noise == 0.0 ? 0 : 2 * n) +
                       (self->force_noise != 0.0 && !self->ideal);
  if (bufs[0].shape[0] != N || cursor < 0 || row < 0 ||
      cursor + (Py_ssize_t)self->substeps * per_step > d.columns) {
    PyErr_SetString(PyExc_ValueError, "Substeps: too few draws for a period");
    goto done;
  }
  /* every touch array: rows for the period's steps, one column per member (the tips' 3) */
  const Py_ssize_t rows = bufs[1].shape[0];
  for (int i = 2; i < 5; i++)
    if (bufs[i].shape[0] != rows || bufs[i].shape[1] != N || (i == 4 && bufs[i].shape[2] != 3)) {
      PyErr_Format(PyExc_ValueError, "Substeps: %s must have %zd rows of the %d members",
                   what[i], rows, N);
      goto done;
    }
  if (row + self->substeps > rows || (!every && bufs[5].shape[0] != N)) {
    PyErr_SetString(PyExc_ValueError,
                    "Substeps: too few touch rows for a period, or stepped not one per member");
    goto done;
  }
  View touch_t = views[1], touch_on = views[2], touch_f = views[3], touch_tip = views[4];
  View* v = self->v;
  double* q_m = self->scratch;
  const Py_ssize_t nevents = PyTuple_GET_SIZE(events);
  for (int s = 0; s < self->substeps; s++) {
    PyObject* event = next < nevents ? PyTuple_GET_ITEM(events, next) : NULL;
    int due = 0;
    if (event != NULL) {
      if (!PyTuple_Check(event) || PyTuple_GET_SIZE(event) != 4) {
        PyErr_SetString(PyExc_TypeError, "Substeps: an event is (substep, q, qd, tau_ff)");
        goto done;
      }
      long at = PyLong_AsLong(PyTuple_GET_ITEM(event, 0));
      if (at == -1 && PyErr_Occurred()) goto done;
      due = at == s;
    }
    if (active || due) {
      position(self, &d, q_m);
      if (due) {
        if (set_point(self, event, q_m, &since, active) < 0) goto done;
        active = 1;
        next++;
      }
      torques(self, q_m, &since, &have_prev);
    }
    if (!self->native)
      for (int k = 0; k < N; k++)
        if (every || *(char*)(views[5].p + k * views[5].s0))
          for (int j = 0; j < n; j++) A2(v[CTRL], k, self->arm[j]) = A2(v[MOTOR], k, j);
    PyObject* out = PyObject_CallFunction(step, "Oii", ids, 1, self->stage);
    if (out == NULL) goto done;
    Py_DECREF(out);
    if (self->native)
      for (int k = 0; k < N; k++)
        for (int j = 0; j < n; j++) A2(v[MOTOR], k, j) = A2(v[ACT_FORCE], k, self->arm[j]);
    time += self->h;
    A1(touch_t, row) = time - self->h;
    for (int k = 0; k < N; k++) {
      int on = every || *(char*)(views[5].p + k * views[5].s0);
      double force = 0.0;
      for (int c = 0; c < self->normal_count; c++) {
        double x = A2(v[SENSOR], k, self->normal_adr + 3 * c);
        force = force + x; /* (numpy's sum: from +0, so that -0 sums to +0) */
      }
      *(char*)(touch_on.p + row * touch_on.s0 + k * touch_on.s1) = (char)on;
      A2(touch_f, row, k) = on ? force : 0.0;
      for (int i = 0; i < 3; i++) {
        A3(touch_tip, row, k, i) = A2(v[TIP_PREV], k, i);
        if (on) A2(v[TIP_PREV], k, i) = A3(v[SITE_XPOS], k, self->tip_site, i);
      }
      if (on) A1(v[PEN], k) = force;
    }
    row++;
    steps++;
    if (!self->ideal) record(self, &d, steps % self->ring, time, &have_sq);
  }
  if (next != nevents) {
    PyErr_SetString(PyExc_ValueError, "Substeps: an event past the period's steps");
    goto done;
  }
  result = Py_NewRef(Py_None); /* (what it did: progress()) */
done:
  self->left = 1;
  self->left_since = since, self->left_time = time;
  self->left_steps = steps, self->left_cursor = got == (every ? 5 : 6) ? d.cursor : cursor;
  self->left_row = row, self->left_events = next, self->left_active = active;
  self->left_have_prev = have_prev, self->left_have_sq = have_sq;
  for (int i = 0; i < got; i++) PyBuffer_Release(bufs + i);
  Py_DECREF(events);
  return result;
}

static PyObject* substeps_progress(Substeps* self, PyObject* Py_UNUSED(ignored)) {
  if (!self->left) Py_RETURN_NONE;
  return Py_BuildValue("(ddnnnNNNn)", self->left_since, self->left_time, self->left_steps,
                       self->left_cursor, self->left_row, PyBool_FromLong(self->left_active),
                       PyBool_FromLong(self->left_have_prev),
                       PyBool_FromLong(self->left_have_sq), self->left_events);
}

static PyMethodDef substeps_methods[] = {
    {"period", (PyCFunction)substeps_period, METH_VARARGS,
     "One control period of every member's physics steps (see the module's source)."},
    {"progress", (PyCFunction)substeps_progress, METH_NOARGS,
     "After a period that raised: (since, time, steps, cursor, row, active, have_prev, "
     "have_sq) of the physics steps it completed; else None."},
    {NULL, NULL, 0, NULL}};

static PyTypeObject SubstepsType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "inkarm.sim._batch.Substeps",
    .tp_basicsize = sizeof(Substeps),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "A BatchPlant's physics steps in C (inkarm.sim.batch_substeps).",
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)substeps_init,
    .tp_dealloc = (destructor)substeps_dealloc,
    .tp_methods = substeps_methods,
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_batch",
                                    "The batched plant's physics steps in C.", -1, NULL};

PyMODINIT_FUNC PyInit__batch(void) {
  if (PyType_Ready(&SubstepsType) < 0) return NULL;
  PyObject* m = PyModule_Create(&module);
  if (m == NULL) return NULL;
  Py_INCREF(&SubstepsType);
  if (PyModule_AddObject(m, "Substeps", (PyObject*)&SubstepsType) < 0 ||
      PyModule_AddIntConstant(m, "API", INKARM_BATCH_API) < 0) {
    Py_DECREF(&SubstepsType);
    Py_DECREF(m);
    return NULL;
  }
  return m;
}
