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
from itertools import pairwise

import numpy as np

from inkarm.analysis.butterworth import butter_sections, filtfilt_odd
from inkarm.analysis.peaks import find_peaks
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


PEAK_PROMINENCE = 1e-6
"""Smallest prominence of a speed peak, as a fraction of the top speed."""


def speed_peaks(traj: Trajectory, threshold: float = 0.1) -> int:
    """Number of local maxima of the speed higher than ``threshold`` times its maximum.

    A plateau counts once; a maximum at the first or last sample does not count, nor one that
    stands out by less than :data:`PEAK_PROMINENCE` of the maximum (rounding noise on a
    constant speed).
    """
    return int(speed_peak_indices(traj, threshold).size)


def speed_peak_indices(traj: Trajectory, threshold: float = 0.1,
                       prominence: float = PEAK_PROMINENCE) -> np.ndarray:
    """Sample indices (int, increasing) of the speed peaks that :func:`speed_peaks` counts,
    or, with a larger ``prominence`` (a fraction of the top speed), of those that stand out
    of the speed minima on both sides by that much (scipy.signal.peak_prominences)."""
    if not 0.0 <= threshold < 1.0:
        raise InputError(f"speed_peaks threshold: expected a fraction in [0, 1), got {threshold}",
                         key="threshold", value=threshold)
    v = speed(traj)
    vmax = float(np.max(v)) if v.size else 0.0
    if vmax <= 0:
        return np.zeros(0, dtype=int)
    if not 0.0 <= prominence < 1.0:
        raise InputError(f"speed peak prominence: expected a fraction in [0, 1), got "
                         f"{prominence}", key="prominence", value=prominence)
    peaks = find_peaks(v, height=threshold * vmax,
                       prominence=max(prominence, PEAK_PROMINENCE) * vmax)
    return peaks.astype(int)


@dataclass(frozen=True)
class SpeedPulse:
    """One speed pulse: sample indices of its start, peak and end.

    The pulse around a speed peak runs from the speed minimum between it and the previous peak
    (or the stroke's first sample) to the minimum before the next peak (or the last sample).
    """

    start: int
    peak: int
    end: int

    def asymmetry(self, t: np.ndarray) -> float:
        """(t_peak - t_start) / (t_end - t_start): 0.5 for a symmetric pulse (minimum jerk),
        below 0.5 when the pulse rises faster than it falls (a lognormal)."""
        return float((t[self.peak] - t[self.start]) / (t[self.end] - t[self.start]))


def speed_pulses(traj: Trajectory, threshold: float = 0.1,
                 prominence: float = PEAK_PROMINENCE) -> list[SpeedPulse]:
    """The pulses around the speed peaks of :func:`speed_peak_indices`, in time order;
    consecutive pulses share their boundary sample."""
    peaks = speed_peak_indices(traj, threshold, prominence)
    if peaks.size == 0:
        return []
    v = speed(traj)
    bounds = [0] + [int(a + np.argmin(v[a:b])) for a, b in pairwise(peaks)]
    bounds.append(traj.n - 1)
    return [SpeedPulse(bounds[i], int(p), bounds[i + 1]) for i, p in enumerate(peaks)]


def path_length(traj: Trajectory) -> float:
    """Length of the polyline through the samples, in [mm]."""
    return float(np.sum(np.linalg.norm(np.diff(traj.pos, axis=0), axis=1)))


def normalised_jerk(traj: Trajectory) -> float:
    """Dimensionless jerk sqrt(1/2 * integral |d^3x/dt^3|^2 dt * T^5 / L^2), T the duration
    [s] and L the path length [mm] (Teulings et al. 1997, with L the amplitude).

    Independent of size and duration; a minimum-jerk point-to-point movement has sqrt(360)
    = 18.97 (its cost is 720 L^2 / T^5, :func:`jerk_cost`).
    """
    length = path_length(traj)
    if length <= 0:
        raise InputError("normalised_jerk: the pen does not move (path length 0 mm)")
    duration = float(traj.t[-1] - traj.t[0])
    return float(np.sqrt(0.5 * jerk_cost(traj) * duration**5 / length**2))


