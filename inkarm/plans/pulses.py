"""A recorded stroke's own timing for the LQT: key-points at its speed minima and peaks, at the
times, places and velocities the hand passed them.

A human stroke is a train of speed pulses (submovements) joined at speed minima. With
``timing = "pulses"`` a restyle keeps the recording's timing and re-draws its movement between
them: at the stroke's two ends and at each speed minimum and peak, sample indices
b_0 = 0 < b_1 < ... < b_m = w - 1 at times t_i, the LQT of seed 000 gets a key-point (GI paper
eq. 6-7: a target active at one instant) with the target's covariance, and the recording's
velocity there as a velocity constraint (GI sec. 4.3, as its Bezier mimicking does at a
curve's ends):

    x(t_i) ~ N(mu_i, Sigma_i),   dx/dt(t_i) ~ N(v_i, sigma_v^2 I),

mu_i and v_i the recording's position and velocity (low-passed at the 10 Hz the human measures
use, :data:`inkarm.analysis.humanlike.SMOOTHING_HZ`, with their peak threshold) at t_i.
Between key-points the LQT is free: its control cost alone shapes the movement, so the restyled
stroke keeps the recording's pulses and their timing (a pulse's rise and fall each run between
two key-points), and its jerk is the LQT's, not the tablet's. Key-points at the minima alone
are not enough: where two minima are close and shallow (a hand's minima keep 50-90 % of the
peak speed) the smoothest path between them has no peak, and the pulse is lost (LASA: 13 peaks
per stroke restyled against 16 drawn).

The LQT spaces key-points evenly (one every segment time); uneven ones are written as a key-point
at every time step dt whose covariance is :data:`FREE_VARIANCE` (a precision of 1e-10 per mm^2:
no pull) away from the t_i (:func:`pulse_plan`). The control weight is the one an isochronous
restyle with the same number of targets gets (seed 000 eq. 9-10):

    r = 1 / (omega^n d)^2,   omega = 2 pi (m + 1) / (t_m - t_0).

Units: [mm], [s], [mm/s].
"""

from __future__ import annotations

import numpy as np

from inkarm.analysis.humanlike import PEAK_THRESHOLD, SMOOTHING_HZ
from inkarm.analysis.kinematics import lowpass, speed_pulses
from inkarm.core.plan import StrokePlan
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError
from inkarm.plans.handstyles import PULSE_DT as DT

FREE_VARIANCE = 1e10
"""Covariance [mm^2] of the key-points between the minima: a precision of 1e-10 per mm^2 (the
LQT takes variances up to 1e12), whose pull is negligible beside the control cost."""
VELOCITY_VARIANCE = 1.0
"""sigma_v^2 of the velocity constraints at the key-points [(mm/s)^2]."""
STRETCH_LIMIT = 1.1
"""Key-points closer than a step apart are moved a step on; a restyle whose stroke that
lengthens beyond this factor is refused (the step is too coarse for the recording)."""


def pulse_breakpoints(traj: Trajectory, smoothing_hz: float = SMOOTHING_HZ,
                      threshold: float = PEAK_THRESHOLD) -> np.ndarray:
    """Sample indices b_0 = 0 < ... < b_m = w - 1 of the stroke's ends, of its speed peaks and
    of the speed minima between them (on the positions low-passed at ``smoothing_hz``); a
    stroke without a pulse gets its two ends."""
    pulses = speed_pulses(lowpass(traj, smoothing_hz), threshold)
    cuts = [pulse.end for pulse in pulses[:-1]] + [pulse.peak for pulse in pulses]
    return np.unique(np.array([0, *cuts, traj.n - 1], dtype=np.intp))


def pulse_plan(traj: Trajectory, breakpoints: np.ndarray, covs: np.ndarray, dt: float,
               velocity_variance: float = VELOCITY_VARIANCE) -> StrokePlan:
    """Key-points every ``dt`` [s] over the stroke's duration: at the steps nearest the times of
    ``breakpoints`` the recording's positions with ``covs`` (m + 1, D, D) [mm^2] and its
    velocities; elsewhere free (module docstring). ``meta["pulse_steps"]`` keeps the steps of
    the breakpoints."""
    t = traj.t[breakpoints] - traj.t[0]
    order = np.arange(len(t))  # (minima closer than dt apart: one step after the other)
    steps = np.maximum.accumulate(np.round(t / dt).astype(np.intp) - order) + order
    if steps[-1] * dt > STRETCH_LIMIT * t[-1] + dt:
        raise InputError(f"a step of {dt:g} s is too coarse for the recording's key-points "
                         f"(closest {float(np.min(np.diff(t))):.3g} s apart): the {t[-1]:.3g} s "
                         f"stroke would last {steps[-1] * dt:.3g} s", key="dt", value=dt)
    n_steps, dim = int(steps[-1]) + 1, traj.dim
    grid = np.arange(n_steps) * dt
    means = np.column_stack([np.interp(grid, steps * dt, traj.pos[breakpoints, k])
                             for k in range(dim)])
    free = FREE_VARIANCE * np.eye(dim)
    covariances = np.repeat(free[None], n_steps, axis=0)
    covariances[steps] = covs
    velocities = np.full((n_steps, dim), np.nan)
    velocities[steps] = lowpass(traj, SMOOTHING_HZ).velocity()[breakpoints]  # (as the minima)
    plan = StrokePlan.from_arrays(means, covariances, segment_time=dt, keypoints=True,
                                  meta={"pulse_steps": tuple(steps.tolist())})
    return StrokePlan(plan.targets, dt, True, meta=plan.meta, velocities=velocities,
                      velocity_var=velocity_variance)


def control_weight(order: int, d: float, duration: float, targets: int) -> float:
    """r = 1 / (omega^n d)^2 of ``targets`` targets over ``duration`` [s] (module docstring);
    ``d`` [mm]."""
    omega = 2.0 * np.pi * targets / duration
    return 1.0 / (omega**order * d) ** 2


__all__ = ["DT", "FREE_VARIANCE", "PEAK_THRESHOLD", "SMOOTHING_HZ", "STRETCH_LIMIT",
           "VELOCITY_VARIANCE",
           "control_weight", "pulse_breakpoints", "pulse_plan"]
