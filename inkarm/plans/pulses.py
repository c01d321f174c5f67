"""A recorded stroke's own timing for the LQT: key-points at its speed minima and peaks, at the
times, places and kinematic states the hand passed them.

A human stroke is a train of speed pulses (submovements) joined at speed minima. With
``timing = "pulses"`` a restyle keeps the recording's timing and re-draws its movement between
them: at the stroke's two ends and at each speed minimum and peak, sample indices
b_0 = 0 < b_1 < ... < b_m = w - 1 at times t_i, the LQT of seed 000 gets a key-point (GI paper
eq. 6-7: a target active at one instant) with the target's covariance, the recording's
velocity there as a velocity constraint (GI sec. 4.3, as its Bezier mimicking does at a
curve's ends) and, for an order n >= 3 (whose state holds the acceleration), the recording's
acceleration as a reference on the second derivative (seed 000 eq. 18-19):

    x(t_i) ~ N(mu_i, Sigma_i),   dx/dt(t_i) ~ N(v_i, sigma_v^2 I),   d2x/dt2(t_i) ~ N(a_i, sigma_a^2 I).

The times t_i are the measure's own speed minima and peaks: the pulses of
:func:`inkarm.analysis.kinematics.speed_pulses` on the stroke low-passed at 10 Hz with the
peak threshold of :mod:`inkarm.analysis.humanlike` (:data:`SMOOTHING_HZ`, :data:`PEAK_THRESHOLD`),
so every peak and minimum the measure counts is a key-point. The state (mu_i, v_i, a_i) is the
recording's, under three conditions found on LASA demonstrations 0-4 (130 recordings, 1577
peaks; each restyle, order 3, d 3.16 mm, measured as its recording is):

1. at the time of the step the key-point lands on, t_0 + k_i dt (:func:`_states_at`), not at
   the sample b_i up to half a step away: states taken there are off by v dt / 2 and a dt / 2,
   and between two such key-points a few steps apart the LQT wiggles (31 restyles gained 54
   speed peaks; none with the states at the steps);
2. low-passed at :data:`KEYPOINT_HZ` (50 Hz), not at the measure's 10 Hz: the restyle is
   measured through the 10 Hz low-pass in its turn, and one that follows the 10 Hz trace is
   low-passed twice (98 restyles lost 221 peaks; the 10 Hz low-pass applied twice to the
   recordings loses 231 in 100 of them, applied after the 50 Hz one none);
3. with the acceleration, for an order >= 3 (whose state holds it): the key-point is then the
   speed extremum it is in the recording (d|v|/dt = a . v / |v| = 0) and the path bends as the
   hand's (without it 57 restyles lose 67 peaks, with it 35 lose 40: of the recordings' 41
   pulses then lost, 40 stand out of their minima by less than 1 % of the top speed, and the
   measure's low-pass of the restyle flattens them; 8 restyles gain 8, 6 of them in a stroke's
   first or last pulse, a long stretch free of key-points).

Between key-points the LQT is free: its control cost alone shapes the movement, so the
restyled stroke keeps the recording's pulses and their timing (a pulse's rise and fall each run
between two key-points), and its jerk is the LQT's, not the tablet's. Key-points at the minima
alone are not enough: where two minima are close and shallow (a hand's minima keep 50-90 % of
the peak speed) the smoothest path between them has no peak, and the pulse is lost (LASA: 13
peaks per stroke restyled against 16 drawn).

The LQT spaces key-points evenly (one every segment time); uneven ones are written as a key-point
at every time step dt whose covariance is :data:`FREE_VARIANCE` (a precision of 1e-10 per mm^2:
no pull) away from the t_i (:func:`pulse_plan`). The control weight is the one an isochronous
restyle with the same number of targets gets (seed 000 eq. 9-10):

    r = 1 / (omega^n d)^2,   omega = 2 pi (m + 1) / (t_m - t_0).

Units: [mm], [s], [mm/s], [mm/s^2].
"""

from __future__ import annotations

import numpy as np

from inkarm.analysis.humanlike import PEAK_THRESHOLD, SMOOTHING_HZ
from inkarm.analysis.kinematics import acceleration, lowpass, speed_pulses
from inkarm.core.plan import StrokePlan
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError
from inkarm.plans.handstyles import PULSE_DT as DT

FREE_VARIANCE = 1e10
"""Covariance [mm^2] of the key-points between the minima: a precision of 1e-10 per mm^2 (the
LQT takes variances up to 1e12), whose pull is negligible beside the control cost."""
VELOCITY_VARIANCE = 1.0
"""sigma_v^2 of the velocity constraints at the key-points [(mm/s)^2]."""
ACCELERATION_VARIANCE = 100.0
"""sigma_a^2 of the acceleration references at the key-points [(mm/s^2)^2]: 10 mm/s^2 (on LASA
demonstrations 0-4 the restyles keep the same peaks, within one recording, for sigma_a from 1
to 100 mm/s^2)."""
KEYPOINT_HZ = 50.0
"""Cut-off [Hz] of the low-pass of the recording whose states the key-points take (module
docstring, condition 2): the 10 Hz measure of the 50 Hz trace counts the recording's peaks on
all 130 LASA training recordings (of the 30 Hz one: 126; 20 Hz: 99; 10 Hz: 30)."""
STRETCH_LIMIT = 1.1
"""Key-points closer than a step apart are moved a step on; a restyle whose stroke that
lengthens beyond this factor is refused (the step is too coarse for the recording)."""


