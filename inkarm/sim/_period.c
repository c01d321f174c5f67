/* One control period of the simulated plant in one call (issue 22 part 2).
 *
 * What MujocoPlant.step does per physics step on its default path (drives as affine MuJoCo
 * actuators, ideal senses, no stiction, no relief), without returning to Python:
 *
 *     ctrl[arm] = u;  u = u + du;  since = since + h          (the set point ramp)
 *     mj_step2                                                  (forces, integration)
 *     f = sum_i mj_contactForce(i)[0] over the tip's contacts   (the pen's normal force [N])
 *     (x, y) = p A - o, written out as the plant's _tip_page    (tip in page [mm], at t - h)
 *     mj_step1                                                  (positions, contacts at t)
 *
 * and after the period the cheap divergence test (|qd|^2 against the threshold, the count of
 * MuJoCo's bad-state warnings), conservatively: a period it flags goes to the plant's exact test.
 * Before it, a new set point of the drives (JointDrive.set_point then affine_control, in the
 * order of their numpy operations), when the period was given the drives' gains:
 *
 *     I = clip(I + K_i since (q*_old + qd*_old since - q_link), -limit, limit)   (since > 0)
 *     u = K_p q* + (K_d qd* + tau_ff + I),   du = (K_p h) qd*
 * Every sum runs in the Python path's order; built with -ffp-contract=off (no fused multiply-add)
 * so that both paths give the same bits.
 *
 * MuJoCo's functions are not linked: they are looked up in the libmujoco that the `mujoco`
 * package has already loaded (dlopen with RTLD_NOLOAD, then dlsym), so the extension uses exactly
 * the library the Python bindings use, wherever pip put it. bind() refuses a library whose
 * mj_version() differs from the headers this file was built with (the structs' layout).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <dlfcn.h>
#include <setjmp.h>
#include <string.h>
#include <mujoco/mujoco.h>

#include "../core/_plant.h"
#include "_drive.h"

#ifndef INKARM_MUJOCO_VERSION
#define INKARM_MUJOCO_VERSION "unknown"
#endif
/* What this file offers, as inkarm.sim.compiled.API expects it (2: Period.command, the gains;
 * 3: the plant's port, enter/leave) */
#define INKARM_PERIOD_API 3

typedef void (*step_fn)(const mjModel*, mjData*);
typedef void (*force_fn)(const mjModel*, const mjData*, int, mjtNum*);
typedef int (*version_fn)(void);

static step_fn step1 = NULL, step2 = NULL;
static force_fn contact_force = NULL;

/* MuJoCo's fatal errors (mju_error) inside a period: the bindings' handler throws a C++
 * exception, which cannot cross this C code; during a period the handler is ours, which jumps
 * back to the period and raises the bindings' own mujoco.FatalError, as the Python path would. */
typedef void (*error_fn)(const char*);
static error_fn* user_error = NULL;
static PyObject* fatal_error = NULL;
/* (thread-local for safety; a period holds the GIL throughout, and mju_user_error itself is one
 * process-wide handler, saved and restored around each period) */
static _Thread_local jmp_buf* error_jump = NULL;
static _Thread_local char error_message[512];

static void period_error(const char* message) {
  strncpy(error_message, message, sizeof(error_message) - 1);
  error_message[sizeof(error_message) - 1] = '\0';
  longjmp(*error_jump, 1);
}

static PyObject* bind(PyObject* self, PyObject* args) {
  const char* path;
  PyObject* fatal;
  if (!PyArg_ParseTuple(args, "sO", &path, &fatal)) return NULL;
  void* lib = dlopen(path, RTLD_NOW | RTLD_NOLOAD);
  if (lib == NULL) {
    PyErr_Format(PyExc_ImportError, "_period: %s is not loaded (%s)", path, dlerror());
    return NULL;
  }
  version_fn version = (version_fn)dlsym(lib, "mj_version");
  step_fn s1 = (step_fn)dlsym(lib, "mj_step1"), s2 = (step_fn)dlsym(lib, "mj_step2");
  force_fn cf = (force_fn)dlsym(lib, "mj_contactForce");
  error_fn* handler = (error_fn*)dlsym(lib, "mju_user_error");
  dlclose(lib);  /* (drops our reference only: the bindings keep the library loaded) */
  if (!version || !s1 || !s2 || !cf || !handler) {
    PyErr_Format(PyExc_ImportError, "_period: %s lacks mj_version/mj_step1/mj_step2/"
                 "mj_contactForce/mju_user_error", path);
    return NULL;
  }
  if (version() != mjVERSION_HEADER) {
    PyErr_Format(PyExc_ImportError, "_period: built with MuJoCo headers %d, library is %d",
                 mjVERSION_HEADER, version());
    return NULL;
  }
  step1 = s1; step2 = s2; contact_force = cf; user_error = handler;
  Py_INCREF(fatal);
  Py_XSETREF(fatal_error, fatal);
  Py_RETURN_NONE;
}

