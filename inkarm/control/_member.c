/* One member's control period in one call (issue 22 part 2): the executor's steps 2-4
 * (inkarm/control/executor.py, _member) for the common case, in the order of their Python
 * arithmetic, so that both give the same bits (tests/control/test_member_lane.py):
 *
 *     lag    = (t_first + row dt - t) / dt            (whole periods up to 1e-6: rounded)
 *     seen, blend                                     (the plan row the reading belongs to)
 *     F_f    = F_f + s (F - F_f)                      ForceLoop.shape (inkarm/control/force.py)
 *     z      = max(z + k_F (F* - F_f), -z_max)  or  z + v_s dt  (the guarded search)
 *     h, r, tau_L r                                   ForceLoop._measure (the lead)
 *     P      <- (x, y, P(x, y) + z); z -= dP           SurfaceEstimate.add (the plane)
 *     d      = z + P(x_c, y_c) [+ tau_L r]            ForceLoop.depth, at c = i + lead rows
 *     q_row  = q_ref[c] + d normal_q[c];  q* = q_row [+ lookahead_step[c]]
 *     tau_ff                                          the position law (_law.c)
 *     the log row, the pen's distance from its reference, the watchdogs
 *
 * and returns PositionCommand(q*, qd_ref[c], qdd_ref[c], tau_ff); advance() then moves to the
 * next plan row (or holds the end of a descent until the force settles), as the executor does
 * after the period's step. What stays in Python, called from here: the plane's 3 x 3 solve
 * (SurfaceEstimate.plane, every refit_every samples: NumPy's LAPACK gives its bits), the
 * watchdogs whenever the cheap test below is not conclusive (Watchdogs.check: the same state,
 * counters and messages), and the search's fault (ForceLoop.search_failed).
 *
 * The cheap test: every joint strictly inside its range, speed and torque envelope, the force
 * at or below force_limit and the pen within tracking_limit of its reference (with a margin of
 * 1e-9 relative: C's hypot and Python's may part in the last bit), in a period after another
 * such period (then the watchdogs' counters are zero and their state is what Watchdogs.check
 * would leave). Otherwise Watchdogs.check runs, with math.hypot's distance.
 *
 * A reading this period cannot take (arrays that are not float64 of the arm's length, a force
 * that is not a number) raises NotForLane before anything changes: the executor then goes on in
 * Python from this period (export() hands over the state).
 *
 * _member_batch.c's periods() takes the period of every member of a batch in one call, with
 * these same steps (period_ready, period_steps, period_advance; _member.h).
 */
#include <math.h>
#include <string.h>

#include "_member.h"
#include "../core/_plant.h"

static PyObject* NotForLane = NULL;
static PyObject *s_time, *s_q, *s_qd, *s_torque, *s_force, *s_tip_mm;

#define RATE_DEAD_BAND 4e-3 /* (inkarm.control.force.RATE_DEAD_BAND, checked at init) */

static void member_clear(MemberPeriod* self) {
  for (int k = 0; k < NV; k++)  /* (taken out of index order: each one that is held) */
    if (self->v[k].obj != NULL) PyBuffer_Release(self->v + k);
  Py_CLEAR(self->qd_ref);
  Py_CLEAR(self->qdd_ref);
  Py_CLEAR(self->law);
  Py_CLEAR(self->check);
  Py_CLEAR(self->plane);
  Py_CLEAR(self->search_failed);
  Py_CLEAR(self->hypot);
  Py_CLEAR(self->empty);
  Py_CLEAR(self->command_type);
  Py_CLEAR(self->n_obj);
  PyMem_Free(self->depths);
  PyMem_Free(self->envelope);
  PyMem_Free(self->scratch);
  self->depths = self->envelope = self->scratch = NULL;
  self->n = 0;
}

static void member_dealloc(MemberPeriod* self) {
  member_clear(self);
  Py_TYPE(self)->tp_free((PyObject*)self);
}

/* The buffer of obj as v[k]: format fmt ("d", "q": int64, "?"), ndim 1 or 2, its first dimension
 * rows (-1: any), its second cols (ndim 2). 0, or -1 with a ValueError naming it. */
static int take(MemberPeriod* self, int k, PyObject* obj, const char* fmt, int ndim,
                Py_ssize_t rows, Py_ssize_t cols, int writable, const char* name) {
  int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_ND | (writable ? PyBUF_WRITABLE : 0);
  if (PyObject_GetBuffer(obj, self->v + k, flags) < 0) {
    self->v[k].obj = NULL;
    return -1;
  }
  Py_buffer* b = self->v + k;
  /* ("q": 8-byte integers, which NumPy names "l" where a long has 8 bytes) */
  int same = b->format != NULL && (strcmp(b->format, fmt) == 0 ||
                                   (fmt[0] == 'q' && b->itemsize == 8 && strcmp(b->format, "l") == 0));
  int ok = same && b->ndim == ndim &&
           (rows < 0 || b->shape[0] == rows) && (ndim == 1 || b->shape[1] == cols);
  if (!ok) {
    PyErr_Format(PyExc_ValueError, "_law.MemberPeriod: %s must be of format %s, %d-d, %zd rows "
                 "(x %zd)", name, fmt, ndim, rows, cols);
    return -1;
  }
  return 0;
}

