/* A plant's control period as C functions: the seam between a compiled controller
 * (inkarm/control/_member.c) and a compiled plant (inkarm/sim/_period.c), the C face of
 * inkarm.core.plant.Plant's read / command / step. A plant offers it in a PyCapsule named
 * INKARM_PLANT_CAPSULE (see inkarm.sim.compiled.Port); the consumer calls it with the GIL held,
 * between the provider's enter() and leave(), which hand the plant's Python state over and back.
 *
 * Units as the Plant protocol's: SI joints [rad, rad/s, N m], the tip in page [mm], force [N],
 * time [s]. Every function returns 0, or -1 with a Python exception set (MuJoCo's fatal error,
 * the plant's divergence fault, ...).
 */
#ifndef INKARM_PLANT_H
#define INKARM_PLANT_H

#define INKARM_PLANT_ABI 1
#define INKARM_PLANT_CAPSULE "inkarm.plant"

typedef struct {
  int abi;      /* INKARM_PLANT_ABI */
  void* self;   /* the provider's object (alive as long as the capsule's owner) */
  int n;        /* joints */
  /* the reading now: time, q (n), qd (n), torque (n), tip (x, y, z), pen force */
  int (*read)(void* self, double* time, double* q, double* qd, double* torque, double* tip,
              double* force);
  /* position goals for the coming period: q (n), qd (n), torque feed-forward (n) */
  int (*command)(void* self, const double* q, const double* qd, const double* tau_ff);
  /* one control period */
  int (*step)(void* self);
} inkarm_plant;

#endif
