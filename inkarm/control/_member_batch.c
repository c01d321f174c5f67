/* The periods of a batch's members in one call (issue 22 part 2; inkarm/control/batch_lanes.py;
 * part of the extension inkarm.control._law, sharing _member.h with _member.c): for each member
 * of ``ids`` from ``start`` on, what its generator's resume does on the lane path
 * (inkarm/control/executor.py, _member): ``rows[m]`` = its plan row, advance(), its reading
 * (row m of the batch's arrays, as BatchMembers.states() would make it), steps 2-4 and its command
 * written into row m of the command arrays (given[m] set), as BatchMembers.step packs a
 * PositionCommand(q*, qd_ref[c], qdd_ref[c], tau_ff). It stops at the first member it hands back
 * to its generator: returns (k, None) where member ids[k]'s next period is not for this call
 * (its plan ends, its reading is not one the lane takes: nothing of it changed), (k, exception)
 * where its period raised (a watchdog's fault, the search's, a Ctrl-C: its state then as
 * period()'s at that point, its reading taken, ``fresh``), (len(ids), None) when all ran. */
#include <math.h>
#include <string.h>

#include "_member.h"

/* The batch's row arrays: fetch()'s tuple (time, times or None, q, qd, torque, force, tip, q_cmd,
 * qd_cmd, tau_cmd, given). */
enum { B_Q, B_QD, B_TORQUE, B_FORCE, B_TIP, B_TIMES, B_QCMD, B_QDCMD, B_TAUCMD, B_GIVEN, NB };

typedef struct {
  Py_buffer b[NB];  /* (obj NULL: not held) */
  double time;
  Py_ssize_t n;     /* the arm's joints (q's columns) */
} BatchRows;

static void rows_release(BatchRows* rows) {
  for (int k = 0; k < NB; k++)
    if (rows->b[k].obj != NULL) PyBuffer_Release(rows->b + k);
}

/* 0: taken; 1: fetch() gave None (no rows the lane takes); -1: an error set. */
static int rows_take(BatchRows* rows, PyObject* fetch, Py_ssize_t members) {
  static const char* names[NB] = {"q", "qd", "torque", "force", "tip", "times", "q_cmd",
                                  "qd_cmd", "tau_cmd", "given"};
  for (int k = 0; k < NB; k++) rows->b[k].obj = NULL;
  PyObject* got = PyObject_CallNoArgs(fetch);
  if (got == NULL) return -1;
  if (got == Py_None) {
    Py_DECREF(got);
    return 1;
  }
  PyObject *time, *objs[NB];
  if (!PyTuple_Check(got) ||
      !PyArg_ParseTuple(got, "OOOOOOOOOOO", &time, objs + B_TIMES, objs + B_Q, objs + B_QD,
                        objs + B_TORQUE, objs + B_FORCE, objs + B_TIP, objs + B_QCMD,
                        objs + B_QDCMD, objs + B_TAUCMD, objs + B_GIVEN)) {
    if (!PyErr_Occurred())
      PyErr_SetString(PyExc_TypeError, "_law.periods: fetch() must return a tuple or None");
    Py_DECREF(got);
    return -1;
  }
  rows->time = PyFloat_AsDouble(time);
  if (rows->time == -1.0 && PyErr_Occurred()) {
    Py_DECREF(got);
    return -1;
  }
  Py_ssize_t n = -1;
  for (int k = 0; k < NB; k++) {
    if (k == B_TIMES && objs[k] == Py_None) continue;
    int out = k >= B_QCMD;
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_ND | (out ? PyBUF_WRITABLE : 0);
    Py_buffer* b = rows->b + k;
    if (PyObject_GetBuffer(objs[k], b, flags) < 0) {
      b->obj = NULL;
      rows_release(rows);
      Py_DECREF(got);
      return -1;
    }
    int ndim = (k == B_FORCE || k == B_TIMES || k == B_GIVEN) ? 1 : 2;
    const char* fmt = k == B_GIVEN ? "?" : "d";
    if (n < 0 && ndim == 2 && k != B_TIP) n = b->shape[1];
    Py_ssize_t cols = k == B_TIP ? 3 : n;
    if (b->format == NULL || strcmp(b->format, fmt) != 0 || b->ndim != ndim ||
        b->shape[0] != members || (ndim == 2 && b->shape[1] != cols)) {
      PyErr_Format(PyExc_ValueError, "_law.periods: the batch's %s must be of format %s, "
                   "%d-d, %zd rows (x %zd)", names[k], fmt, ndim, members, ndim == 2 ? cols : 0);
      rows_release(rows);
      Py_DECREF(got);
      return -1;
    }
  }
  Py_DECREF(got);  /* (the buffers hold the arrays) */
  rows->n = n;
  return 0;
}

/* The raised exception as an object (a traceback kept), the error cleared. */
static PyObject* raised(void) {
#if PY_VERSION_HEX >= 0x030C0000
  return PyErr_GetRaisedException();
#else
  PyObject *type, *value, *tb;
  PyErr_Fetch(&type, &value, &tb);
  PyErr_NormalizeException(&type, &value, &tb);
  if (value != NULL && tb != NULL) PyException_SetTraceback(value, tb);
  Py_XDECREF(type);
  Py_XDECREF(tb);
  return value;
#endif
}