def pulse_breakpoints(traj: Trajectory, smoothing_hz: float = SMOOTHING_HZ,
                      threshold: float = PEAK_THRESHOLD) -> np.ndarray:
    """Sample indices b_0 = 0 < ... < b_m = w - 1 of the stroke's ends, of its speed peaks and
    of the speed minima between them (on the positions low-passed at ``smoothing_hz``: the
    peaks and pulses :mod:`inkarm.analysis.humanlike` counts); a stroke without a pulse gets its
    two ends."""
    pulses = speed_pulses(lowpass(traj, smoothing_hz), threshold)
    cuts = [pulse.end for pulse in pulses[:-1]] + [pulse.peak for pulse in pulses]
    return np.unique(np.array([0, *cuts, traj.n - 1], dtype=np.intp))


def pulse_plan(traj: Trajectory, breakpoints: np.ndarray, covs: np.ndarray, dt: float,
               velocity_variance: float = VELOCITY_VARIANCE) -> StrokePlan:
    """Key-points every ``dt`` [s] over the stroke's duration: at the steps nearest the times of
    ``breakpoints`` the recording's positions with ``covs`` (m + 1, D, D) [mm^2] and its
    velocities, at the steps' times (:func:`_states_at`); elsewhere free (module docstring).
    ``meta["pulse_steps"]`` keeps the steps of the breakpoints and
    ``meta["pulse_accelerations"]`` the recording's accelerations there [mm/s^2] (for
    :func:`pulse_references`)."""
    t = traj.t[breakpoints] - traj.t[0]
    order = np.arange(len(t))  # (minima closer than dt apart: one step after the other)
    steps = np.maximum.accumulate(np.round(t / dt).astype(np.intp) - order) + order
    if steps[-1] * dt > STRETCH_LIMIT * t[-1] + dt:
        raise InputError(f"a step of {dt:g} s is too coarse for the recording's key-points "
                         f"(closest {float(np.min(np.diff(t))):.3g} s apart): the {t[-1]:.3g} s "
                         f"stroke would last {steps[-1] * dt:.3g} s", key="dt", value=dt)
    n_steps, dim = int(steps[-1]) + 1, traj.dim
    grid = np.arange(n_steps) * dt
    position, velocity, accel = _states_at(traj, traj.t[0] + steps * dt)
    means = np.column_stack([np.interp(grid, steps * dt, position[:, k]) for k in range(dim)])
    free = FREE_VARIANCE * np.eye(dim)
    covariances = np.repeat(free[None], n_steps, axis=0)
    covariances[steps] = covs
    velocities = np.full((n_steps, dim), np.nan)
    velocities[steps] = velocity
    meta = {"pulse_steps": tuple(steps.tolist()),
            "pulse_accelerations": tuple(map(tuple, accel.tolist()))}
    plan = StrokePlan.from_arrays(means, covariances, segment_time=dt, keypoints=True, meta=meta)
    return StrokePlan(plan.targets, dt, True, meta=plan.meta, velocities=velocities,
                      velocity_var=velocity_variance)


def _states_at(traj: Trajectory, times: np.ndarray) -> tuple[np.ndarray, ...]:
    """Position [mm], velocity [mm/s] and acceleration [mm/s^2] of ``traj`` low-passed at
    :data:`KEYPOINT_HZ`, linearly interpolated at ``times`` [s] (the key-points' steps, within
    half a step of the samples they stand for; clamped to the stroke), each (len(times), D)."""
    smooth = lowpass(traj, KEYPOINT_HZ)
    derivatives = (smooth.pos, smooth.velocity(),
                   acceleration(smooth) if traj.n >= 3 else np.zeros_like(smooth.pos))
    return tuple(np.column_stack([np.interp(times, traj.t, q[:, k]) for k in range(traj.dim)])
                 for q in derivatives)


def pulse_references(plan: StrokePlan, order: int,
                     acceleration_variance: float = ACCELERATION_VARIANCE) -> tuple:
    """The acceleration references of a :func:`pulse_plan` for an LQT of ``order``: one
    :class:`inkarm.models.lqt.Reference` on the second derivative at the key-points' steps,
    precision I / ``acceleration_variance`` [(mm/s^2)^-2]; none below order 3 (the state has no
    acceleration) or for a plan without ``meta["pulse_accelerations"]``."""
    values = plan.meta.get("pulse_accelerations")
    if order < 3 or not values:
        return ()
    from inkarm.models.lqt import Reference

    values = np.asarray(values, dtype=float)
    precision = np.eye(values.shape[1]) / acceleration_variance
    return (Reference(2, precision, values, np.asarray(plan.meta["pulse_steps"])),)


def control_weight(order: int, d: float, duration: float, targets: int) -> float:
    """r = 1 / (omega^n d)^2 of ``targets`` targets over ``duration`` [s] (module docstring);
    ``d`` [mm]."""
    omega = 2.0 * np.pi * targets / duration
    return 1.0 / (omega**order * d) ** 2


__all__ = ["ACCELERATION_VARIANCE", "DT", "FREE_VARIANCE", "KEYPOINT_HZ", "PEAK_THRESHOLD",
           "SMOOTHING_HZ", "STRETCH_LIMIT", "VELOCITY_VARIANCE",
           "control_weight", "pulse_breakpoints", "pulse_plan", "pulse_references"]