static int doubles_into(PyObject* seq, double* out, Py_ssize_t n, const char* name) {
  PyObject* fast = PySequence_Fast(seq, name);
  if (fast == NULL) return -1;
  if (PySequence_Fast_GET_SIZE(fast) != n) {
    Py_DECREF(fast);
    PyErr_Format(PyExc_ValueError, "_law.MemberPeriod: %s needs %zd numbers", name, n);
    return -1;
  }
  for (Py_ssize_t k = 0; k < n; k++) out[k] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(fast, k));
  Py_DECREF(fast);
  return PyErr_Occurred() ? -1 : 0;
}

/* MemberPeriod(plan, log, law, force_loop, check, envelope, limits, settle, phases, makers):
 * see inkarm/control/member_lane.py, which builds it. */
static int member_init(MemberPeriod* self, PyObject* args, PyObject* kwds) {
  PyObject *plan, *log, *law, *loop, *check, *envelope, *makers;
  double force_limit, tracking_limit, dt, t_first;
  int has_t_first, approach, descend, draw, home;
  member_clear(self);
  if (!PyArg_ParseTuple(args, "OOO!OOOddiiii(iiii)dpdO", &plan, &log, &PositionLawType, &law,
                        &loop, &check, &envelope, &force_limit, &tracking_limit,
                        &self->lookahead_rows, &self->senses_force, &self->settle_ticks,
                        &self->timeout_ticks, &approach, &descend, &draw, &home, &dt,
                        &has_t_first, &t_first, &makers))
    return -1;
  /* plan: (q_ref, normal_q, lookahead_step or None, page_x, page_y, phases, hold_at, qd_ref,
   * qdd_ref); log: (time, q, qd, torque, tip, force, commanded, ref_row, ref_blend) */
  PyObject *q_ref, *normal, *step, *px, *py, *phase, *hold, *qd_ref, *qdd_ref, *ltime, *lq, *lqd,
      *ltorque, *ltip, *lforce, *commanded, *ref_row, *blend;
  if (!PyArg_ParseTuple(plan, "OOOOOOOOO", &q_ref, &normal, &step, &px, &py, &phase, &hold,
                        &qd_ref, &qdd_ref) ||
      !PyArg_ParseTuple(log, "OOOOOOOOO", &ltime, &lq, &lqd, &ltorque, &ltip, &lforce, &commanded,
                        &ref_row, &blend))
    return -1;
  self->qd_ref = Py_NewRef(qd_ref);  /* (references of our own from here: member_clear's) */
  self->qdd_ref = Py_NewRef(qdd_ref);
  PositionLaw* pl = (PositionLaw*)law;
  Py_ssize_t n = pl->n, rows = pl->rows;
  if (n < 1) {
    PyErr_SetString(PyExc_ValueError, "_law.MemberPeriod: the law is not initialised");
    return -1;
  }
  if (take(self, V_QREF, q_ref, "d", 2, rows, n, 0, "q_ref") < 0 ||
      take(self, V_NORMAL, normal, "d", 2, rows, n, 0, "normal_q") < 0 ||
      take(self, V_PX, px, "d", 1, rows, 0, 0, "page_x") < 0 ||
      take(self, V_PY, py, "d", 1, rows, 0, 0, "page_y") < 0 ||
      take(self, V_PHASE, phase, "q", 1, rows, 0, 0, "phases") < 0 ||
      take(self, V_HOLD, hold, "?", 1, rows, 0, 0, "hold_at") < 0)
    return -1;
  self->lookahead = step != Py_None;
  if (self->lookahead) {
    if (take(self, V_STEP, step, "d", 2, rows - 1, n, 0, "lookahead_step") < 0) return -1;
  } else {
    if (PyObject_GetBuffer(q_ref, self->v + V_STEP, PyBUF_SIMPLE) < 0) {  /* (never read) */
      self->v[V_STEP].obj = NULL;
      return -1;
    }
  }
  if (take(self, V_LTIME, ltime, "d", 1, -1, 0, 1, "log time") < 0) return -1;
  Py_ssize_t cap = self->v[V_LTIME].shape[0];
  if (take(self, V_LQ, lq, "d", 2, cap, n, 1, "log q") < 0 ||
      take(self, V_LQD, lqd, "d", 2, cap, n, 1, "log qd") < 0 ||
      take(self, V_LTORQUE, ltorque, "d", 2, cap, n, 1, "log torque") < 0 ||
      take(self, V_LTIP, ltip, "d", 2, cap, 3, 1, "log tip") < 0 ||
      take(self, V_LFORCE, lforce, "d", 1, cap, 0, 1, "log force") < 0 ||
      take(self, V_COMMANDED, commanded, "q", 1, cap, 0, 1, "commanded") < 0 ||
      take(self, V_REFROW, ref_row, "q", 1, cap, 0, 1, "ref_row") < 0 ||
      take(self, V_BLEND, blend, "d", 1, cap, 0, 1, "ref_blend") < 0 ||
      take(self, V_QD, self->qd_ref, "d", 2, rows, n, 0, "qd_ref") < 0)
    return -1;
  /* the force loop: (smoothing, threshold, k_force, f_star, z_limit, search_step, settle_tol,
   * k_inv, rate_smoothing, inv_dt, lead_gain, sampling, lag, dead_band, prior, refit_every,
   * search_failed, plane) */
  PyObject *search_failed, *plane;
  double dead_band;
  if (!PyArg_ParseTuple(loop, "dddddddddddpiddlOO", &self->smoothing, &self->threshold,
                        &self->k_force, &self->f_star, &self->z_limit, &self->search_step,
                        &self->settle_tol, &self->k_inv, &self->rate_smoothing, &self->inv_dt,
                        &self->lead_gain, &self->sampling, &self->lag, &dead_band, &self->prior,
                        &self->refit_every, &search_failed, &plane))
    return -1;
  if (dead_band != RATE_DEAD_BAND || self->lag < 1 || self->refit_every < 1) {
    PyErr_SetString(PyExc_ValueError, "_law.MemberPeriod: the force loop's dead band, lag or "
                    "refit interval is not this file's");
    return -1;
  }
  self->depths = PyMem_New(double, 3 * (size_t)self->lag);
  self->scratch = PyMem_New(double, 6 * n + 3);
  if (self->depths == NULL || self->scratch == NULL) {
    PyErr_NoMemory();
    return -1;
  }
  for (int k = 0; k < 3 * self->lag; k++) self->depths[k] = 0.0;
  if (envelope != Py_None) {
    self->envelope = PyMem_New(double, 4 * n);
    if (self->envelope == NULL) {
      PyErr_NoMemory();
      return -1;
    }
    if (doubles_into(envelope, self->envelope, 4 * n, "the watchdogs' envelope") < 0) return -1;
  }
  /* makers: (math.hypot, numpy.empty, PositionCommand) */
  PyObject *hypot_fn, *empty, *command_type;
  if (!PyArg_ParseTuple(makers, "OOO!", &hypot_fn, &empty, &PyType_Type, &command_type))
    return -1;
  self->n_obj = PyLong_FromSsize_t(n);
  if (self->n_obj == NULL) return -1;
#define KEEP(field, value) (Py_INCREF(value), self->field = (value))
  KEEP(law, pl);
  KEEP(check, check);
  KEEP(plane, plane);
  KEEP(search_failed, search_failed);
  KEEP(hypot, hypot_fn);
  KEEP(empty, empty);
  KEEP(command_type, command_type);
#undef KEEP
  self->force_limit = force_limit;
  self->tracking_limit = tracking_limit;
  self->approach = approach;
  self->descend = descend;
  self->draw = draw;
  self->home = home;
  self->dt = dt;
  self->has_t_first = has_t_first;
  self->t_first = t_first;
  self->z = self->force = self->rate = self->lead = self->h_prev = 0.0;
  self->has_h_prev = 0;
  self->head = 0;
  memset(self->sums, 0, sizeof(self->sums));
  self->coef[0] = self->coef[1] = self->coef[2] = 0.0;
  self->count = 0;
  self->has_origin = 0;
  self->dirty = 1;  /* (Watchdogs start counting: the first period is checked in Python) */
  self->i = self->row = self->next_i = 0;
  self->waited = self->settled_for = self->next_waited = self->next_settled = 0;
  self->logged = self->fresh = 0;
  self->force_f = 0.0;
  self->rows = rows;
  self->capacity = cap;
  self->n = n;
  return 0;
}