/* periods(kernels, ids, start, fetch, rows) -> (k, exception or None): above. kernels: one
 * MemberPeriod per member of the batch (N); ids: the members' indices, ascending; rows: the
 * board's plan rows (a list of N). */
static PyObject* batch_periods(PyObject* unused, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 5 || !PyTuple_Check(args[0]) || !PyList_Check(args[1]) ||
      !PyList_Check(args[4])) {
    PyErr_SetString(PyExc_TypeError, "periods(kernels: tuple, ids: list, start, fetch, "
                    "rows: list)");
    return NULL;
  }
  PyObject *kernels = args[0], *ids = args[1], *fetch = args[3], *plan_rows = args[4];
  const Py_ssize_t members = PyTuple_GET_SIZE(kernels);
  Py_ssize_t k = PyLong_AsSsize_t(args[2]);
  if (k == -1 && PyErr_Occurred()) return NULL;
  if (k < 0) {
    PyErr_Format(PyExc_ValueError, "_law.periods: start must be >= 0, not %zd", k);
    return NULL;
  }
  if (PyList_GET_SIZE(plan_rows) != members) {
    PyErr_Format(PyExc_ValueError, "_law.periods: rows has %zd items for %zd members",
                 PyList_GET_SIZE(plan_rows), members);
    return NULL;
  }
  BatchRows batch;
  int fetched = 0;  /* 0: not yet; 1: taken; 2: none the lane takes */
  PyObject* fault = NULL;
  for (; k < PyList_GET_SIZE(ids); k++) {  /* (ids: the caller's, read afresh) */
    Py_ssize_t m = PyLong_AsSsize_t(PyList_GET_ITEM(ids, k));
    if (m == -1 && PyErr_Occurred()) goto failed;
    if (m < 0 || m >= members ||
        !PyObject_TypeCheck(PyTuple_GET_ITEM(kernels, m), &MemberPeriodType)) {
      PyErr_Format(PyExc_ValueError, "_law.periods: member %zd has no MemberPeriod among the "
                   "%zd kernels", m, members);
      goto failed;
    }
    MemberPeriod* self = (MemberPeriod*)PyTuple_GET_ITEM(kernels, m);
    if (self->n == 0 || self->next_i >= self->rows) break;  /* (its plan ends: its generator's) */
    if (PyErr_CheckSignals() < 0) {  /* (a Ctrl-C before its period: at its generator's yield) */
      fault = raised();
      break;
    }
    if (!fetched) {
      int got = rows_take(&batch, fetch, members);
      if (got < 0) goto failed;
      fetched = got == 0 ? 1 : 2;
    }
    const Py_ssize_t n = self->n;
    const double time = batch.b[B_TIMES].obj ? ((const double*)batch.b[B_TIMES].buf)[m]
                                             : batch.time;
    if (fetched == 2 || batch.n != n || !isfinite(time)) break;  /* (period() would refuse it) */
    PyObject* row = PyLong_FromSsize_t(self->i);
    if (row == NULL) goto failed;
    PyList_SetItem(plan_rows, m, row);  /* (the row stepped: the executor's rows[member] = i) */
    period_advance(self);
    if (period_ready(self) < 0) {
      fault = raised();
      break;
    }
    Reading r = {0};
    r.time = time;
    r.force = self->senses_force ? ((const double*)batch.b[B_FORCE].buf)[m] : NAN;
    r.q = (const double*)batch.b[B_Q].buf + m * n;
    r.qd = (const double*)batch.b[B_QD].buf + m * n;
    r.torque = (const double*)batch.b[B_TORQUE].buf + m * n;
    r.tip = (const double*)batch.b[B_TIP].buf + m * 3;
    double* goal = (double*)batch.b[B_QCMD].buf + m * n;
    Py_ssize_t c;
    self->fresh = 1;
    if (period_steps(self, &r, goal, (double*)batch.b[B_TAUCMD].buf + m * n, &c) < 0) {
      fault = raised();
      break;
    }
    memcpy((double*)batch.b[B_QDCMD].buf + m * n, (const double*)self->v[V_QD].buf + c * n,
           n * sizeof(double));
    ((unsigned char*)batch.b[B_GIVEN].buf)[m] = 1;
    self->fresh = 0;  /* (commanded: the executor's _send) */
  }
  if (fetched == 1) rows_release(&batch);
  return Py_BuildValue("(nN)", k, fault != NULL ? fault : Py_NewRef(Py_None));
failed:
  if (fetched == 1) rows_release(&batch);
  return NULL;
}

static PyMethodDef batch_functions[] = {
    {"periods", (PyCFunction)(void (*)(void))batch_periods, METH_FASTCALL,
     "periods(kernels, ids, start, fetch, rows) -> (k, exception or None): the members' "
     "periods of one batch in one call (inkarm/control/batch_lanes.py)"},
    {NULL, NULL, 0, NULL}};

/* Adds periods() to the module; 0, or -1 with an exception. */
int add_batch_periods(PyObject* module) { return PyModule_AddFunctions(module, batch_functions); }