typedef struct {
  PyObject_HEAD
  PyObject* owners;        /* the MjModel and MjData: kept alive while the period points in */
  const mjModel* m;
  mjData* d;
  int* arm;                /* the arm's actuators, in the plant's joint order */
  int narm;
  int tip_site;
  int tip_geom;            /* -1: every contact is the tip's (the plant's _only_tip_touches) */
  double page[12];         /* a00 a01 a02 a10 a11 a12 a20 a21 a22 o0 o1 o2 (_page_map) */
  int substeps;
  double* out;             /* per physics step: force, x, y, t */
  double* gains;           /* the drives' K_p, K_d, K_i, K_p h, integral limit (narm each) */
  double max_speed_sq;
  int warning_total;
  /* The port (inkarm/core/_plant.h) between enter() and leave(): the plant's drives and pen
   * state, handed over from Python and back. */
  inkarm_plant port;
  int entered;
  Py_buffer u_view, du_view, integral_view;  /* the plant's u, du and the drives' integral */
  int* qpos_adr;
  int* dof_adr;
  double* goal;            /* 3 narm: the drives' set point q*, qd*, tau_ff (held) */
  double* next;            /* 3 narm: the command for the coming period; narm: scratch */
  int have_goal, have_qd_goal, pending;
  double since, pen_force, force_bias;
  long steps;              /* physics steps since enter() */
  double* rows;            /* (force, x, y, t) per physics step since enter(), for the canvas */
  Py_ssize_t nrows, cap_rows;
  PyObject* diverged;      /* the plant's exact divergence test (raises SimulationError) */
} Period;

static void port_release(Period* self) {
  if (self->entered) {
    PyBuffer_Release(&self->u_view);
    PyBuffer_Release(&self->du_view);
    PyBuffer_Release(&self->integral_view);
    self->entered = 0;
  }
  Py_CLEAR(self->diverged);
}

static void period_dealloc(Period* self) {
  port_release(self);
  PyMem_Free(self->qpos_adr);
  PyMem_Free(self->dof_adr);
  PyMem_Free(self->goal);
  PyMem_Free(self->next);
  PyMem_Free(self->rows);
  Py_XDECREF(self->owners);
  PyMem_Free(self->arm);
  PyMem_Free(self->out);
  PyMem_Free(self->gains);
  Py_TYPE(self)->tp_free((PyObject*)self);
}

/* n doubles of the sequence seq into a new array (NULL and an exception on failure). */
static double* doubles_of(PyObject* seq, Py_ssize_t n, const char* what) {
  PyObject* fast = PySequence_Fast(seq, what);
  if (fast == NULL) return NULL;
  if (PySequence_Fast_GET_SIZE(fast) != n) {
    Py_DECREF(fast);
    PyErr_Format(PyExc_ValueError, "%s: expected %zd numbers", what, n);
    return NULL;
  }
  double* out = PyMem_New(double, n);
  if (out == NULL) {
    Py_DECREF(fast);
    PyErr_NoMemory();
    return NULL;
  }
  for (Py_ssize_t i = 0; i < n; i++)
    out[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(fast, i));
  Py_DECREF(fast);
  if (PyErr_Occurred()) {
    PyMem_Free(out);
    return NULL;
  }
  return out;
}