/* SurfaceEstimate.height */
static double plane_height(const MemberPeriod* self, double x, double y) {
  if (!self->has_origin) return 0.0;
  return self->coef[0] + self->coef[1] * (x - self->origin[0]) +
         self->coef[2] * (y - self->origin[1]);
}

/* SurfaceEstimate.add; -1 with an exception where the solve raised. */
static int plane_add(MemberPeriod* self, double x, double y, double z) {
  if (!self->has_origin) {
    self->origin[0] = x;
    self->origin[1] = y;
    self->has_origin = 1;
  }
  double u = x - self->origin[0], v = y - self->origin[1];
  double* s = self->sums;
  s[0] += 1.0;
  s[1] += u;
  s[2] += v;
  s[3] += u * u;
  s[4] += u * v;
  s[5] += v * v;
  s[6] += z;
  s[7] += z * u;
  s[8] += z * v;
  self->count += 1;
  if (self->count == 1 || self->count % self->refit_every == 0) {
    PyObject* sums = PyList_New(9);
    if (sums == NULL) return -1;
    for (int k = 0; k < 9; k++) {
      PyObject* item = PyFloat_FromDouble(s[k]);
      if (item == NULL) {
        Py_DECREF(sums);
        return -1;
      }
      PyList_SET_ITEM(sums, k, item);
    }
    PyObject* coef = PyObject_CallFunction(self->plane, "Nd", sums, self->prior);
    if (coef == NULL) return -1;
    int ok = PyArg_ParseTuple(coef, "ddd", self->coef, self->coef + 1, self->coef + 2);
    Py_DECREF(coef);
    if (!ok) return -1;
  }
  return 0;
}

