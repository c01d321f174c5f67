"""Sigma-lognormal fit of a speed profile (Plamondon's kinematic theory of rapid movements).

The speed of a stroke is modelled as a sum of lognormal impulse responses, one per speed
pulse (Plamondon 1995, Part I; Plamondon et al. 2014; seed 002, sec. 2.2.2;
seed 000 refs. [33, 37, 38])::

    |v|(t) = sum_i D_i / (sigma_i sqrt(2 pi) (t - t0_i)) exp(-(ln(t - t0_i) - mu_i)^2 / (2 sigma_i^2))

for t > t0_i (0 before), with D_i the distance travelled by lognormal i [mm], t0_i its time of
occurrence [s], mu_i its log time delay [ln s] and sigma_i its log response time. The sum of
speed magnitudes is the usual approximation of the vector sum for pulses that overlap little.

The fit is nonlinear least squares (``scipy.optimize.least_squares``, trust region
reflective, bounds D > 0, 0.05 <= sigma <= 3, t0 before the pulse's peak) started with one
lognormal per speed pulse (:func:`inkarm.analysis.kinematics.speed_pulses`): sigma 0.3, the
mode exp(mu - sigma^2) placed on the pulse's peak with the lognormal's onset (3 sigma below
mu) on the pulse's start, and D the area of the pulse. Its quality is the signal-to-noise
ratio of the reconstruction (Plamondon et al. 2014; O'Reilly and Plamondon 2009)::

    SNR = 10 log10( integral v^2 dt / integral (v - v_hat)^2 dt )   [dB]

Reconstructions of human handwriting are usually accepted from about 15 to 25 dB; LASA's
demonstrations (low-passed at 10 Hz) reach 33.4 [30.0, 36.0] dB, median [IQR].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from inkarm.analysis.kinematics import speed, speed_pulses
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError

SIGMA_START = 0.3
"""Log response time every lognormal starts from."""
SIGMA_BOUNDS = (0.05, 3.0)
"""Bounds of sigma during the fit."""


@dataclass(frozen=True)
class Lognormal:
    """One lognormal speed pulse: D [mm], t0 [s], mu [ln s], sigma (dimensionless)."""

    d: float
    t0: float
    mu: float
    sigma: float

    @property
    def peak_time(self) -> float:
        """Time of the pulse's maximum, t0 + exp(mu - sigma^2), in [s]."""
        return self.t0 + math.exp(self.mu - self.sigma**2)

    def speed(self, t: np.ndarray) -> np.ndarray:
        """The pulse's speed [mm/s] at the times ``t`` [s] (0 up to t0)."""
        return _lognormal(np.asarray(t, dtype=float), self.d, self.t0, self.mu, self.sigma)


@dataclass(frozen=True)
class LognormalFit:
    """A fitted sigma-lognormal speed profile.

    Attributes:
        pulses: The lognormals, one per speed pulse of the stroke, in time order of start.
        snr_db: Signal-to-noise ratio of the reconstruction in [dB] (module docstring).
    """

    pulses: tuple[Lognormal, ...]
    snr_db: float

    def speed(self, t: np.ndarray) -> np.ndarray:
        """The reconstructed speed [mm/s] at the times ``t`` [s]."""
        t = np.asarray(t, dtype=float)
        return sum((p.speed(t) for p in self.pulses), np.zeros_like(t))


def _lognormal(t: np.ndarray, d: float, t0: float, mu: float, sigma: float) -> np.ndarray:
    dt = t - t0
    out = np.zeros_like(t)
    after = dt > 0
    x = dt[after]
    out[after] = d / (sigma * math.sqrt(2 * math.pi) * x) * np.exp(
        -((np.log(x) - mu) ** 2) / (2 * sigma**2))
    return out


