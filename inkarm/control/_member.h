/* What the two sources of the member's compiled period share (_member.c: one member's period;
 * _member_batch.c: a batch's members' periods in one call): its state and its steps. */
#ifndef INKARM_MEMBER_H
#define INKARM_MEMBER_H
#include "_law.h"

enum { V_QREF, V_NORMAL, V_STEP, V_PX, V_PY, V_PHASE, V_HOLD, V_LTIME, V_LQ, V_LQD, V_LTORQUE,
       V_LTIP, V_LFORCE, V_COMMANDED, V_REFROW, V_BLEND, V_QD, NV };

typedef struct {
  PyObject_HEAD
  Py_buffer v[NV];          /* (obj NULL: not held) */
  Py_ssize_t n, rows, capacity;
  PyObject *qd_ref, *qdd_ref;   /* (rows, n): their rows are the command's qd, qdd (views) */
  PositionLaw* law;
  PyObject *check, *plane, *search_failed, *hypot, *empty, *command_type, *n_obj;
  int approach, descend, draw, home;
  int lookahead_rows, lookahead, senses_force, settle_ticks, timeout_ticks;
  double dt, t_first;
  int has_t_first;
  /* the force loop (ForceLoop's attributes) */
  double smoothing, threshold, k_force, f_star, z_limit, search_step, settle_tol;
  double k_inv, rate_smoothing, inv_dt, lead_gain;
  int sampling;
  double z, force, rate, lead, h_prev;
  int has_h_prev;
  double* depths;               /* ring of lag (d, x, y), oldest at head */
  int lag, head;
  /* the plane (SurfaceEstimate's) */
  double sums[9], coef[3], origin[2], prior;
  long count, refit_every;
  int has_origin;
  /* the watchdogs' cheap test (4 n: mid, half, speed, effort; NULL: Python every period) */
  double* envelope;
  double force_limit, tracking_limit;
  int dirty;
  /* where the member is: the plan row, the log row, the descent's hold, the pending advance */
  Py_ssize_t i, row, next_i;
  int waited, settled_for, next_waited, next_settled, logged, fresh;
  double force_f;
  double* scratch;              /* q_row, and run()'s reading (q, qd, torque, tip), goal, tau_ff */
} MemberPeriod;

/* A reading: the state object's arrays (period()) or the port's (run(): the objects NULL,
 * made only for the watchdogs in Python). */
typedef struct {
  double time, force;
  const double *q, *qd, *torque, *tip;
  PyObject *q_o, *qd_o, *torque_o;
} Reading;

extern PyTypeObject MemberPeriodType;

/* 0 where the member can take a period; -1 with an error (not initialised, past its plan or
 * its log). */
int period_ready(MemberPeriod* self);

/* The period's steps 2-4 on reading r: the goal q* and tau_ff into goal and feedforward (n
 * each), the commanded plan row into *c_out, the log row written, the advance after the step
 * pending. 0, or -1 with the fault (a watchdog's, the search's) or an error set. */
int period_steps(MemberPeriod* self, const Reading* r, double* goal, double* feedforward,
                 Py_ssize_t* c_out);

/* The member on to the plan row after its period's step (the hold's counters with it). */
void period_advance(MemberPeriod* self);

/* Adds periods() (_member_batch.c) to the module; 0, or -1 with an exception. */
int add_batch_periods(PyObject* module);

#endif
