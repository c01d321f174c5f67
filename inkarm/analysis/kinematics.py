"""Measures of human-likeness of a pen trajectory: speed, curvature, jerk, speed peaks and the
speed-curvature power law.

Derivatives come from the trajectory's stored velocity when it has one, otherwise from
second-order finite differences of the positions (:meth:`Trajectory.velocity`, the one
definition of velocity and speed in inkarm); higher derivatives are the same finite
differences (:func:`inkarm.core.trajectory.time_derivative`) of the velocity. Sample finely
(dt of 10 ms or less) for accurate curvature and jerk.

Units: positions in [mm], times in [s]; speed in [mm/s], curvature in [1/mm], jerk cost in
[mm^2/s^5].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import find_peaks

from inkarm.core.trajectory import Trajectory, time_derivative
from inkarm.errors import InputError


def _finite(values: np.ndarray, what: str, traj: Trajectory) -> np.ndarray:
    """``values`` if finite; else an InputError: sample times too close (or positions too far
    apart) for the finite differences to stay within floating point."""
    if not np.all(np.isfinite(values)):
        i = int(np.argwhere(~np.isfinite(values))[0][0])
        raise InputError(
            f"{what}: overflows at sample {i} (t = {traj.t[i]:g} s); the sample times are too "
            f"close for finite differences (smallest step {float(np.min(np.diff(traj.t))):g} s)",
            value=float(traj.t[i]),
        )
    return values


def _derivative(values: np.ndarray, traj: Trajectory, what: str) -> np.ndarray:
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        return _finite(time_derivative(values, traj.t), what, traj)


def _velocity(traj: Trajectory) -> np.ndarray:
    if traj.vel is not None:
        return traj.vel
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        return _finite(traj.velocity(), "velocity", traj)


def _check_samples(traj: Trajectory, minimum: int, what: str) -> None:
    if traj.n < minimum:
        raise InputError(f"{what}: needs at least {minimum} samples, the trajectory has {traj.n}")


def speed(traj: Trajectory) -> np.ndarray:
    """Tangential speed |dx/dt| in [mm/s], shape (N,): :meth:`Trajectory.speed`, refusing a
    single sample."""
    _check_samples(traj, 2, "speed")
    return np.linalg.norm(_velocity(traj), axis=1)


def acceleration(traj: Trajectory) -> np.ndarray:
    """d^2x/dt^2 in [mm/s^2], shape (N, D)."""
    _check_samples(traj, 3, "acceleration")
    return _derivative(_velocity(traj), traj, "acceleration")


def jerk(traj: Trajectory) -> np.ndarray:
    """d^3x/dt^3 in [mm/s^3], shape (N, D)."""
    _check_samples(traj, 4, "jerk")
    return _derivative(acceleration(traj), traj, "jerk")


def curvature(traj: Trajectory) -> np.ndarray:
    """Curvature in [1/mm], shape (N,): signed in 2-D, kappa = (x' y'' - y' x'') / |v|^3
    (positive when turning left), and the magnitude |v x a| / |v|^3 in 3-D.

    Where the pen stands still (|v| = 0) the curvature is undefined and returned as NaN.
    """
    _check_samples(traj, 3, "curvature")
    v = _velocity(traj)
    a = acceleration(traj)
    if traj.dim not in (2, 3):
        raise InputError(f"curvature: needs a 2-D or 3-D trajectory, got D = {traj.dim}")
    # Where |v|^3 or the cross product overflows the curvature is returned as NaN too.
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        if traj.dim == 2:
            cross = v[:, 0] * a[:, 1] - v[:, 1] * a[:, 0]
        else:
            cross = np.linalg.norm(np.cross(v, a), axis=1)
        s3 = np.linalg.norm(v, axis=1) ** 3
        kappa = np.where(s3 > 0, cross / s3, np.nan)
    return np.where(np.isfinite(s3) & np.isfinite(cross), kappa, np.nan)


def jerk_cost(traj: Trajectory) -> float:
    """Integral over time of the squared jerk |d^3x/dt^3|^2, in [mm^2/s^5] (trapezoidal rule).

    The minimum-jerk movement of amplitude A in time T has cost 720 A^2 / T^5.
    """
    j = jerk(traj)
    with np.errstate(over="ignore"):
        cost = float(np.trapezoid(np.sum(j * j, axis=1), traj.t))
    if not np.isfinite(cost):
        raise InputError(f"jerk_cost: overflows ({cost}); the jerk is too large for floating "
                         "point (sample times too close?)")
    return cost


def speed_peaks(traj: Trajectory, threshold: float = 0.1) -> int:
    """Number of local maxima of the speed higher than ``threshold`` times its maximum.

    A plateau counts once; a maximum at the first or last sample does not count.
    """
    if not 0.0 <= threshold < 1.0:
        raise InputError(f"speed_peaks threshold: expected a fraction in [0, 1), got {threshold}")
    v = speed(traj)
    vmax = float(np.max(v)) if v.size else 0.0
    if vmax <= 0:
        return 0
    peaks, _ = find_peaks(v, height=threshold * vmax)
    return int(peaks.size)


@dataclass(frozen=True)
class PowerLawFit:
    """v = k r^beta fitted in log-log space.

    Attributes:
        k: Gain in [mm^(1 - beta)/s].
        beta: Exponent (about 1/3 for human drawing: the "two-thirds power law").
        r2: Coefficient of determination of the log-log fit.
        n: Number of samples used.
    """

    k: float
    beta: float
    r2: float
    n: int


def power_law_fit(
    traj: Trajectory,
    min_speed: float = 0.05,
    max_radius: float = 1e3,
) -> PowerLawFit:
    """Least-squares fit of log v = log k + beta log r, with r = 1 / |kappa| the radius of
    curvature in [mm].

    Samples are left out where the speed is below ``min_speed`` times its maximum (the pen
    starting or stopping) or where the path is nearly straight, r > ``max_radius`` [mm]
    (inflections, where log r blows up).
    """
    if not 0.0 <= min_speed < 1.0:
        raise InputError(f"power_law_fit min_speed: expected a fraction in [0, 1), got {min_speed}")
    if not max_radius > 0:
        raise InputError(
            f"power_law_fit max_radius: expected a positive length in mm, got {max_radius}"
        )
    v = speed(traj)
    kappa = np.abs(curvature(traj))
    keep = np.isfinite(kappa) & (v > min_speed * np.max(v)) & (kappa > 1.0 / max_radius)
    if np.count_nonzero(keep) < 3:
        raise InputError(
            f"power_law_fit: only {np.count_nonzero(keep)} samples are curved and moving enough "
            "to fit; need at least 3"
        )
    x = np.log(1.0 / kappa[keep])
    y = np.log(v[keep])
    if np.ptp(x) < 1e-4:
        raise InputError(
            "power_law_fit: the radius of curvature is constant (within 0.01 %); beta is undefined"
        )
    design = np.column_stack([np.ones_like(x), x])
    (log_k, beta), *_ = np.linalg.lstsq(design, y, rcond=None)
    residual = y - design @ np.array([log_k, beta])
    total = np.sum((y - y.mean()) ** 2)
    r2 = 1.0 - float(residual @ residual) / float(total) if total > 0 else 1.0
    return PowerLawFit(k=float(np.exp(log_k)), beta=float(beta), r2=r2, n=int(keep.sum()))
