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

#ifndef INKARM_MUJOCO_VERSION
#define INKARM_MUJOCO_VERSION "unknown"
#endif

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
static jmp_buf* error_jump = NULL;
static char error_message[512];

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
  double max_speed_sq;
  int warning_total;
} Period;

static void period_dealloc(Period* self) {
  Py_XDECREF(self->owners);
  PyMem_Free(self->arm);
  PyMem_Free(self->out);
  Py_TYPE(self)->tp_free((PyObject*)self);
}

static int period_init(Period* self, PyObject* args, PyObject* kwds) {
  PyObject *owners, *arm, *page;
  unsigned long long m_addr, d_addr;
  if (!PyArg_ParseTuple(args, "OKKOiiOidi", &owners, &m_addr, &d_addr, &arm, &self->tip_site,
                        &self->tip_geom, &page, &self->substeps, &self->max_speed_sq,
                        &self->warning_total))
    return -1;
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
  for (Py_ssize_t i = 0; i < n; i++)
    self->arm[i] = (int)PyLong_AsLong(PySequence_Fast_GET_ITEM(arm_seq, i));
  Py_DECREF(arm_seq);
  self->narm = (int)n;
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
  self->m = (const mjModel*)(uintptr_t)m_addr;
  self->d = (mjData*)(uintptr_t)d_addr;
  Py_INCREF(owners);
  Py_XSETREF(self->owners, owners);
  return 0;
}

/* step(u, du, since) -> (since, suspect, ((force, x, y, t), ...) one per physics step).
 * u [N m] is advanced in place by du each physics step (the plant's own array). */
static PyObject* period_step(Period* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 3) {
    PyErr_SetString(PyExc_TypeError, "step(u, du, since)");
    return NULL;
  }
  Py_buffer ub, dub;
  if (PyObject_GetBuffer(args[0], &ub, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS) < 0) return NULL;
  if (PyObject_GetBuffer(args[1], &dub, PyBUF_C_CONTIGUOUS) < 0) {
    PyBuffer_Release(&ub);
    return NULL;
  }
  double since = PyFloat_AsDouble(args[2]);
  Py_ssize_t want = (Py_ssize_t)self->narm * (Py_ssize_t)sizeof(double);
  if (ub.len != want || dub.len != want || (since == -1.0 && PyErr_Occurred())) {
    PyBuffer_Release(&ub);
    PyBuffer_Release(&dub);
    if (!PyErr_Occurred())
      PyErr_Format(PyExc_ValueError, "_period: u and du must be %d float64", self->narm);
    return NULL;
  }
  double* u = (double*)ub.buf;
  const double* du = (const double*)dub.buf;
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
    PyBuffer_Release(&ub);
    PyBuffer_Release(&dub);
    PyErr_SetString(fatal_error, error_message);
    return NULL;
  }
  error_jump = &jump;
  *user_error = period_error;
  for (int s = 0; s < self->substeps; s++) {
    for (int i = 0; i < self->narm; i++) {
      d->ctrl[self->arm[i]] = u[i];
      u[i] = u[i] + du[i];
    }
    since = since + h;
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
  PyBuffer_Release(&ub);
  PyBuffer_Release(&dub);
  double speed_sq = 0.0;
  for (int i = 0; i < m->nv; i++) speed_sq += d->qvel[i] * d->qvel[i];
  int warnings = d->warning[mjWARN_BADQPOS].number + d->warning[mjWARN_BADQVEL].number +
                 d->warning[mjWARN_BADQACC].number;
  /* (a margin over the summation order of NumPy's dot: flagged periods get the exact test) */
  int suspect = !(speed_sq <= self->max_speed_sq * (1.0 - 1e-9)) ||
                warnings != self->warning_total;
  PyObject* steps = PyTuple_New(self->substeps);
  if (steps == NULL) return NULL;
  for (int s = 0; s < self->substeps; s++) {
    const double* o = out + 4 * s;
    PyObject* row = Py_BuildValue("(dddd)", o[0], o[1], o[2], o[3]);
    if (row == NULL) {
      Py_DECREF(steps);
      return NULL;
    }
    PyTuple_SET_ITEM(steps, s, row);
  }
  return Py_BuildValue("(dON)", since, suspect ? Py_True : Py_False, steps);
}

static PyMethodDef period_methods[] = {
    {"step", (PyCFunction)(void (*)(void))period_step, METH_FASTCALL,
     "step(u, du, since) -> (since, suspect, ((force, x, y, t), ...)): one control period"},
    {NULL, NULL, 0, NULL}};

static PyTypeObject PeriodType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "inkarm.sim._period.Period",
    .tp_basicsize = sizeof(Period),
    .tp_dealloc = (destructor)period_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Period(owners, model_address, data_address, arm, tip_site, tip_geom, page_map, "
              "substeps, max_speed_sq, warning_total)",
    .tp_methods = period_methods,
    .tp_init = (initproc)period_init,
    .tp_new = PyType_GenericNew,
};

static PyMethodDef module_methods[] = {
    {"bind", bind, METH_VARARGS, "bind(path): MuJoCo's functions from the loaded libmujoco"},
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
      PyModule_AddStringConstant(mod, "MUJOCO_VERSION", INKARM_MUJOCO_VERSION) < 0) {
    Py_DECREF(mod);
    return NULL;
  }
  return mod;
}
