"""Flash-Hogan minimum-jerk trajectories: the profile, point to point, and one via-point.

The minimum-jerk model (Flash & Hogan 1985) picks, among all paths from rest to rest in a
given time, the one that minimises the jerk cost

    J = integral_0^tf |d^3 x / dt^3|^2 dt                      (seed 002 eq. 2.3, without the 1/2)

Point to point, the optimum is the quintic of seed 002 eq. 3.1,

    x(t) = x0 + (xf - x0) s(tau),  s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5,  tau = t / tf,

(:func:`minimum_jerk_profile`, the one implementation of s in inkarm), whose bell-shaped speed
peaks at tf/2 with V_max = 1.875 A / tf (seed 002 eq. 3.2), and whose
cost is J = 720 A^2 / tf^5. (Seed 002 writes the polynomial as
(x0 - xf)(15 tau^4 - 6 tau^5 - 10 tau^3): the same thing with both signs flipped.)

Through via-points the optimum is a piecewise quintic, C^4 at each via-point (only the
fifth derivative jumps; several via-points: :mod:`inkarm.models.minjerk_spline`). With one
via-point u = x1 - x0 reached at tau1, and v = xf - x0,

    J(tau1) = [720 |v|^2 + 20 |u - v s(tau1)|^2 / (tau1^5 (1 - tau1)^5)] / tf^5,

and setting dJ/dtau1 = 0 gives the polynomial of degree 9 that the GI paper (seed 000,
sec. 4.2) solves for the via time (see :func:`via_time_polynomial`).

Units: positions in [mm], times in [s].
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import Polynomial

from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError

PEAK_SPEED_RATIO = 1.875  # seed 002 eq. 3.2: V_max = C A / t_f with C = 15/8


def minimum_jerk_profile(tau, derivative: int = 0) -> np.ndarray:
    """The normalised minimum-jerk profile s(tau) (seed 002 eq. 3.1, Flash & Hogan 1985):

        s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5,   tau = t / t_f in [0, 1],

    the fraction of the movement covered at tau: 0 at tau = 0, 1 at tau = 1, with zero velocity
    and acceleration at both ends. ``derivative`` k = 1..3 gives d^k s / d tau^k instead
    (divide by t_f^k [s^k] for a time derivative):

        s'   = 30 tau^2 (1 - tau)^2
        s''  = 60 tau (1 - tau) (1 - 2 tau)
        s''' = 60 - 360 tau + 360 tau^2

    tau outside [0, 1] is clamped: at rest before and after (s = 0 or 1, derivatives 0).

    Args:
        tau: Normalised times, any shape (dimensionless).
        derivative: k in 0..3.
    Returns:
        s^(k)(tau), the shape of ``tau``.
    """
    if isinstance(derivative, bool) or derivative not in (0, 1, 2, 3):
        raise InputError(
            f"expected 0, 1, 2 or 3, got {derivative!r}", key="derivative", value=derivative
        )
    tau = np.asarray(tau, dtype=float)
    if np.isnan(tau).any():
        raise InputError("contains NaN; expected normalised times in [0, 1]", key="tau", value=tau)
    x = np.clip(tau, 0.0, 1.0)
    if derivative == 0:
        return x**3 * (10.0 - 15.0 * x + 6.0 * x**2)
    if derivative == 1:
        out = 30.0 * x**2 * (1.0 - x) ** 2
    elif derivative == 2:
        out = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x)
    else:
        out = 60.0 - 360.0 * x + 360.0 * x**2
    return np.where((tau < 0.0) | (tau > 1.0), 0.0, out)


def peak_speed(amplitude: float, duration: float) -> float:
    """Peak speed in [mm/s] of a point-to-point movement of ``amplitude`` [mm] in ``duration`` [s]."""
    return PEAK_SPEED_RATIO * amplitude / duration  # seed 002 eq. 3.2


def _point(name: str, value, dim: int | None = None) -> np.ndarray:
    p = np.asarray(value, dtype=float)
    if p.ndim != 1 or not 1 <= p.shape[0] <= 3:
        raise InputError(f"expected 1 to 3 coordinates in mm, got shape {p.shape}", key=name,
                         value=value)
    if dim is not None and p.shape[0] != dim:
        raise InputError(f"has {p.shape[0]} coordinates, expected {dim}", key=name, value=value)
    if not np.all(np.isfinite(p)):
        raise InputError(f"NaN or inf in {p.tolist()}", key=name, value=value)
    return p


def check_positive(name: str, value: float) -> float:
    """``value`` as a float; InputError naming ``name`` unless it is finite and > 0."""
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise InputError(f"must be a positive number, got {value}", key=name, value=value)
    return v


def time_grid(duration: float, dt: float) -> np.ndarray:
    """Samples 0, dt, 2 dt, ... ending exactly at ``duration`` (last step possibly shorter)."""
    dt = check_positive("dt", dt)
    n = max(int(np.ceil(duration / dt - 1e-9)), 1)
    t = np.minimum(np.arange(n + 1) * dt, duration)
    t[-1] = duration
    return t


def point_to_point(start, end, duration: float, dt: float = 0.01) -> Trajectory:
    """Minimum-jerk movement from rest at ``start`` to rest at ``end`` [mm] in ``duration`` [s].

    Seed 002 eq. 3.1 (without the squiggle term D, see :mod:`inkarm.models.human_line`),
    sampled every ``dt`` [s]; the returned velocity is the exact derivative.
    """
    x0 = _point("start", start)
    xf = _point("end", end, x0.shape[0])
    tf = check_positive("duration", duration)
    t = time_grid(tf, dt)
    tau = t / tf
    pos = x0 + np.outer(minimum_jerk_profile(tau), xf - x0)  # eq. 3.1
    vel = np.outer(minimum_jerk_profile(tau, 1) / tf, xf - x0)
    return Trajectory(t=t, pos=pos, vel=vel)


# -- one via-point: closed forms --------------------------------------------------------------


def via_jerk_cost(start, via, end, duration: float, t_via: float) -> float:
    """Jerk cost in [mm^2/s^5] of the minimum-jerk path through ``via`` at time ``t_via`` [s].

    J = [720 |v|^2 + 20 |u - v s(tau1)|^2 / (tau1^5 (1 - tau1)^5)] / tf^5, with u = via - start,
    v = end - start, tau1 = t_via / tf. The first term is the point-to-point cost; the second
    is the miss u - v s(tau1) of that movement at tau1, squared, over G(tau1, tau1) =
    tau1^5 (1 - tau1)^5 / 20, the diagonal of the Green's function of d^6/dtau^6 with
    position, velocity and acceleration clamped at both ends (our derivation; checked against
    the piecewise-quintic solution in the tests).
    """
    x0 = _point("start", start)
    u = _point("via", via, x0.shape[0]) - x0
    v = _point("end", end, x0.shape[0]) - x0
    tf = check_positive("duration", duration)
    tau1 = float(t_via) / tf
    if not 0.0 < tau1 < 1.0:
        raise InputError(f"must lie strictly inside (0, {tf}) s, got {t_via}", key="t_via",
                         value=t_via)
    s1 = minimum_jerk_profile(tau1)
    miss = u - v * s1
    return float(720.0 * v @ v + 20.0 * miss @ miss / (tau1 * (1.0 - tau1)) ** 5) / tf**5


def via_time_polynomial(start, via, end) -> Polynomial:
    """The degree-9 polynomial in tau1 = t_via / tf whose real roots in (0, 1) are the stationary
    points of the via-point jerk cost (Flash & Hogan 1985; seed 000, GI sec. 4.2).

    With u = via - start, v = end - start and a(tau) = u - v s(tau), dJ/dtau1 = 0 reads
    tau (1 - tau) d|a|^2/dtau - 5 |a|^2 (1 - 2 tau) = 0; the degree-11 and degree-10 terms cancel
    and, divided by 5, what is left is

        -6|v|^2 t^9 + 27|v|^2 t^8 - 40|v|^2 t^7 + (20|v|^2 - 12 u.v) t^6 + 36 u.v t^5
        - 34 u.v t^4 + 8 u.v t^3 + 2|u|^2 t - |u|^2.
    """
    x0 = _point("start", start)
    u = _point("via", via, x0.shape[0]) - x0
    v = _point("end", end, x0.shape[0]) - x0
    vv, uv, uu = float(v @ v), float(u @ v), float(u @ u)
    return Polynomial(
        [-uu, 2 * uu, 0.0, 8 * uv, -34 * uv, 36 * uv, 20 * vv - 12 * uv, -40 * vv, 27 * vv, -6 * vv]
    )


def optimal_via_time(start, via, end, duration: float) -> float:
    """Time [s] at which the minimum-jerk movement should pass ``via`` to minimise its jerk cost.

    The candidates are the real roots in (0, 1) of :func:`via_time_polynomial`; the one of least
    cost wins. A via-point on the start or end point (|u| = 0 or u = v) has no interior optimum
    and is refused.
    """
    tf = check_positive("duration", duration)
    x0 = _point("start", start)
    x1 = _point("via", via, x0.shape[0])
    xf = _point("end", end, x0.shape[0])
    # The roots do not change when u and v are scaled together: work on |u|, |v| <= 1, where
    # the coefficients cannot overflow (then one eigenvalue solve of the polynomial's 9 x 9
    # companion matrix, whatever the digits of the points).
    big = max(float(np.max(np.abs(np.concatenate([x0, x1, xf])))), 1e-300)
    x0, x1, xf = x0 / big, x1 / big, xf / big
    u, v = x1 - x0, xf - x0
    scale = max(float(np.linalg.norm(u)), float(np.linalg.norm(v)), 1e-300)
    if np.linalg.norm(u) <= 1e-12 * scale or np.linalg.norm(u - v) <= 1e-12 * scale:
        raise InputError("coincides with the start or end point; no interior via time",
                         key="via", value=via)
    u, v = u / scale, v / scale
    poly = via_time_polynomial(np.zeros_like(u), u, v)
    roots = poly.trim(1e-12 * np.max(np.abs(poly.coef))).roots()  # end ~ start: degree drops
    real = roots[np.abs(roots.imag) <= 1e-7 * np.maximum(1.0, np.abs(roots))].real
    inside = real[(real > 0.0) & (real < 1.0)]
    if inside.size == 0:  # cannot happen: J -> inf at both ends (kept as a guard on round-off)
        raise InputError("no stationary via time in (0, 1); check the points", key="via",
                         value=via)
    costs = [via_jerk_cost(np.zeros_like(u), u, v, 1.0, tau) for tau in inside]
    return float(inside[int(np.argmin(costs))] * tf)