def lowpass(traj: Trajectory, cutoff_hz: float, order: int = 2) -> Trajectory:
    """The positions low-pass filtered forwards and backwards (zero phase) by a Butterworth
    filter of ``order`` with its -3 dB point at ``cutoff_hz`` [Hz] (the filtfilt'ed response
    is -6 dB there), on the mean sampling rate (:mod:`inkarm.analysis.butterworth`: SciPy's
    butter and filtfilt in NumPy); velocities and pressure are dropped (the
    derivatives then come from the filtered positions). The ends are padded by point
    reflection (odd extension) over the stroke's length, so a line at constant speed is kept.

    Returned unchanged when the cutoff is at or above the Nyquist frequency (nothing to
    remove) or the stroke is too short for the filter's padding (3 (order + 1) samples).
    """
    if not (np.isfinite(cutoff_hz) and cutoff_hz > 0):
        raise InputError(f"lowpass cutoff: expected a positive frequency in Hz, got {cutoff_hz}",
                         key="cutoff_hz", value=cutoff_hz)
    if order not in range(1, 9):
        raise InputError(f"lowpass order: expected 1 to 8, got {order}", key="order", value=order)
    if traj.n <= 3 * (order + 1):
        return traj
    dt = float(traj.t[-1] - traj.t[0]) / (traj.n - 1)
    wn = 2.0 * cutoff_hz * dt  # fraction of the Nyquist frequency
    if wn >= 1.0:
        return traj
    # Padded by point reflection about each end over the whole stroke: a straight line at
    # constant speed comes out exact (the default 3 (order + 1) samples leave the filter's
    # start-up transient in the first and last tenths of a second: false speed peaks).
    return Trajectory(t=traj.t, pos=filtfilt_odd(butter_sections(order, wn), traj.pos,
                                                 padlen=traj.n - 1))


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
    return fit_log_log(*power_law_samples(traj, min_speed, max_radius))


def power_law_samples(
    traj: Trajectory, min_speed: float = 0.05, max_radius: float = 1e3
) -> tuple[np.ndarray, np.ndarray]:
    """(log r, log v) of the samples :func:`power_law_fit` keeps, r in [mm], v in [mm/s]; the
    samples of several strokes are pooled by concatenating them before :func:`fit_log_log`."""
    if not 0.0 <= min_speed < 1.0:
        raise InputError(f"power_law_fit min_speed: expected a fraction in [0, 1), got {min_speed}")
    if not max_radius > 0:
        raise InputError(
            f"power_law_fit max_radius: expected a positive length in mm, got {max_radius}"
        )
    v = speed(traj)
    kappa = np.abs(curvature(traj))
    keep = np.isfinite(kappa) & (v > min_speed * np.max(v)) & (kappa > 1.0 / max_radius)
    return np.log(1.0 / kappa[keep]), np.log(v[keep])


def fit_log_log(x: np.ndarray, y: np.ndarray) -> PowerLawFit:
    """Ordinary least squares y = log k + beta x of log speeds ``y`` on log radii ``x``."""
    if x.size < 3:
        raise InputError(
            f"power_law_fit: only {x.size} samples are curved and moving enough "
            "to fit; need at least 3"
        )
    if np.ptp(x) < 1e-4:
        raise InputError(
            "power_law_fit: the radius of curvature is constant (within 0.01 %); beta is undefined"
        )
    design = np.column_stack([np.ones_like(x), x])
    (log_k, beta), *_ = np.linalg.lstsq(design, y, rcond=None)
    residual = y - design @ np.array([log_k, beta])
    total = np.sum((y - y.mean()) ** 2)
    r2 = 1.0 - float(residual @ residual) / float(total) if total > 0 else 1.0
    return PowerLawFit(k=float(np.exp(log_k)), beta=float(beta), r2=r2, n=int(x.size))