static int period_init(Period* self, PyObject* args, PyObject* kwds) {
  PyObject *owners, *arm, *page, *gains = Py_None;
  unsigned long long m_addr, d_addr;
  if (!PyArg_ParseTuple(args, "OKKOiiOidi|O", &owners, &m_addr, &d_addr, &arm, &self->tip_site,
                        &self->tip_geom, &page, &self->substeps, &self->max_speed_sq,
                        &self->warning_total, &gains))
    return -1;
  self->m = NULL;  /* (unusable until this initialisation succeeds: a failed re-init included) */
  if (step1 == NULL) {
    PyErr_SetString(PyExc_RuntimeError, "_period: bind() the MuJoCo library first");
    return -1;
  }
  PyObject* arm_seq = PySequence_Fast(arm, "_period: arm actuators must be a sequence");
  if (arm_seq == NULL) return -1;
  Py_ssize_t n = PySequence_Fast_GET_SIZE(arm_seq);
  if (n < 1 || self->substeps < 1) {
    Py_DECREF(arm_seq);
    PyErr_Format(PyExc_ValueError, "_period: %zd actuators, %d substeps (>= 1 each)", n,
                 self->substeps);
    return -1;
  }
  PyMem_Free(self->arm);
  PyMem_Free(self->out);
  self->arm = PyMem_New(int, n);
  self->out = PyMem_New(double, 4 * (size_t)self->substeps);
  if (self->arm == NULL || self->out == NULL) {
    Py_DECREF(arm_seq);
    PyErr_NoMemory();
    return -1;
  }
  const mjModel* m = (const mjModel*)(uintptr_t)m_addr;
  for (Py_ssize_t i = 0; i < n; i++) {
    long a = PyLong_AsLong(PySequence_Fast_GET_ITEM(arm_seq, i));
    if ((a == -1 && PyErr_Occurred()) || a < 0 || a >= m->nu) {
      Py_DECREF(arm_seq);
      if (!PyErr_Occurred())
        PyErr_Format(PyExc_ValueError, "_period: actuator %ld not in the model's 0..%d", a,
                     m->nu - 1);
      return -1;
    }
    self->arm[i] = (int)a;
  }
  Py_DECREF(arm_seq);
  self->narm = (int)n;
  if (self->tip_site < 0 || self->tip_site >= m->nsite || self->tip_geom < -1 ||
      self->tip_geom >= m->ngeom) {
    PyErr_Format(PyExc_ValueError, "_period: tip site %d / geom %d not in the model's %d sites"
                 " / %d geoms", self->tip_site, self->tip_geom, m->nsite, m->ngeom);
    return -1;
  }
  PyObject* page_seq = PySequence_Fast(page, "_period: the page map must be a sequence");
  if (page_seq == NULL) return -1;
  if (PySequence_Fast_GET_SIZE(page_seq) != 12) {
    Py_DECREF(page_seq);
    PyErr_SetString(PyExc_ValueError, "_period: the page map needs 12 numbers");
    return -1;
  }
  for (int i = 0; i < 12; i++)
    self->page[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(page_seq, i));
  Py_DECREF(page_seq);
  if (PyErr_Occurred()) return -1;
  PyMem_Free(self->gains);
  self->gains = NULL;
  if (gains != Py_None) {
    self->gains = doubles_of(gains, 5 * n, "_period: the drives' gains (K_p, K_d, K_i, K_p h, "
                             "limit per actuator)");
    if (self->gains == NULL) return -1;
  }
  self->m = m;
  self->d = (mjData*)(uintptr_t)d_addr;
  Py_INCREF(owners);
  Py_XSETREF(self->owners, owners);
  return 0;
}

/* The period's physics steps (the file's docstring): u [N m] advanced in place by du each step,
 * *since by h; self->out gets (force, x, y, t) per step, *suspect the cheap divergence test's
 * verdict. 0, or -1 with mujoco.FatalError set. */
