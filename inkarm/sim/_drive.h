/* The joint drive's set point arithmetic (inkarm/sim/drive.py: JointDrive.set_point's integral
 * and affine_control), one joint at a time, shared by the plant's compiled period (_period.c)
 * and the batched plant's substeps (_batch.c): the same operations in NumPy's order, so the
 * same bits (with -ffp-contract=off). Gains are laid out (5, n): K_p, K_d, K_i, K_p h, the
 * integral's limit (DRIVE_KP .. DRIVE_LIMIT rows). */
#ifndef INKARM_DRIVE_H
#define INKARM_DRIVE_H

enum { DRIVE_KP, DRIVE_KD, DRIVE_KI, DRIVE_KP_H, DRIVE_LIMIT };

/* I <- clip(I + K_i s (q* + qd* s - q_link), +-limit), at a new set point s after the old one;
 * np.maximum, np.minimum: NaN stays NaN; of two equal values the second (signed 0). */
static inline double drive_integral(double integral, double q_old, double qd_old,
                                    double q_link, double ki, double since, double limit) {
  double x = q_old + qd_old * since;
  x = x - q_link;
  x = x * (ki * since);
  x = x + integral;
  const double floor = -limit;
  x = (x > floor || x != x) ? x : floor;
  return (x < limit || x != x) ? x : limit;
}

/* The affine actuator's control u = K_p q* + ((K_d qd* + tau_ff) + I) and its rise per physics
 * step du = K_p h qd*. */
static inline void drive_affine(double kp, double kd, double kp_h, double q, double qd,
                                double tau_ff, double integral, double* u, double* du) {
  double rest = kd * qd;
  rest = rest + tau_ff;
  rest = rest + integral;
  *u = kp * q + rest;
  *du = kp_h * qd;
}

#endif