def _jacobian(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """d model / d (D, t0, mu, sigma) of every lognormal, shape (N, 4 n): with g the unit
    lognormal (D = 1), x = t - t0 and z = (ln x - mu) / sigma: dL/dD = g, dL/dt0 =
    L (1 + z / sigma) / x, dL/dmu = L z / sigma, dL/dsigma = L (z^2 - 1) / sigma."""
    jac = np.zeros((t.size, x.size))
    for k, (d, t0, mu, sigma) in enumerate(x.reshape(-1, 4)):
        g = _lognormal(t, 1.0, t0, mu, sigma)
        after = t > t0
        dt = np.where(after, t - t0, 1.0)
        z = (np.log(dt) - mu) / sigma
        big = d * g
        jac[:, 4 * k] = g
        jac[:, 4 * k + 1] = np.where(after, big * (1.0 + z / sigma) / dt, 0.0)
        jac[:, 4 * k + 2] = big * z / sigma
        jac[:, 4 * k + 3] = big * (z * z - 1.0) / sigma
    return jac


def snr_db(v: np.ndarray, v_hat: np.ndarray, t: np.ndarray) -> float:
    """10 log10(integral v^2 dt / integral (v - v_hat)^2 dt) in [dB] (trapezoidal rule);
    inf for an exact reconstruction."""
    signal = float(np.trapezoid(v * v, t))
    noise = float(np.trapezoid((v - v_hat) ** 2, t))
    if signal <= 0:
        raise InputError("snr_db: the speed is zero throughout; nothing to reconstruct")
    return math.inf if noise <= 0 else 10.0 * math.log10(signal / noise)


def initial_guess(traj: Trajectory, threshold: float = 0.1) -> list[Lognormal]:
    """One lognormal per speed pulse (module docstring), before any fitting."""
    t, v = traj.t, speed(traj)
    out = []
    for pulse in speed_pulses(traj, threshold):
        rise = max(float(t[pulse.peak] - t[pulse.start]), float(np.min(np.diff(t))))
        sigma = SIGMA_START
        # onset/mode = exp(-3 sigma + sigma^2): the mode m satisfies m (1 - onset/mode) = rise
        mode = rise / (1.0 - math.exp(-3 * sigma + sigma**2))
        area = float(np.trapezoid(v[pulse.start:pulse.end + 1], t[pulse.start:pulse.end + 1]))
        out.append(Lognormal(d=max(area, 1e-9), t0=float(t[pulse.peak]) - mode,
                             mu=math.log(mode) + sigma**2, sigma=sigma))
    return out


def fit_sigma_lognormal(traj: Trajectory, threshold: float = 0.1,
                        max_evaluations: int = 200) -> LognormalFit:
    """Fit the sigma-lognormal model to the speed of ``traj`` (module docstring).

    Args:
        traj: One stroke; sample it finely (dt <= 10 ms) and smooth it first if it is noisy
            (:func:`inkarm.analysis.kinematics.lowpass`).
        threshold: Speed peaks below this fraction of the maximum speed get no lognormal.
        max_evaluations: Bound on the residual evaluations of the least-squares solver.

    Raises:
        InputError: a stroke whose speed has no peak (a constant-speed or still trace).
    """
    from scipy.optimize import least_squares

    start = initial_guess(traj, threshold)
    if not start:
        raise InputError("fit_sigma_lognormal: the speed has no peak to fit (a still or "
                         "constant-speed stroke)")
    t, v = traj.t, speed(traj)
    scale = float(np.max(v))
    x0, low, high = [], [], []
    for p, pulse in zip(start, speed_pulses(traj, threshold)):
        t_peak = float(t[pulse.peak])
        span = float(t[-1] - t[0]) + 1.0
        x0 += [p.d, p.t0, p.mu, p.sigma]
        low += [0.0, t_peak - span, -20.0, SIGMA_BOUNDS[0]]
        high += [np.inf, t_peak - 1e-6, 5.0, SIGMA_BOUNDS[1]]
    x0 = np.clip(np.array(x0), np.array(low) + 1e-12, np.array(high) - 1e-12)

    def model(x: np.ndarray) -> np.ndarray:
        total = np.zeros_like(t)
        for d, t0, mu, sigma in x.reshape(-1, 4):
            total += _lognormal(t, d, t0, mu, sigma)
        return total

    result = least_squares(lambda x: (model(x) - v) / scale, x0, bounds=(low, high),
                           jac=lambda x: _jacobian(t, x) / scale, method="trf", tr_solver="lsmr",
                           max_nfev=max_evaluations, x_scale="jac")
    pulses = tuple(Lognormal(*map(float, row)) for row in result.x.reshape(-1, 4))
    return LognormalFit(pulses=pulses, snr_db=snr_db(v, model(result.x), t))