static int physics(Period* self, double* u, const double* du, double* since, int* suspect) {
  const mjModel* m = self->m;
  mjData* d = self->d;
  const double h = m->opt.timestep;
  const double* a = self->page;
  const mjtNum* tip = d->site_xpos + 3 * self->tip_site;
  double* out = self->out;
  mjtNum contact[6];
  jmp_buf jump;
  error_fn saved = *user_error;
  if (setjmp(jump)) {
    *user_error = saved;
    PyErr_SetString(fatal_error, error_message);
    return -1;
  }
  error_jump = &jump;
  *user_error = period_error;
  for (int s = 0; s < self->substeps; s++) {
    for (int i = 0; i < self->narm; i++) {
      d->ctrl[self->arm[i]] = u[i];
      u[i] = u[i] + du[i];
    }
    *since = *since + h;
    step2(m, d);
    double force = 0.0;
    for (int i = 0; i < d->ncon; i++) {
      if (self->tip_geom >= 0 && d->contact[i].geom[0] != self->tip_geom &&
          d->contact[i].geom[1] != self->tip_geom)
        continue;
      contact_force(m, d, i, contact);
      force += contact[0];
    }
    double x = tip[0], y = tip[1], z = tip[2];
    out[4 * s] = force;
    out[4 * s + 1] = a[0] * x + a[3] * y + a[6] * z - a[9];
    out[4 * s + 2] = a[1] * x + a[4] * y + a[7] * z - a[10];
    out[4 * s + 3] = d->time - h;
    step1(m, d);
  }
  *user_error = saved;
  double speed_sq = 0.0;
  for (int i = 0; i < m->nv; i++) speed_sq += d->qvel[i] * d->qvel[i];
  int warnings = d->warning[mjWARN_BADQPOS].number + d->warning[mjWARN_BADQVEL].number +
                 d->warning[mjWARN_BADQACC].number;
  /* (a margin over the summation order of NumPy's dot: flagged periods get the exact test) */
  *suspect = !(speed_sq <= self->max_speed_sq * (1.0 - 1e-9)) || warnings != self->warning_total;
  return 0;
}

/* step(u, du, since) -> (since, suspect, ((force, x, y, t), ...) one per physics step).
 * u [N m] is advanced in place by du each physics step (the plant's own array). */
