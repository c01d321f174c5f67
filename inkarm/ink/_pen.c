/* The felt-tip marker's pen between physics steps, in C: Canvas._touch_rows for
 * inkarm.ink.marker.MarkerInk (inkarm/ink/canvas.py, the reference, gives the same bits:
 * tests/ink/test_compiled_pen.py).
 *
 * advance(pen, rows, start, ink, motion, queue, queue_floats) walks the rows
 * (force [N], x [mm], y [mm], t [s]) from row `start` and returns (pen, next row, why):
 *   DONE        every row taken;
 *   LIFT        row `next - 1` lifts the pen while it is down: the canvas lifts (Python), then
 *               calls again from `next`;
 *   FLUSH       the queue reached `queue_floats`: the canvas rasterises it, then calls again;
 *   NOT_FINITE  row `next` holds a value that is not finite (the canvas raises, naming it);
 *   BACKWARDS   row `next`'s time is before the pen's last (the canvas raises).
 * pen: the canvas's 17-tuple (_PEN_UP in canvas.py); ink: (w0_mm, k_mm, f0_n, opacity,
 * threshold_n); motion: (speed_tau_s, px_per_mm, max_segment_mm^2). Capsules (x0, y0, w0, x1, y1,
 * w1, opacity) are appended to the list `queue` as the Python loop appends them.
 *
 * The marker's law (marker.py):  a = 0 below F_th;  w(F) = w0 + k (1 - exp(-(F - F_th) / F0)).
 * The pen speed: v <- v + g (|p - p_last| / dt - v),  g = 1 - exp(-dt / tau). */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>

#define INKARM_PEN_API 2

enum { DONE = 0, LIFT = 1, FLUSH = 2, NOT_FINITE = 3, BACKWARDS = 4 };

typedef struct {
  int down, has_speed, has_first, waiting, has_gain_dt;
  double lx, ly, lt, speed, first, sx, sy, sw, sa, px, py, pw, pa, gain_dt, gain;
} Pen;

typedef struct {
  double w0, k, f0, opacity, threshold;
} Marker;

static void mark(const Marker* ink, double force, double* width, double* opacity) {
  if (force < ink->threshold) {
    *width = ink->w0;
    *opacity = 0.0;
    return;
  }
  *width = ink->w0 + ink->k * (1.0 - exp(-(force - ink->threshold) / ink->f0));
  *opacity = ink->opacity;
}

/* A float of the pen tuple, or None as `present` = 0. */
static int optional(PyObject* item, int* present, double* value) {
  *present = item != Py_None;
  *value = *present ? PyFloat_AsDouble(item) : 0.0;
  return *present && *value == -1.0 && PyErr_Occurred() ? -1 : 0;
}

static int pen_from(PyObject* tuple, Pen* p) {
  if (!PyTuple_Check(tuple) || PyTuple_GET_SIZE(tuple) != 17) {
    PyErr_SetString(PyExc_TypeError, "pen: expected the canvas's 17-tuple");
    return -1;
  }
  PyObject** t = &PyTuple_GET_ITEM(tuple, 0);
  double* plain[] = {&p->lx, &p->ly, &p->lt, &p->sx, &p->sy, &p->sw, &p->sa, &p->px, &p->py,
                     &p->pw, &p->pa, &p->gain};
  const int at[] = {1, 2, 3, 6, 7, 8, 9, 11, 12, 13, 14, 16};
  if ((p->down = PyObject_IsTrue(t[0])) < 0 || (p->waiting = PyObject_IsTrue(t[10])) < 0)
    return -1;
  for (int i = 0; i < 12; i++) {
    *plain[i] = PyFloat_AsDouble(t[at[i]]);
    if (*plain[i] == -1.0 && PyErr_Occurred()) return -1;
  }
  if (optional(t[4], &p->has_speed, &p->speed) || optional(t[5], &p->has_first, &p->first) ||
      optional(t[15], &p->has_gain_dt, &p->gain_dt))
    return -1;
  return 0;
}

static PyObject* optional_float(int present, double value) {
  if (present) return PyFloat_FromDouble(value);
  Py_RETURN_NONE;
}

static PyObject* pen_to(const Pen* p) {
  return Py_BuildValue("(NdddNNddddNddddNd)", PyBool_FromLong(p->down), p->lx, p->ly, p->lt,
                       optional_float(p->has_speed, p->speed),
                       optional_float(p->has_first, p->first), p->sx, p->sy, p->sw, p->sa,
                       PyBool_FromLong(p->waiting), p->px, p->py, p->pw, p->pa,
                       optional_float(p->has_gain_dt, p->gain_dt), p->gain);
}

static int extend(PyObject* queue, double a, double b, double c, double d, double e, double f,
                  double g) {
  const double fields[7] = {a, b, c, d, e, f, g};
  for (int i = 0; i < 7; i++) {
    PyObject* v = PyFloat_FromDouble(fields[i]);
    if (v == NULL || PyList_Append(queue, v) < 0) {
      Py_XDECREF(v);
      return -1;
    }
    Py_DECREF(v);
  }
  return 0;
}

