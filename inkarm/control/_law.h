/* What the two sources of the extension inkarm.control._law share: the position law's state and
 * its feed-forward (_law.c), used per period by the member's compiled period (_member.c). */
#ifndef INKARM_LAW_H
#define INKARM_LAW_H
#define PY_SSIZE_T_CLEAN
#include <Python.h>

enum { PLANNED, DIRECTION, CONTACT, Q_REF, NORMAL_Q, ESTIMATE, CEILING, NBUF };

typedef struct {
  PyObject_HEAD
  Py_buffer views[NBUF];   /* the plan's (rows, n) columns; F_hat (written) and F_max, (n,) */
  int held;                /* views held (released on dealloc and re-init) */
  Py_ssize_t rows, n;
  double rate;             /* gamma dt [N m / rad]; 0: F_hat fixed */
} PositionLaw;

extern PyTypeObject PositionLawType;

/* tau_ff into out (n), F_hat adapted in place: PositionGoals.command past the safe stop, for
 * plan rows c and seen already checked to be in 0..rows-1 (_law.c's docstring). */
void position_feedforward(PositionLaw* self, double* out, const double* q_row, const double* q,
                          Py_ssize_t c, Py_ssize_t seen, double depth, double blend,
                          int pressing);

/* Adds MemberPeriod and NotForLane to the module (_member.c); 0, or -1 with an exception. */
int add_member_period(PyObject* module);

#endif