static PyObject* period_step(Period* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 3) {
    PyErr_SetString(PyExc_TypeError, "step(u, du, since)");
    return NULL;
  }
  if (self->m == NULL || self->entered) {
    PyErr_SetString(PyExc_RuntimeError, self->m == NULL ? "_period: the period was not "
                    "initialised" : "_period: step() between enter() and leave()");
    return NULL;
  }
  Py_buffer ub, dub;
  if (PyObject_GetBuffer(args[0], &ub, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0)
    return NULL;
  if (PyObject_GetBuffer(args[1], &dub, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) {
    PyBuffer_Release(&ub);
    return NULL;
  }
  double since = PyFloat_AsDouble(args[2]);
  Py_ssize_t want = (Py_ssize_t)self->narm * (Py_ssize_t)sizeof(double);
  if (ub.len != want || dub.len != want || ub.format == NULL || strcmp(ub.format, "d") != 0 ||
      dub.format == NULL || strcmp(dub.format, "d") != 0 || (since == -1.0 && PyErr_Occurred())) {
    PyBuffer_Release(&ub);
    PyBuffer_Release(&dub);
    if (!PyErr_Occurred())
      PyErr_Format(PyExc_ValueError, "_period: u and du must be %d float64", self->narm);
    return NULL;
  }
  int suspect = 0;
  int status = physics(self, (double*)ub.buf, (const double*)dub.buf, &since, &suspect);
  PyBuffer_Release(&ub);
  PyBuffer_Release(&dub);
  if (status < 0) return NULL;
  PyObject* steps = PyTuple_New(self->substeps);
  if (steps == NULL) return NULL;
  for (int s = 0; s < self->substeps; s++) {
    const double* o = self->out + 4 * s;
    PyObject* row = Py_BuildValue("(dddd)", o[0], o[1], o[2], o[3]);
    if (row == NULL) {
      Py_DECREF(steps);
      return NULL;
    }
    PyTuple_SET_ITEM(steps, s, row);
  }
  return Py_BuildValue("(dON)", since, suspect ? Py_True : Py_False, steps);
}

/* The float64 buffer of args[i], narm long (writable if asked), or NULL for None (where
 * allowed); views[*held] is kept for release_all. Returns 0, or -1 with an exception set. */
static int doubles_arg(Period* self, PyObject* arg, int writable, int optional, double** out,
                       Py_buffer* views, int* held, const char* name) {
  *out = NULL;
  if (arg == Py_None && optional) return 0;
  Py_buffer* view = views + *held;
  int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
  if (PyObject_GetBuffer(arg, view, flags) < 0) return -1;
  (*held)++;
  if (view->len != (Py_ssize_t)self->narm * (Py_ssize_t)sizeof(double) || view->format == NULL ||
      strcmp(view->format, "d") != 0) {
    PyErr_Format(PyExc_ValueError, "_period.command: %s must be %d float64", name, self->narm);
    return -1;
  }
  *out = (double*)view->buf;
  return 0;
}

static void release_all(Py_buffer* views, int held) {
  for (int i = 0; i < held; i++) PyBuffer_Release(views + i);
}

/* The drives' new set point (JointDrive.set_point then affine_control, the file's docstring):
 * the integral in place from the old set point (q_old NULL: none yet; qd_old, qd, tau_ff NULL:
 * zeros; q_link NULL: no integration), u and du written. */
static void set_point(Period* self, double* u, double* du, double* integral, const double* q_old,
                      const double* qd_old, const double* q, const double* qd,
                      const double* tau_ff, const double* q_link, double since) {
  const int n = self->narm;
  const double* g = self->gains;
  const double *kp = g + DRIVE_KP * n, *kd = g + DRIVE_KD * n, *ki = g + DRIVE_KI * n;
  const double *kp_h = g + DRIVE_KP_H * n, *limit = g + DRIVE_LIMIT * n;
  if (q_old != NULL && q_link != NULL && since > 0.0)
    for (int i = 0; i < n; i++)
      integral[i] = drive_integral(integral[i], q_old[i], qd_old ? qd_old[i] : 0.0, q_link[i],
                                   ki[i], since, limit[i]);
  for (int i = 0; i < n; i++)
    drive_affine(kp[i], kd[i], kp_h[i], q[i], qd ? qd[i] : 0.0, tau_ff ? tau_ff[i] : 0.0,
                 integral[i], u + i, du + i);
}

/* command(u, du, integral, q_old, qd_old, q, qd, tau_ff, q_link, since): a new set point of the
 * drives, JointDrive.set_point(q, qd, tau_ff, q_link) then affine_control() with the same bits
 * (the file's docstring). The drives' state is the caller's: the integral is updated in place
 * from the old set point (q_old, qd_old; q_old None: none yet), u and du are written. qd,
 * tau_ff, qd_old None: zeros; q_link None: no integration. */
static PyObject* period_command(Period* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 10) {
    PyErr_SetString(PyExc_TypeError,
                    "command(u, du, integral, q_old, qd_old, q, qd, tau_ff, q_link, since)");
    return NULL;
  }
  if (self->gains == NULL) {
    PyErr_SetString(PyExc_RuntimeError, "_period.command: the period was made without gains");
    return NULL;
  }
  double since = PyFloat_AsDouble(args[9]);
  if (since == -1.0 && PyErr_Occurred()) return NULL;
  static const char* names[] = {"u", "du", "integral", "q_old", "qd_old", "q", "qd", "tau_ff",
                                "q_link"};
  static const int writable[] = {1, 1, 1, 0, 0, 0, 0, 0, 0};
  static const int optional[] = {0, 0, 0, 1, 1, 0, 1, 1, 1};
  double* v[9];
  Py_buffer views[9];
  int held = 0;
  for (int k = 0; k < 9; k++) {
    if (doubles_arg(self, args[k], writable[k], optional[k], v + k, views, &held, names[k]) < 0) {
      release_all(views, held);
      return NULL;
    }
  }
  set_point(self, v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8], since);
  release_all(views, held);
  Py_RETURN_NONE;
}

/* ---- The port (inkarm/core/_plant.h): the plant's read / command / step in C ---- */

static int port_open(Period* self) {
  if (self->entered) return 0;
  PyErr_SetString(PyExc_RuntimeError, "_period: the plant's port is closed (leave() was called)");
  return -1;
}

