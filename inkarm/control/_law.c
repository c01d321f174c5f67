/* The built-in ``position`` law's feed-forward in one call (issue 22 part 2).
 *
 * PositionGoals.command (inkarm/control/laws/position_goals.py) with its friction adaptation
 * (inkarm/control/friction.py), past the safe stop, in the order of their numpy operations:
 *
 *     q_then = q_row                                        (seen == c)
 *            = q_ref[seen] + depth normal_q[seen]           (else)
 *     q_then = q_then + blend (q_ref[min(seen + 1, last)] - q_ref[seen])      (blend != 0)
 *     F_hat  = min(max(((q_then - q) (gamma dt)) dir[c] + F_hat, 0), F_max)   (gamma > 0)
 *     tau_ff = planned[c] + F_hat dir[c]  [+ contact_tau[c] while pressing]
 *
 * with numpy's maximum/minimum (NaN stays NaN; of two equal values the second, as x86's
 * maxsd/minsd: setup.py builds this on x86-64 only) and -ffp-contract=off: the same bits as the
 * Python law (tests/control/test_compiled_law.py). No MuJoCo, no NumPy headers: arrays come as
 * float64 buffers.
 */
#include <string.h>

#include "_law.h"

/* What this module offers, as inkarm.control.compiled.API expects it (2: MemberPeriod) */
#define INKARM_LAW_API 3

static void release_views(PositionLaw* self) {
  for (int i = 0; i < self->held; i++) PyBuffer_Release(self->views + i);
  self->held = 0;
}

static void law_dealloc(PositionLaw* self) {
  release_views(self);
  Py_TYPE(self)->tp_free((PyObject*)self);
}

static const char* view_names[NBUF] = {"planned_torque", "direction", "contact_tau", "q_ref",
                                       "normal_q", "estimate", "ceiling"};

static int law_init(PositionLaw* self, PyObject* args, PyObject* kwds) {
  PyObject* arrays[NBUF];
  double rate;
  release_views(self);
  self->n = 0;  /* (unusable until this initialisation succeeds) */
  if (!PyArg_ParseTuple(args, "OOOOOOOd", arrays, arrays + 1, arrays + 2, arrays + 3,
                        arrays + 4, arrays + 5, arrays + 6, &rate))
    return -1;
  for (int k = 0; k < NBUF; k++) {
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_ND | (k == ESTIMATE ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(arrays[k], self->views + k, flags) < 0) {
      release_views(self);
      return -1;
    }
    self->held++;
  }
  Py_buffer* plan = self->views + PLANNED;
  Py_ssize_t rows = plan->ndim == 2 ? plan->shape[0] : 0, n = plan->ndim == 2 ? plan->shape[1] : 0;
  for (int k = 0; k < NBUF; k++) {
    Py_buffer* v = self->views + k;
    int columns = k == ESTIMATE || k == CEILING;
    int ok = v->format != NULL && strcmp(v->format, "d") == 0 &&
             (columns ? v->ndim == 1 && v->shape[0] == n
                      : v->ndim == 2 && v->shape[0] == rows && v->shape[1] == n);
    if (!ok || rows < 1 || n < 1) {
      PyErr_Format(PyExc_ValueError, "_law.PositionLaw: %s must be float64 of shape %s (the "
                   "plan's %zd rows x %zd joints)", view_names[k], columns ? "(n,)" : "(rows, n)",
                   rows, n);
      release_views(self);
      return -1;
    }
  }
  self->rows = rows;
  self->rate = rate;
  self->n = n;
  return 0;
}

void position_feedforward(PositionLaw* self, double* out, const double* q_row, const double* q,
                          Py_ssize_t c, Py_ssize_t seen, double depth, double blend,
                          int pressing) {
  const Py_ssize_t n = self->n, last = self->rows - 1;
  const double* planned = (const double*)self->views[PLANNED].buf + c * n;
  const double* dir = (const double*)self->views[DIRECTION].buf + c * n;
  double* estimate = (double*)self->views[ESTIMATE].buf;
  const double* ceiling = (const double*)self->views[CEILING].buf;
  if (self->rate != 0.0) {
    const double* q_seen = (const double*)self->views[Q_REF].buf + seen * n;
    const double* q_next = (const double*)self->views[Q_REF].buf + (seen < last ? seen + 1 : last) * n;
    const double* normal = (const double*)self->views[NORMAL_Q].buf + seen * n;
    for (Py_ssize_t i = 0; i < n; i++) {
      double q_then = seen == c ? q_row[i] : q_seen[i] + depth * normal[i];
      if (blend != 0.0) q_then = q_then + blend * (q_next[i] - q_seen[i]);
      double x = (q_then - q[i]) * self->rate;
      x = x * dir[i];
      x = x + estimate[i];
      x = (x > 0.0 || x != x) ? x : 0.0;                   /* np.maximum(x, 0) */
      estimate[i] = (x < ceiling[i] || x != x) ? x : ceiling[i];  /* np.minimum(x, F_max) */
    }
  }
  const double* contact = (const double*)self->views[CONTACT].buf + c * n;
  for (Py_ssize_t i = 0; i < n; i++) {
    double tau = planned[i] + estimate[i] * dir[i];
    out[i] = pressing ? tau + contact[i] : tau;
  }
}