/* ForceLoop._measure */
static void measure(MemberPeriod* self, double f, int touching) {
  if (!touching) {
    self->has_h_prev = 0;
    self->rate = self->lead = 0.0;
    return;
  }
  const double* oldest = self->depths + 3 * self->head;
  double h = oldest[0] - (f - self->f_star) * self->k_inv;
  if (self->has_h_prev) {
    self->rate += self->rate_smoothing * ((h - self->h_prev) * self->inv_dt - self->rate);
    double r = self->rate;
    r = r > RATE_DEAD_BAND ? r - RATE_DEAD_BAND : (r < -RATE_DEAD_BAND ? r + RATE_DEAD_BAND : 0.0);
    self->lead = self->lead_gain * r;
  }
  self->h_prev = h;
  self->has_h_prev = 1;
}

/* ForceLoop.shape: the low-passed force; -1 with the search's RunFault (or the solve's error). */
static int shape(MemberPeriod* self, double force, double time, int phase, int holding,
                 int pressing, double x_mm, double y_mm, double* out) {
  double f = self->force = self->force + self->smoothing * (force - self->force);
  if (pressing || (phase == self->descend && f > self->threshold)) {
    if (f > self->threshold) {
      double z = self->z + self->k_force * (self->f_star - f);
      self->z = -self->z_limit > z ? -self->z_limit : z;  /* Python's max: the first of ties */
    } else {
      self->z += self->search_step;
      if (self->z >= self->z_limit) {
        PyObject* fault = PyObject_CallFunction(self->search_failed, "d", time);
        if (fault != NULL) {
          PyErr_SetObject((PyObject*)Py_TYPE(fault), fault);
          Py_DECREF(fault);
        }
        return -1;
      }
    }
    if (self->sampling)
      measure(self, f, phase == self->draw && 0.5 * self->f_star < f && f < 1.5 * self->f_star);
    if ((phase == self->draw || holding) && fabs(f - self->f_star) < self->settle_tol) {
      double x = x_mm / 1000.0, y = y_mm / 1000.0;
      double before = plane_height(self, x, y);
      if (plane_add(self, x, y, before + self->z) < 0) return -1;
      self->z -= plane_height(self, x, y) - before;
    }
  } else if (self->sampling) {
    measure(self, f, 0);
  }
  *out = f;
  return 0;
}

/* ForceLoop.depth (no field, no prior: the lane's conditions) */
static double depth_at(MemberPeriod* self, double x_mm, double y_mm) {
  double d = self->z + plane_height(self, x_mm / 1000.0, y_mm / 1000.0);
  if (self->sampling) {
    double* slot = self->depths + 3 * self->head;  /* (the oldest goes: deque(maxlen=lag)) */
    slot[0] = d;
    slot[1] = x_mm;
    slot[2] = y_mm;
    self->head = (self->head + 1) % self->lag;
    d += self->lead;
  }
  return d;
}