static int port_read(void* p, double* time, double* q, double* qd, double* torque, double* tip,
                     double* force) {
  Period* self = p;
  if (port_open(self) < 0) return -1;
  const mjData* d = self->d;
  *time = d->time;
  for (int j = 0; j < self->narm; j++) {
    q[j] = d->qpos[self->qpos_adr[j]];
    qd[j] = d->qvel[self->dof_adr[j]];
    torque[j] = d->actuator_force[self->arm[j]];
  }
  const mjtNum* x = d->site_xpos + 3 * self->tip_site;
  const double* a = self->page;
  /* (MujocoPlant._tip_page's sums, in its order) */
  tip[0] = a[0] * x[0] + a[3] * x[1] + a[6] * x[2] - a[9];
  tip[1] = a[1] * x[0] + a[4] * x[1] + a[7] * x[2] - a[10];
  tip[2] = a[2] * x[0] + a[5] * x[1] + a[8] * x[2] - a[11];
  *force = self->pen_force + self->force_bias;  /* (an ideal sensor: Senses.force) */
  return 0;
}

static int port_command(void* p, const double* q, const double* qd, const double* tau_ff) {
  Period* self = p;
  if (port_open(self) < 0) return -1;
  const int n = self->narm;
  memcpy(self->next, q, n * sizeof(double));
  memcpy(self->next + n, qd, n * sizeof(double));
  memcpy(self->next + 2 * n, tau_ff, n * sizeof(double));
  self->pending = 1;
  return 0;
}

static int port_step(void* p) {
  Period* self = p;
  if (port_open(self) < 0) return -1;
  const int n = self->narm;
  double* u = self->u_view.buf;
  if (self->pending) {  /* (MujocoPlant._apply: the drives' set point from the joints now) */
    double* q_link = self->next + 3 * n;
    for (int j = 0; j < n; j++) q_link[j] = self->d->qpos[self->qpos_adr[j]];
    set_point(self, u, self->du_view.buf, self->integral_view.buf,
              self->have_goal ? self->goal : NULL, self->have_qd_goal ? self->goal + n : NULL,
              self->next, self->next + n, self->next + 2 * n, q_link, self->since);
    memcpy(self->goal, self->next, 3 * n * sizeof(double));
    self->have_goal = self->have_qd_goal = 1;
    self->since = 0.0;
    self->pending = 0;
  }
  int suspect = 0;
  double since = self->since;  /* (kept only if the period completes, as the plant's own) */
  if (physics(self, u, self->du_view.buf, &since, &suspect) < 0) return -1;
  self->since = since;
  self->steps += self->substeps;
  if (self->nrows + self->substeps > self->cap_rows) {
    Py_ssize_t cap = 2 * (self->cap_rows + self->substeps);
    double* rows = PyMem_Realloc(self->rows, 4 * cap * sizeof(double));
    if (rows == NULL) {
      PyErr_NoMemory();
      return -1;
    }
    self->rows = rows;
    self->cap_rows = cap;
  }
  memcpy(self->rows + 4 * self->nrows, self->out, 4 * self->substeps * sizeof(double));
  self->nrows += self->substeps;
  self->pen_force = self->out[4 * (self->substeps - 1)];
  if (suspect) {  /* (the C test is conservative: the plant's own decides) */
    PyObject* ok = PyObject_CallNoArgs(self->diverged);
    if (ok == NULL) return -1;
    Py_DECREF(ok);
  }
  return 0;
}

static int int_list(PyObject* seq, int* out, int n, int bound, const char* what) {
  PyObject* fast = PySequence_Fast(seq, what);
  if (fast == NULL) return -1;
  int ok = PySequence_Fast_GET_SIZE(fast) == n;
  for (int j = 0; ok && j < n; j++) {
    long k = PyLong_AsLong(PySequence_Fast_GET_ITEM(fast, j));
    ok = !(k == -1 && PyErr_Occurred()) && k >= 0 && k < bound;
    out[j] = (int)k;
  }
  Py_DECREF(fast);
  if (!ok && !PyErr_Occurred())
    PyErr_Format(PyExc_ValueError, "_period.enter: %s must be %d indices below %d", what, n, bound);
  return ok ? 0 : -1;
}

/* enter(u, du, integral, q_goal, qd_goal, since, pen_force, force_bias, qpos_adr, dof_adr,
 * diverged): the plant's state handed to the port (the drives' u, du and integral in place;
 * q_goal, qd_goal copied, None: no set point yet). Until leave(), step() is refused. */