/* One row of Canvas._touch_rows (its comments say why); returns the row's outcome. */
static int take(Pen* p, const Marker* ink, double tau, double ppm, double segment2,
                const double* row, PyObject* queue, Py_ssize_t queue_floats, int* error) {
  const double force = row[0], x = row[1], y = row[2], t = row[3];
  *error = 0;
  if (!(force > 0.0)) return p->down ? LIFT : DONE; /* (touch_many: a lift) */
  if ((x + y + t + force) * 0.0 != 0.0 &&
      !(isfinite(x) && isfinite(y) && isfinite(t) && isfinite(force)))
    return NOT_FINITE;
  if (!p->down) {
    p->down = 1;
    p->lx = x, p->ly = y, p->lt = t;
    p->has_first = 1, p->first = force;
    p->waiting = 0;
    return DONE;
  }
  if (t < p->lt) return BACKWARDS;
  const double dt = t - p->lt;
  if (dt > 0.0) {
    const double dx = x - p->lx, dy = y - p->ly;
    const double raw = sqrt(dx * dx + dy * dy) / dt;
    if (!p->has_speed) {
      p->has_speed = 1, p->speed = raw;
    } else {
      if (!p->has_gain_dt || dt != p->gain_dt) {
        p->has_gain_dt = 1, p->gain_dt = dt;
        p->gain = 1.0 - exp(-dt / tau);
      }
      p->speed += p->gain * (raw - p->speed);
    }
  }
  if (p->has_first) {  /* the pen-down point, now that the speed is known */
    mark(ink, p->first, &p->sw, &p->sa);
    p->sx = p->lx, p->sy = p->ly, p->has_first = 0;
    if (extend(queue, p->sx, p->sy, p->sw, p->sx, p->sy, p->sw, p->sa)) return *error = 1;
  }
  p->lx = x, p->ly = y, p->lt = t;
  double width, opacity;
  mark(ink, force, &width, &opacity);
  if (opacity <= 0.0) {
    if (p->waiting) {
      if (extend(queue, p->sx, p->sy, p->sw, p->px, p->py, p->pw, p->pa)) return *error = 1;
      p->waiting = 0;
    }
    p->sx = x, p->sy = y, p->sw = width, p->sa = 0.0;
  } else if ((x - p->sx) * (x - p->sx) + (y - p->sy) * (y - p->sy) >= segment2 ||
             fabs(width - p->sw) * ppm >= 0.5 || fabs(opacity - p->sa) >= 0.05) {
    if (extend(queue, p->sx, p->sy, p->sw, x, y, width, opacity)) return *error = 1;
    p->sx = x, p->sy = y, p->sw = width, p->sa = opacity, p->waiting = 0;
    if (PyList_GET_SIZE(queue) >= queue_floats) return FLUSH;
  } else {
    p->px = x, p->py = y, p->pw = width, p->pa = opacity, p->waiting = 1;
  }
  return DONE;
}

static PyObject* advance(PyObject* self, PyObject* args) {
  PyObject *pen_tuple, *rows, *queue;
  Py_ssize_t start, queue_floats;
  Marker ink;
  double tau, ppm, segment2;
  if (!PyArg_ParseTuple(args, "OOn(ddddd)(ddd)O!n", &pen_tuple, &rows, &start, &ink.w0,
                        &ink.k, &ink.f0, &ink.opacity, &ink.threshold, &tau, &ppm, &segment2,
                        &PyList_Type, &queue, &queue_floats))
    return NULL;
  Pen p;
  if (pen_from(pen_tuple, &p)) return NULL;
  Py_buffer view;
  if (PyObject_GetBuffer(rows, &view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_ND) < 0)
    return NULL;
  PyObject* out = NULL;
  if (view.ndim != 2 || view.shape[1] != 4 || view.format == NULL ||
      strcmp(view.format, "d") != 0) {
    PyErr_SetString(PyExc_TypeError, "rows: expected a C-contiguous (n, 4) float64 array");
    goto done;
  }
  const double* data = (const double*)view.buf;
  const Py_ssize_t n = view.shape[0];
  Py_ssize_t i = start < 0 ? 0 : start;
  int why = DONE, error = 0;
  for (; i < n; i++) {
    why = take(&p, &ink, tau, ppm, segment2, data + 4 * i, queue, queue_floats, &error);
    if (error) goto done;
    if (why == NOT_FINITE || why == BACKWARDS) break;
    if (why != DONE) {
      i++;
      break;
    }
  }
  out = Py_BuildValue("(Nni)", pen_to(&p), i, why);
done:
  PyBuffer_Release(&view);
  return out;
}

static PyMethodDef methods[] = {
    {"advance", advance, METH_VARARGS,
     "advance(pen, rows, start, ink, motion, queue, queue_floats) -> (pen, next, why)"},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_pen",
                                    "The marker's pen between physics steps (inkarm.ink.pen).",
                                    -1, methods};

PyMODINIT_FUNC PyInit__pen(void) {
  PyObject* m = PyModule_Create(&module);
  if (m == NULL) return NULL;
  const char* names[] = {"DONE", "LIFT", "FLUSH", "NOT_FINITE", "BACKWARDS"};
  for (int i = 0; i < 5; i++)
    if (PyModule_AddIntConstant(m, names[i], i) < 0) goto fail;
  if (PyModule_AddIntConstant(m, "API", INKARM_PEN_API) < 0) goto fail;
  return m;
fail:
  Py_DECREF(m);
  return NULL;
}