/* A float64 buffer of n, or -1 (NotForLane where the object is there but not that). */
static int reading(PyObject* obj, Py_buffer* view, Py_ssize_t n, const char* name) {
  if (PyObject_GetBuffer(obj, view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) {
    PyErr_Clear();
    PyErr_Format(NotForLane, "the reading's %s is not a buffer", name);
    return -1;
  }
  if (view->len != n * (Py_ssize_t)sizeof(double) || view->format == NULL ||
      strcmp(view->format, "d") != 0) {
    PyBuffer_Release(view);
    PyErr_Format(NotForLane, "the reading's %s is not %zd float64", name, n);
    return -1;
  }
  return 0;
}

/* A float64 array of n copied from x (for the watchdogs in Python). */
static PyObject* array_of(MemberPeriod* self, const double* x) {
  PyObject* array = PyObject_CallOneArg(self->empty, self->n_obj);
  if (array == NULL) return NULL;
  Py_buffer b;
  if (PyObject_GetBuffer(array, &b, PyBUF_C_CONTIGUOUS | PyBUF_WRITABLE) < 0) {
    Py_DECREF(array);
    return NULL;
  }
  memcpy(b.buf, x, self->n * sizeof(double));
  PyBuffer_Release(&b);
  return array;
}

/* The watchdogs in Python (Watchdogs.check) with math.hypot's distance; -1 when one fired. */
static int python_check(MemberPeriod* self, const Reading* r, double dx, double dy,
                        int joint_move) {
  PyObject* error = joint_move ? PyFloat_FromDouble(0.0)
                               : PyObject_CallFunction(self->hypot, "dd", dx, dy);
  if (error == NULL) return -1;
  PyObject *q = r->q_o, *qd = r->qd_o, *torque = r->torque_o;
  int made = q == NULL;
  if (made) {
    q = array_of(self, r->q);
    qd = q ? array_of(self, r->qd) : NULL;
    torque = qd ? (r->torque ? array_of(self, r->torque) : Py_NewRef(Py_None)) : NULL;
    if (torque == NULL) {
      Py_XDECREF(q);
      Py_XDECREF(qd);
      Py_DECREF(error);
      return -1;
    }
  }
  PyObject* result = PyObject_CallFunction(self->check, "dOOOdN", r->time, q, qd, torque,
                                           self->force_f, error);
  if (made) {
    Py_DECREF(q);
    Py_DECREF(qd);
    Py_DECREF(torque);
  }
  if (result == NULL) return -1;
  Py_DECREF(result);
  return 0;
}

/* The period's steps 2-4 on reading r: the goal q* and tau_ff into goal and feedforward (n
 * each), the commanded plan row into *c_out, the log row written, the advance after the step
 * pending. 0, or -1 with the fault (a watchdog's, the search's) or an error set. */
int period_steps(MemberPeriod* self, const Reading* r, double* goal, double* feedforward,
                 Py_ssize_t* c_out) {
  const Py_ssize_t n = self->n, i = self->i, rows = self->rows, row = self->row;
  const int64_t* phases = self->v[V_PHASE].buf;
  const double *page_x = self->v[V_PX].buf, *page_y = self->v[V_PY].buf;
  Py_ssize_t* commanded = self->v[V_COMMANDED].buf;
  const double time = r->time, *q = r->q, *tip = r->tip, *torque = r->torque;
  if (!self->has_t_first) {
    self->t_first = time;
    self->has_t_first = 1;
  }
  int phase = (int)phases[i];
  int holding = ((const unsigned char*)self->v[V_HOLD].buf)[i] != 0;
  commanded[row] = i;
  double lag = (self->t_first + row * self->dt - time) / self->dt;
  double whole = rint(lag);  /* (Python's round: halves to even) */
  if (fabs(lag - whole) < 1e-6) lag = whole;
  Py_ssize_t seen;
  double blend;
  if (lag > 0.0) {
    double back = trunc(lag), frac = lag - back;
    Py_ssize_t at = row - (Py_ssize_t)back - (frac > 0);
    seen = commanded[at > 0 ? at : 0];
    blend = frac > 0 ? 1.0 - frac : 0.0;
  } else {
    seen = i;
    blend = 0.0;
  }
  ((double*)self->v[V_BLEND].buf)[row] = blend;
  int pressing = phase == self->draw || (holding && self->waited > 0);
  if (self->senses_force) {
    double f;
    if (shape(self, r->force, time, phase, holding, pressing, page_x[i], page_y[i], &f) < 0)
      return -1;
    self->force_f = f;
  }
  Py_ssize_t c = i + self->lookahead_rows < rows - 1 ? i + self->lookahead_rows : rows - 1;
  double depth = depth_at(self, page_x[c], page_y[c]);
  const double* q_ref = (const double*)self->v[V_QREF].buf + c * n;
  const double* normal = (const double*)self->v[V_NORMAL].buf + c * n;
  double* q_row = self->scratch;
  for (Py_ssize_t k = 0; k < n; k++) q_row[k] = q_ref[k] + depth * normal[k];
  if (self->lookahead && c + 1 < rows) {
    const double* step = (const double*)self->v[V_STEP].buf + c * n;
    for (Py_ssize_t k = 0; k < n; k++) goal[k] = q_row[k] + step[k];
  } else {
    memcpy(goal, q_row, n * sizeof(double));
  }
  position_feedforward(self->law, feedforward, q_row, q, c, seen, depth, blend, pressing);
  *c_out = c;

  /* the log row */
  ((double*)self->v[V_LTIME].buf)[row] = time;
  memcpy((double*)self->v[V_LQ].buf + row * n, q, n * sizeof(double));
  memcpy((double*)self->v[V_LQD].buf + row * n, r->qd, n * sizeof(double));
  double* log_torque = (double*)self->v[V_LTORQUE].buf + row * n;
  for (Py_ssize_t k = 0; k < n; k++) log_torque[k] = torque ? torque[k] : NAN;
  memcpy((double*)self->v[V_LTIP].buf + row * 3, tip, 3 * sizeof(double));
  ((double*)self->v[V_LFORCE].buf)[row] = self->senses_force ? r->force : NAN;
  ((Py_ssize_t*)self->v[V_REFROW].buf)[row] = seen;
  self->row = row + 1;
  self->logged = 1;

  /* the pen's distance from its reference, and the watchdogs */
  int joint_move = phase == self->approach || phase == self->home;
  double dx = 0.0, dy = 0.0, error = 0.0;
  if (!joint_move) {
    if (blend != 0.0) {
      Py_ssize_t after = seen + 1 < rows - 1 ? seen + 1 : rows - 1;
      dx = tip[0] - page_x[seen] - blend * (page_x[after] - page_x[seen]);
      dy = tip[1] - page_y[seen] - blend * (page_y[after] - page_y[seen]);
    } else {
      dx = tip[0] - page_x[seen];
      dy = tip[1] - page_y[seen];
    }
    error = hypot(dx, dy);
  }
  int clean = self->envelope != NULL && torque != NULL && !(self->force_f > self->force_limit) &&
              !(error > self->tracking_limit * (1.0 - 1e-9));
  for (Py_ssize_t k = 0; clean && k < n; k++) {
    const double* e = self->envelope + 4 * k;
    clean = fabs(q[k] - e[0]) < e[1] && fabs(r->qd[k]) < e[2] && fabs(torque[k]) < e[3];
  }
  if ((!clean || self->dirty) && python_check(self, r, dx, dy, joint_move) < 0) return -1;
  self->dirty = !clean;

  /* the advance after the step: hold the end of a descent until the force has settled */
  self->next_i = i;
  self->next_waited = self->waited;
  self->next_settled = self->settled_for;
  if (holding && self->waited < self->timeout_ticks) {
    self->next_waited = self->waited + 1;
    self->next_settled = fabs(self->force_f - self->f_star) < self->settle_tol
                             ? self->settled_for + 1 : 0;
    if (self->next_settled < self->settle_ticks) return 0;
  }
  self->next_waited = self->next_settled = 0;
  self->next_i = i + 1;
  return 0;
}

int period_ready(MemberPeriod* self) {
  if (self->n == 0) {
    PyErr_SetString(PyExc_RuntimeError, "_law.MemberPeriod: not initialised");
    return -1;
  }
  if (self->i < 0 || self->i >= self->rows || self->row >= self->capacity) {
    PyErr_Format(PyExc_IndexError, "_law.MemberPeriod: plan row %zd of %zd, log row %zd of %zd",
                 self->i, self->rows, self->row, self->capacity);
    return -1;
  }
  return 0;
}

/* period(state) -> PositionCommand (the file's docstring). */
static PyObject* member_period(MemberPeriod* self, PyObject* state) {
  if (period_ready(self) < 0) return NULL;
  const Py_ssize_t n = self->n;
  Reading r = {0};
  PyObject *time_o = NULL, *force_o = NULL, *tip_o = NULL, *result = NULL;
  PyObject *goal = NULL, *feedforward = NULL;
  Py_buffer qb, qdb, torqueb, tipb, gb, fb;
  int have_q = 0, have_qd = 0, have_torque = 0, have_tip = 0, have_g = 0, have_f = 0;
  Py_ssize_t c;
  /* the reading, checked before anything changes */
  time_o = PyObject_GetAttr(state, s_time);
  r.q_o = PyObject_GetAttr(state, s_q);
  r.qd_o = PyObject_GetAttr(state, s_qd);
  r.torque_o = PyObject_GetAttr(state, s_torque);
  tip_o = PyObject_GetAttr(state, s_tip_mm);
  if (!time_o || !r.q_o || !r.qd_o || !r.torque_o || !tip_o) goto done;
  r.time = PyFloat_AsDouble(time_o);
  if ((r.time == -1.0 && PyErr_Occurred()) || !isfinite(r.time)) {
    PyErr_Clear();  /* (Python's steps raise on a time that is not finite, as round() does) */
    PyErr_SetString(NotForLane, "the reading's time is not a finite number");
    goto done;
  }
  r.force = NAN;
  if (self->senses_force) {
    force_o = PyObject_GetAttr(state, s_force);
    if (force_o == NULL) goto done;
    if (!PyFloat_Check(force_o)) {
      PyErr_SetString(NotForLane, "the reading's force is not a float");
      goto done;
    }
    r.force = PyFloat_AS_DOUBLE(force_o);
  }
  if (reading(r.q_o, &qb, n, "q") < 0) goto done;
  have_q = 1;
  if (reading(r.qd_o, &qdb, n, "qd") < 0) goto done;
  have_qd = 1;
  if (r.torque_o != Py_None) {
    if (reading(r.torque_o, &torqueb, n, "torque") < 0) goto done;
    have_torque = 1;
  }
  if (reading(tip_o, &tipb, 3, "tip_mm") < 0) goto done;
  have_tip = 1;
  r.q = qb.buf;
  r.qd = qdb.buf;
  r.torque = have_torque ? torqueb.buf : NULL;
  r.tip = tipb.buf;
  goal = PyObject_CallOneArg(self->empty, self->n_obj);
  feedforward = goal ? PyObject_CallOneArg(self->empty, self->n_obj) : NULL;
  if (feedforward == NULL) goto done;
  if (PyObject_GetBuffer(goal, &gb, PyBUF_C_CONTIGUOUS | PyBUF_WRITABLE) < 0) goto done;
  have_g = 1;
  if (PyObject_GetBuffer(feedforward, &fb, PyBUF_C_CONTIGUOUS | PyBUF_WRITABLE) < 0) goto done;
  have_f = 1;  /* (fresh stays 0: the reading is the caller's, who knows it is not commanded) */
  if (period_steps(self, &r, gb.buf, fb.buf, &c) < 0) goto done;
  PyObject* qd_c = PySequence_GetItem(self->qd_ref, c);
  PyObject* qdd_c = qd_c ? PySequence_GetItem(self->qdd_ref, c) : NULL;
  if (qdd_c == NULL) {
    Py_XDECREF(qd_c);
    goto done;
  }
  PyObject* fields = PyTuple_Pack(4, goal, qd_c, qdd_c, feedforward);
  Py_DECREF(qd_c);
  Py_DECREF(qdd_c);
  if (fields == NULL) goto done;
  PyObject* targs = PyTuple_Pack(1, fields);
  Py_DECREF(fields);
  if (targs == NULL) goto done;
  /* (a NamedTuple's __new__ is tuple.__new__(cls, fields)) */
  result = PyTuple_Type.tp_new((PyTypeObject*)self->command_type, targs, NULL);
  Py_DECREF(targs);
done:
  if (have_q) PyBuffer_Release(&qb);
  if (have_qd) PyBuffer_Release(&qdb);
  if (have_torque) PyBuffer_Release(&torqueb);
  if (have_tip) PyBuffer_Release(&tipb);
  if (have_g) PyBuffer_Release(&gb);
  if (have_f) PyBuffer_Release(&fb);
  Py_XDECREF(goal);
  Py_XDECREF(feedforward);
  Py_XDECREF(time_o);
  Py_XDECREF(r.q_o);
  Py_XDECREF(r.qd_o);
  Py_XDECREF(r.torque_o);
  Py_XDECREF(tip_o);
  Py_XDECREF(force_o);
  return result;
}

/* The member on to the plan row after its period's step: the hold's counters with it, nothing
 * logged or read for the next period yet. */
void period_advance(MemberPeriod* self) {
  self->i = self->next_i;
  self->waited = self->next_waited;
  self->settled_for = self->next_settled;
  self->logged = self->fresh = 0;
}

/* run(port, periods) -> periods run: up to ``periods`` whole periods through the plant's port
 * (inkarm/core/_plant.h; a PyCapsule): read, steps 2-4, command, the plant's step, and the
 * advance of each but the last (advance() takes it, as after the executor's own yield); stops
 * early at the plan's end. A fault (a watchdog's, the search's, the plant's) or Ctrl-C (checked
 * before each period) raises with ``i``, ``row``, ``logged`` and ``fresh`` as the executor's own
 * would be at that point. */
static PyObject* member_run(MemberPeriod* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 2) {
    PyErr_SetString(PyExc_TypeError, "run(port, periods)");
    return NULL;
  }
  if (!PyCapsule_IsValid(args[0], INKARM_PLANT_CAPSULE)) {
    PyErr_SetString(PyExc_TypeError, "_law.MemberPeriod.run: port must be a plant's port (a "
                    "PyCapsule named " INKARM_PLANT_CAPSULE ")");
    return NULL;
  }
  inkarm_plant* plant = PyCapsule_GetPointer(args[0], INKARM_PLANT_CAPSULE);
  long periods = PyLong_AsLong(args[1]);
  if (plant == NULL || (periods == -1 && PyErr_Occurred())) return NULL;
  if (plant->abi != INKARM_PLANT_ABI || plant->n != self->n) {
    PyErr_Format(PyExc_ValueError, "_law.MemberPeriod.run: a port of ABI %d for %d joints; "
                 "this is ABI %d for %zd", plant->abi, plant->n, INKARM_PLANT_ABI, self->n);
    return NULL;
  }
  const Py_ssize_t n = self->n;
  double* q = self->scratch + n;  /* q, qd, torque (n each), tip (3), goal, tau_ff (n each) */
  Reading r = {0};
  r.q = q;
  r.qd = q + n;
  r.torque = q + 2 * n;
  r.tip = q + 3 * n;
  double* goal = q + 3 * n + 3;
  double* feedforward = goal + n;
  long done = 0;
  while (done < periods) {
    if (done > 0) period_advance(self); /* (the period before's; the last one's is advance()'s) */
    if (self->i >= self->rows) break;
    if (period_ready(self) < 0 || PyErr_CheckSignals() < 0) return NULL;
    if (plant->read(plant->self, &r.time, q, q + n, q + 2 * n, q + 3 * n, &r.force) < 0)
      return NULL;
    self->fresh = 1;
    Py_ssize_t c;
    if (period_steps(self, &r, goal, feedforward, &c) < 0) return NULL;
    const double* qd_c = (const double*)self->v[V_QD].buf + c * n;
    if (plant->command(plant->self, goal, qd_c, feedforward) < 0) return NULL;
    self->fresh = 0;
    if (plant->step(plant->self) < 0) return NULL;
    done++;
  }
  return PyLong_FromLong(done);
}