static PyObject* period_enter(Period* self, PyObject* args) {
  PyObject *u, *du, *integral, *q_goal, *qd_goal, *qpos_adr, *dof_adr, *diverged;
  double since, pen_force, bias;
  if (!PyArg_ParseTuple(args, "OOOOOdddOOO", &u, &du, &integral, &q_goal, &qd_goal, &since,
                        &pen_force, &bias, &qpos_adr, &dof_adr, &diverged))
    return NULL;
  if (self->m == NULL || self->gains == NULL || self->entered) {
    PyErr_SetString(PyExc_RuntimeError, self->entered ? "_period.enter: entered already"
                    : "_period.enter: the period was made without gains");
    return NULL;
  }
  const int n = self->narm;
  if (self->goal == NULL) {
    self->qpos_adr = PyMem_New(int, n);
    self->dof_adr = PyMem_New(int, n);
    self->goal = PyMem_New(double, 3 * n);
    self->next = PyMem_New(double, 4 * n);
    if (!self->qpos_adr || !self->dof_adr || !self->goal || !self->next) return PyErr_NoMemory();
  }
  if (int_list(qpos_adr, self->qpos_adr, n, self->m->nq, "qpos_adr") < 0 ||
      int_list(dof_adr, self->dof_adr, n, self->m->nv, "dof_adr") < 0)
    return NULL;
  Py_buffer views[5];
  int held = 0;
  PyObject* args3[5] = {u, du, integral, q_goal, qd_goal};
  static const char* names[5] = {"u", "du", "integral", "q_goal", "qd_goal"};
  self->have_goal = q_goal != Py_None;
  self->have_qd_goal = qd_goal != Py_None;
  for (int k = 0; k < 5; k++) {
    if (args3[k] == Py_None && k >= 3) continue;
    double* ignored;
    if (doubles_arg(self, args3[k], k <= 2, 0, &ignored, views, &held, names[k]) < 0) {
      release_all(views, held);
      return NULL;
    }
    if (k == 3) memcpy(self->goal, ignored, n * sizeof(double));
    if (k == 4) memcpy(self->goal + n, ignored, n * sizeof(double));
  }
  /* keep u, du, integral (views 0..2); the goals were copied */
  for (int k = 3; k < held; k++) PyBuffer_Release(views + k);
  self->u_view = views[0];
  self->du_view = views[1];
  self->integral_view = views[2];
  self->entered = 1;
  Py_INCREF(diverged);
  Py_XSETREF(self->diverged, diverged);
  self->since = since;
  self->pen_force = pen_force;
  self->force_bias = bias;
  self->pending = 0;
  self->steps = 0;
  self->nrows = 0;
  self->port = (inkarm_plant){INKARM_PLANT_ABI, self, n, port_read, port_command, port_step};
  Py_RETURN_NONE;
}

/* leave() -> (q_goal, qd_goal, tau_ff, since, steps, rows): the plant's state back
 * (the set point as three tuples, or None where there was none; the physics steps taken; the
 * canvas's (force, x, y, t) per step, a list). A command not yet stepped is dropped. */
static PyObject* period_leave(Period* self, PyObject* unused) {
  if (!self->entered) {
    PyErr_SetString(PyExc_RuntimeError, "_period.leave: not entered");
    return NULL;
  }
  const int n = self->narm;
  PyObject* goal[3] = {NULL, NULL, NULL};
  PyObject* rows = PyList_New(self->nrows);
  int ok = rows != NULL;
  for (int k = 0; ok && k < 3; k++) {
    if (!self->have_goal || (k == 1 && !self->have_qd_goal)) {
      goal[k] = Py_NewRef(Py_None);
      continue;
    }
    goal[k] = PyTuple_New(n);
    ok = goal[k] != NULL;
    for (int j = 0; ok && j < n; j++) {
      PyObject* x = PyFloat_FromDouble(self->goal[k * n + j]);
      ok = x != NULL;
      if (ok) PyTuple_SET_ITEM(goal[k], j, x);
    }
  }
  for (Py_ssize_t r = 0; ok && r < self->nrows; r++) {
    const double* o = self->rows + 4 * r;
    PyObject* row = Py_BuildValue("(dddd)", o[0], o[1], o[2], o[3]);
    ok = row != NULL;
    if (ok) PyList_SET_ITEM(rows, r, row);
  }
  PyObject* result = ok ? Py_BuildValue("(NNNdlN)", goal[0], goal[1], goal[2], self->since,
                                        self->steps, rows) : NULL;
  if (result == NULL) {
    for (int k = 0; k < 3; k++) Py_XDECREF(goal[k]);
    Py_XDECREF(rows);
  }
  port_release(self);
  self->nrows = 0;
  return result;
}