/* command(out, q_row, q, c, seen, depth, blend, pressing): tau_ff [N m] into out (n float64),
 * F_hat adapted in place (the file's docstring). */
static PyObject* law_command(PositionLaw* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 8) {
    PyErr_SetString(PyExc_TypeError, "command(out, q_row, q, c, seen, depth, blend, pressing)");
    return NULL;
  }
  if (self->n == 0) {
    PyErr_SetString(PyExc_RuntimeError, "_law.PositionLaw: not initialised");
    return NULL;
  }
  Py_ssize_t c = PyNumber_AsSsize_t(args[3], PyExc_IndexError);
  Py_ssize_t seen = PyNumber_AsSsize_t(args[4], PyExc_IndexError);
  double depth = PyFloat_AsDouble(args[5]), blend = PyFloat_AsDouble(args[6]);
  int pressing = PyObject_IsTrue(args[7]);
  if (PyErr_Occurred() || pressing < 0) return NULL;
  const Py_ssize_t n = self->n, last = self->rows - 1;
  if (c < 0 || c > last || seen < 0 || seen > last) {
    PyErr_Format(PyExc_IndexError, "_law.PositionLaw: rows c = %zd, seen = %zd not in the "
                 "plan's 0..%zd", c, seen, last);
    return NULL;
  }
  static const char* names[3] = {"out", "q_row", "q"};
  Py_buffer views[3];
  int held = 0;
  for (int k = 0; k < 3; k++) {
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (k == 0 ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(args[k], views + k, flags) < 0) goto fail;
    held++;
    if (views[k].len != n * (Py_ssize_t)sizeof(double) || views[k].format == NULL ||
        strcmp(views[k].format, "d") != 0) {
      PyErr_Format(PyExc_ValueError, "_law.PositionLaw.command: %s must be %zd float64",
                   names[k], n);
      goto fail;
    }
  }
  position_feedforward(self, (double*)views[0].buf, (const double*)views[1].buf,
                       (const double*)views[2].buf, c, seen, depth, blend, pressing);
  for (int k = 0; k < held; k++) PyBuffer_Release(views + k);
  Py_RETURN_NONE;
fail:
  for (int k = 0; k < held; k++) PyBuffer_Release(views + k);
  return NULL;
}

static PyMethodDef law_methods[] = {
    {"command", (PyCFunction)(void (*)(void))law_command, METH_FASTCALL,
     "command(out, q_row, q, c, seen, depth, blend, pressing): the feed-forward [N m] into out, "
     "the friction estimate adapted in place"},
    {NULL, NULL, 0, NULL}};

PyTypeObject PositionLawType = {
    PyVarObject_HEAD_INIT(NULL, 0).tp_name = "inkarm.control._law.PositionLaw",
    .tp_basicsize = sizeof(PositionLaw),
    .tp_dealloc = (destructor)law_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "PositionLaw(planned_torque, direction, contact_tau, q_ref, normal_q, estimate, "
              "ceiling, rate)",
    .tp_methods = law_methods,
    .tp_init = (initproc)law_init,
    .tp_new = PyType_GenericNew,
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_law",
                                    "The built-in position law's feed-forward and the member's "
                                    "period in C.", -1, NULL};

PyMODINIT_FUNC PyInit__law(void) {
  if (PyType_Ready(&PositionLawType) < 0) return NULL;
  PyObject* mod = PyModule_Create(&module);
  if (mod == NULL) return NULL;
  Py_INCREF(&PositionLawType);
  if (PyModule_AddObject(mod, "PositionLaw", (PyObject*)&PositionLawType) < 0 ||
      PyModule_AddIntConstant(mod, "API", INKARM_LAW_API) < 0 || add_member_period(mod) < 0) {
    Py_DECREF(mod);
    return NULL;
  }
  return mod;
}