/* advance() -> the plan row after this period's step (the executor calls it after the yield) */
static PyObject* member_advance(MemberPeriod* self, PyObject* unused) {
  period_advance(self);
  return PyLong_FromSsize_t(self->i);
}

/* export() -> the state the Python period goes on from (NotForLane's hand-over). */
static PyObject* member_export(MemberPeriod* self, PyObject* unused) {
  PyObject* depths = PyList_New(self->lag);
  if (depths == NULL) return NULL;
  for (int k = 0; k < self->lag; k++) {
    const double* d = self->depths + 3 * ((self->head + k) % self->lag);
    PyObject* item = Py_BuildValue("(ddd)", d[0], d[1], d[2]);
    if (item == NULL) {
      Py_DECREF(depths);
      return NULL;
    }
    PyList_SET_ITEM(depths, k, item);
  }
  PyObject* sums = Py_BuildValue("[ddddddddd]", self->sums[0], self->sums[1], self->sums[2],
                                 self->sums[3], self->sums[4], self->sums[5], self->sums[6],
                                 self->sums[7], self->sums[8]);
  PyObject* h_prev = self->has_h_prev ? PyFloat_FromDouble(self->h_prev) : Py_NewRef(Py_None);
  PyObject* origin = self->has_origin ? Py_BuildValue("(dd)", self->origin[0], self->origin[1])
                                      : Py_NewRef(Py_None);
  PyObject* t_first = self->has_t_first ? PyFloat_FromDouble(self->t_first) : Py_NewRef(Py_None);
  if (sums == NULL || h_prev == NULL || origin == NULL || t_first == NULL) {
    Py_DECREF(depths);
    Py_XDECREF(sums);
    Py_XDECREF(h_prev);
    Py_XDECREF(origin);
    Py_XDECREF(t_first);
    return NULL;
  }
  return Py_BuildValue(
      "{s:d,s:d,s:d,s:d,s:N,s:N,s:N,s:l,s:(ddd),s:N,s:n,s:n,s:i,s:i,s:d,s:N}", "z", self->z,
      "force", self->force, "rate", self->rate, "lead", self->lead, "h_prev", h_prev, "depths",
      depths, "sums", sums, "count", self->count, "coef", self->coef[0], self->coef[1],
      self->coef[2], "origin", origin, "i", self->i, "row", self->row, "waited", self->waited,
      "settled_for", self->settled_for, "force_f", self->force_f, "t_first", t_first);
}