static void capsule_release(PyObject* capsule) { Py_XDECREF(PyCapsule_GetContext(capsule)); }

/* port() -> the PyCapsule of the port (it keeps the period alive; its functions refuse after
 * leave()) */
static PyObject* period_port(Period* self, PyObject* unused) {
  if (!self->entered) {
    PyErr_SetString(PyExc_RuntimeError, "_period.port: enter() first");
    return NULL;
  }
  PyObject* capsule = PyCapsule_New(&self->port, INKARM_PLANT_CAPSULE, capsule_release);
  if (capsule == NULL) return NULL;
  if (PyCapsule_SetContext(capsule, Py_NewRef(self)) < 0) {
    Py_DECREF(self);
    Py_DECREF(capsule);
    return NULL;
  }
  return capsule;
}

static PyMethodDef period_methods[] = {
    {"step", (PyCFunction)(void (*)(void))period_step, METH_FASTCALL,
     "step(u, du, since) -> (since, suspect, ((force, x, y, t), ...)): one control period"},
    {"command", (PyCFunction)(void (*)(void))period_command, METH_FASTCALL,
     "command(u, du, integral, q_old, qd_old, q, qd, tau_ff, q_link, since): a new set point "
     "of the drives (JointDrive.set_point then affine_control), u, du, integral in place"},
    {"enter", (PyCFunction)period_enter, METH_VARARGS,
     "enter(u, du, integral, q_goal, qd_goal, since, pen_force, force_bias, qpos_adr, dof_adr, "
     "diverged): hand the plant's state to the port"},
    {"leave", (PyCFunction)period_leave, METH_NOARGS,
     "leave() -> (q_goal, qd_goal, tau_ff, since, steps, rows): the state back"},
    {"port", (PyCFunction)period_port, METH_NOARGS,
     "port() -> the plant's port, a PyCapsule (inkarm/core/_plant.h)"},
    {NULL, NULL, 0, NULL}};

static PyTypeObject PeriodType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "inkarm.sim._period.Period",
    .tp_basicsize = sizeof(Period),
    .tp_dealloc = (destructor)period_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Period(owners, model_address, data_address, arm, tip_site, tip_geom, page_map, "
              "substeps, max_speed_sq, warning_total[, gains])",
    .tp_methods = period_methods,
    .tp_init = (initproc)period_init,
    .tp_new = PyType_GenericNew,
};

static PyMethodDef module_methods[] = {
    {"bind", bind, METH_VARARGS,
     "bind(path, fatal_error): MuJoCo's functions from the loaded libmujoco; its fatal errors "
     "inside a period raise fatal_error"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_period",
                                    "One control period of the simulated plant in C.", -1,
                                    module_methods};

PyMODINIT_FUNC PyInit__period(void) {
  if (PyType_Ready(&PeriodType) < 0) return NULL;
  PyObject* mod = PyModule_Create(&module);
  if (mod == NULL) return NULL;
  Py_INCREF(&PeriodType);
  if (PyModule_AddObject(mod, "Period", (PyObject*)&PeriodType) < 0 ||
      PyModule_AddStringConstant(mod, "MUJOCO_VERSION", INKARM_MUJOCO_VERSION) < 0 ||
      PyModule_AddIntConstant(mod, "API", INKARM_PERIOD_API) < 0 ||
      PyModule_AddObject(mod, "WARNINGS", Py_BuildValue("(iii)", mjWARN_BADQPOS, mjWARN_BADQVEL,
                                                        mjWARN_BADQACC)) < 0) {
    Py_DECREF(mod);
    return NULL;
  }
  return mod;
}