static PyObject* get_i(MemberPeriod* self, void* unused) { return PyLong_FromSsize_t(self->i); }
static PyObject* get_row(MemberPeriod* self, void* unused) {
  return PyLong_FromSsize_t(self->row);
}
static PyObject* get_logged(MemberPeriod* self, void* unused) {
  return PyBool_FromLong(self->logged);
}
static PyObject* get_fresh(MemberPeriod* self, void* unused) {
  return PyBool_FromLong(self->fresh);
}

static PyGetSetDef member_getset[] = {
    {"i", (getter)get_i, NULL, "the plan row of this period", NULL},
    {"row", (getter)get_row, NULL, "the next log row", NULL},
    {"logged", (getter)get_logged, NULL, "whether this period's row is in the log", NULL},
    {"fresh", (getter)get_fresh, NULL, "whether this period's reading, read by run() or "
     "periods(), is not commanded yet", NULL},
    {NULL, NULL, NULL, NULL, NULL}};

static PyMethodDef member_methods[] = {
    {"period", (PyCFunction)member_period, METH_O,
     "period(state) -> PositionCommand: one period's steps 2-4 of the executor"},
    {"run", (PyCFunction)(void (*)(void))member_run, METH_FASTCALL,
     "run(port, periods) -> periods run whole through the plant's port"},
    {"advance", (PyCFunction)member_advance, METH_NOARGS,
     "advance() -> the plan row of the next period (after this one's step)"},
    {"export", (PyCFunction)member_export, METH_NOARGS,
     "export() -> dict: the force loop's, the plane's and the member's state"},
    {NULL, NULL, 0, NULL}};

PyTypeObject MemberPeriodType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "inkarm.control._law.MemberPeriod",
    .tp_basicsize = sizeof(MemberPeriod),
    .tp_dealloc = (destructor)member_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "MemberPeriod(...): built by inkarm.control.member_lane",
    .tp_methods = member_methods,
    .tp_getset = member_getset,
    .tp_init = (initproc)member_init,
    .tp_new = PyType_GenericNew,
};

int add_member_period(PyObject* module) {
  if (PyType_Ready(&MemberPeriodType) < 0) return -1;
  s_time = PyUnicode_InternFromString("time");
  s_q = PyUnicode_InternFromString("q");
  s_qd = PyUnicode_InternFromString("qd");
  s_torque = PyUnicode_InternFromString("torque");
  s_force = PyUnicode_InternFromString("force");
  s_tip_mm = PyUnicode_InternFromString("tip_mm");
  NotForLane = PyErr_NewExceptionWithDoc(
      "inkarm.control._law.NotForLane",
      "A reading the compiled member period cannot take: go on in Python.", PyExc_TypeError,
      NULL);
  if (!s_time || !s_q || !s_qd || !s_torque || !s_force || !s_tip_mm || !NotForLane) return -1;
  if (add_batch_periods(module) < 0) return -1;
  Py_INCREF(&MemberPeriodType);
  if (PyModule_AddObject(module, "MemberPeriod", (PyObject*)&MemberPeriodType) < 0) return -1;
  Py_INCREF(NotForLane);
  return PyModule_AddObject(module, "NotForLane", NotForLane);
}
