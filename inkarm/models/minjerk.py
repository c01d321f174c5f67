"""Flash-Hogan minimum-jerk trajectories: point-to-point and through via-points.

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
fifth derivative jumps). With one via-point u = x1 - x0 reached at tau1, and v = xf - x0,

    J(tau1) = [720 |v|^2 + 20 |u - v s(tau1)|^2 / (tau1^5 (1 - tau1)^5)] / tf^5,

and setting dJ/dtau1 = 0 gives the polynomial of degree 9 that the GI paper (seed 000,
sec. 4.2) solves for the via time (see :func:`via_time_polynomial`).

Units: positions in [mm], times in [s].

Budgets (:mod:`inkarm.core.budget`): the path through m points solves a dense linear system
of 6 (m - 1) unknowns, and choosing the via times (none given, m >= 4) runs up to
``_TIME_SEARCH_MAX_EVALUATIONS`` (400) cost evaluations, each a dense solve of 2 (m - 2)
unknowns, plus BFGS with a dense m x m matrix. Before any of it :func:`min_jerk_spline`
checks the estimate of :func:`spline_seconds` against INKARM_MAX_COMPUTE_S (the error names
``points``), and :func:`via_points` its time steps against INKARM_MAX_STEPS (naming ``dt``).
The constants are medians measured on the 2-core development machine under load (BLAS with two
threads on small matrices is slow there):

=============================  ==================================  =========================
work                           estimate [s]                        measured [s]
=============================  ==================================  =========================
given via times                1.5e-3 m + 7e-9 m^3                 0.30, 0.70, 2.3, 7.9 at
                                                                   m = 200, 400, 700, 1000
via-time search, on top        400 x 3e-6 m^2                      0.22, 0.32, 8.5, 9.3, 12.7
                                                                   at m = 20, 40, 70, 100, 150
=============================  ==================================  =========================

so that with the 10 s default, given via times stop near m = 1000 points and the search near
m = 90 (give ``via_times`` for longer paths).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.polynomial import Polynomial
from scipy.optimize import minimize

from inkarm.core import budget
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


def _positive(name: str, value: float) -> float:
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise InputError(f"must be a positive number, got {value}", key=name, value=value)
    return v


def _time_grid(duration: float, dt: float) -> np.ndarray:
    """Samples 0, dt, 2 dt, ... ending exactly at ``duration`` (last step possibly shorter)."""
    dt = _positive("dt", dt)
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
    tf = _positive("duration", duration)
    t = _time_grid(tf, dt)
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
    tf = _positive("duration", duration)
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
    tf = _positive("duration", duration)
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


# -- several via-points: piecewise quintic ----------------------------------------------------


@dataclass(frozen=True)
class MinJerkSpline:
    """Piecewise quintic through ``points`` at ``times``, at rest at both ends, C^4 inside.

    Attributes:
        times: Knot times in [s], shape (m,), times[0] = 0, strictly increasing.
        coeffs: Monomial coefficients of each piece in its local time t - times[k],
            shape (m - 1, 6, D), position in [mm].
    """

    times: np.ndarray
    coeffs: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    def evaluate(self, t, derivative: int = 0) -> np.ndarray:
        """Position (derivative 0) or its ``derivative``-th time derivative at times ``t`` [s]."""
        t = np.clip(np.asarray(t, dtype=float), self.times[0], self.times[-1])
        k = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.coeffs) - 1)
        local = t - self.times[k]
        out = np.zeros((t.shape[0], self.coeffs.shape[2]))
        for i in range(derivative, 6):
            falling = np.prod(np.arange(i - derivative + 1, i + 1))  # i! / (i - derivative)!
            out += falling * self.coeffs[k, i] * (local ** (i - derivative))[:, None]
        return out

    def jerk_cost(self) -> float:
        """Exact integral of |d^3x/dt^3|^2 over the movement in [mm^2/s^5]."""
        total = 0.0
        for k, c in enumerate(self.coeffs):
            h = self.times[k + 1] - self.times[k]
            for d in range(c.shape[1]):
                jerk = Polynomial(c[:, d]).deriv(3)
                total += float((jerk**2).integ()(h))
        return total

    def to_trajectory(self, dt: float = 0.01) -> Trajectory:
        t = _time_grid(self.duration, dt)
        return Trajectory(t=t, pos=self.evaluate(t), vel=self.evaluate(t, 1))


def _monomial_row(h: float, derivative: int) -> np.ndarray:
    """Row r with r @ c = d^derivative/dt^derivative of sum_i c_i t^i at t = h."""
    row = np.zeros(6)
    for i in range(derivative, 6):
        row[i] = np.prod(np.arange(i - derivative + 1, i + 1)) * h ** (i - derivative)
    return row


def _spline_through(points: np.ndarray, times: np.ndarray) -> MinJerkSpline:
    """Solve the 6(m-1) linear conditions: rest at both ends, pass every point, C^4 inside."""
    m, dim = points.shape
    pieces = m - 1
    a = np.zeros((6 * pieces, 6 * pieces))
    b = np.zeros((6 * pieces, dim))
    row = 0

    def put(piece: int, coeffs_row: np.ndarray, rhs, sign: float = 1.0) -> None:
        a[row, 6 * piece : 6 * piece + 6] += sign * coeffs_row
        b[row] = rhs

    for derivative in range(3):  # rest at the start and at the end
        put(0, _monomial_row(0.0, derivative), points[0] if derivative == 0 else 0.0)
        row += 1
        h = times[-1] - times[-2]
        put(pieces - 1, _monomial_row(h, derivative), points[-1] if derivative == 0 else 0.0)
        row += 1
    for k in range(1, m - 1):  # via-point k joins piece k-1 (at its end) and piece k (at 0)
        h = times[k] - times[k - 1]
        put(k - 1, _monomial_row(h, 0), points[k])
        row += 1
        put(k, _monomial_row(0.0, 0), points[k])
        row += 1
        for derivative in range(1, 5):
            put(k - 1, _monomial_row(h, derivative), 0.0)
            a[row, 6 * k : 6 * k + 6] -= _monomial_row(0.0, derivative)
            row += 1
    coeffs = np.linalg.solve(a, b).reshape(pieces, 6, dim)
    return MinJerkSpline(times=times.copy(), coeffs=coeffs)


def _check_points(points) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[0] < 2 or not 1 <= p.shape[1] <= 3:
        raise InputError(f"expected shape (m >= 2, D in 1..3) in mm, got {p.shape}",
                         key="points", value=points)
    if not np.all(np.isfinite(p)):
        raise InputError("NaN or inf", key="points", value=points)
    return p


SPLINE_POINT_S = 1.5e-3  # [s] per point: assembling the conditions
SPLINE_CUBIC_S = 7e-9  # [s] per m^3: the dense solve of 6 (m - 1) unknowns
SEARCH_EVALUATION_S = 3e-6  # [s] per m^2 and evaluation of the via-time search


def spline_seconds(m: int, search: bool) -> float:
    """Estimated seconds of :func:`min_jerk_spline` through ``m`` points, with the via-time
    search (``search``: no via times given and m >= 4) or without (see the module
    docstring)."""
    m = float(m)
    seconds = SPLINE_POINT_S * m + SPLINE_CUBIC_S * m**3
    if search and m >= 4:
        seconds += _TIME_SEARCH_MAX_EVALUATIONS * SEARCH_EVALUATION_S * m**2
    return seconds


def _require_time(m: int, search: bool) -> None:
    search = search and m >= 4
    how = "choosing the via times (up to " if search else "given via times ("
    work = (f"{_TIME_SEARCH_MAX_EVALUATIONS} dense solves of {2 * (m - 2)} unknowns; give "
            f"via_times to skip it)" if search else f"a dense system of {6 * (m - 1)} unknowns)")
    budget.require(
        spline_seconds(m, search), budget.COMPUTE_S,
        f"time of the minimum-jerk path through {m} points, {how}{work}",
        key="points", value=m,
    )


def min_jerk_spline(points, duration: float, via_times=None) -> MinJerkSpline:
    """Minimum-jerk path from rest at ``points[0]`` through ``points[1:-1]`` to rest at
    ``points[-1]`` [mm], lasting ``duration`` [s].

    ``via_times`` [s] gives the passage time of each via-point (strictly inside (0, duration),
    increasing). When omitted they are chosen to minimise the jerk cost: for one via-point as
    the best real root of :func:`via_time_polynomial`, for several by a bounded gradient
    search started from chord-length-proportional times (:func:`_optimal_times`; consecutive
    coincident points are then refused).

    Its time (:func:`spline_seconds`) is checked against INKARM_MAX_COMPUTE_S first.
    """
    p = _check_points(points)
    tf = _positive("duration", duration)
    _require_time(p.shape[0], via_times is None)
    n_via = p.shape[0] - 2
    if via_times is None:
        if n_via == 0:
            inner = np.zeros(0)
        elif n_via == 1:
            inner = np.array([optimal_via_time(p[0], p[1], p[2], tf)])
        else:
            inner = _optimal_times(p, tf)
    else:
        inner = np.atleast_1d(np.asarray(via_times, dtype=float))
        if inner.shape != (n_via,):
            raise InputError(
                f"expected {n_via} times for {n_via} via-points, got {inner.shape[0]}",
                key="via_times",
                value=via_times,
            )
        knots = np.concatenate([[0.0], inner, [tf]])
        if not np.all(np.isfinite(inner)) or np.any(np.diff(knots) <= 0):
            raise InputError(
                f"must increase strictly inside (0, {tf}) s, got {inner.tolist()}",
                key="via_times",
                value=via_times,
            )
    return _spline_through(p, np.concatenate([[0.0], inner, [tf]]))


# -- several via-points: the timing search ----------------------------------------------------

# Jerk cost of a quintic y on [0, 1] in terms of its end states: the integral over [0, 1] of
# (d^3 y / d tau^3)^2 is s^T _HERMITE_JERK s, s = (y(0), y'(0), y''(0), y(1), y'(1), y''(1))
# (exact integers: the quintic's monomial coefficients are linear in s).
_HERMITE_JERK = np.array(
    [
        [720.0, 360.0, 60.0, -720.0, 360.0, -60.0],
        [360.0, 192.0, 36.0, -360.0, 168.0, -24.0],
        [60.0, 36.0, 9.0, -60.0, 24.0, -3.0],
        [-720.0, -360.0, -60.0, 720.0, -360.0, 60.0],
        [360.0, 168.0, 24.0, -360.0, 192.0, -36.0],
        [-60.0, -24.0, -3.0, 60.0, -36.0, 9.0],
    ]
)
_STATE_ORDER = np.array([0, 1, 2, 0, 1, 2])  # derivative order of each end state
_PIECE_POWER = _STATE_ORDER[:, None] + _STATE_ORDER[None, :] - 5

# The timing search: quasi-Newton descent on the exact gradient, a bounded number of
# evaluations of _jerk_cost_and_gradient whatever the digits of the points.
_TIME_SEARCH_GTOL = 1e-9  # on the gradient of J / J(start) in the logits (dimensionless)
_TIME_SEARCH_MAX_ITERATIONS = 200
_NEWTON_STEPS = 3
_NEWTON_GTOL = 1e-11  # on |dJ/dlogits| / J
_NEWTON_FD_STEP = 1e-5
_TIME_SEARCH_MAX_EVALUATIONS = 400
_LOGIT_BOUND = 30.0  # intervals within a ratio e^60 of each other: h^-5 stays finite


def _jerk_cost_and_gradient(points: np.ndarray, times: np.ndarray) -> tuple[float, np.ndarray]:
    """Jerk cost J of the minimum-jerk spline through ``points`` at ``times`` (the spline of
    :func:`_spline_through`), and dJ/dh_k for each interval h_k = times[k+1] - times[k] with the
    other intervals held.

    A quintic piece of length h with end states w = (x, x', x'') at its start and end costs
    w^T A(h) w, A_ij = _HERMITE_JERK_ij h^(p_i + p_j - 5) (t = h tau; p_i the derivative order).
    The positions are given, velocity and acceleration are zero at both ends, and those at each
    via-point are free: minimising the sum over them (one small symmetric solve) makes the
    third and fourth derivatives continuous there, which gives the C^4 piecewise quintic. With
    the free states at that optimum, dJ/dh_k = w_k^T A'(h_k) w_k (envelope theorem).
    """
    m, dim = points.shape
    h = np.diff(times)
    a = _HERMITE_JERK * h[:, None, None] ** _PIECE_POWER  # (m - 1, 6, 6)
    n = 3 * m
    k_full = np.zeros((n, n))
    for k in range(m - 1):
        k_full[3 * k : 3 * k + 6, 3 * k : 3 * k + 6] += a[k]
    fixed = 3 * np.arange(m)
    free = np.sort(np.concatenate([fixed[1:-1] + 1, fixed[1:-1] + 2]))
    states = np.zeros((n, dim))
    states[fixed] = points
    if free.size:
        rhs = k_full[np.ix_(free, fixed)] @ points
        states[free] = -np.linalg.solve(k_full[np.ix_(free, free)], rhs)
    w = np.stack([states[3 * k : 3 * k + 6] for k in range(m - 1)])  # (m - 1, 6, D)
    cost = float(np.einsum("kid,kij,kjd->", w, a, w))
    gradient = np.einsum("kid,kij,kjd->k", w, a * _PIECE_POWER / h[:, None, None], w)
    return cost, gradient


class _SearchBudgetSpent(Exception):
    pass


def _optimal_times(points: np.ndarray, duration: float) -> np.ndarray:
    """Via times [s] minimising the jerk cost (used for two via-points or more).

    The problem is normalised first, as the optimal times do not change under a translation or
    scaling of the points (J scales with their square) and scale with the duration: points
    relative to the first one over the path's chord length, duration 1. The intervals are the
    softmax of logits (the first held at 0), which keeps the times ordered, started from
    chord-length-proportional times. BFGS on the exact gradient of
    :func:`_jerk_cost_and_gradient` stops on a gradient of 1e-9 times the start's cost (or
    when its line search can no longer lower J above round-off), and :func:`_newton_polish`
    takes it to 1e-11 times the optimum's. No test compares costs to an absolute tolerance,
    and a hard cap of ``_TIME_SEARCH_MAX_EVALUATIONS`` evaluations bounds the work whatever
    the input (the best point seen is kept when it is reached).

    (The former Nelder-Mead search stopped only when its simplex's costs agreed within 1e-12
    mm^2/s^5, less than one ulp of a typical cost: whether round-off let them agree depended
    on the digits of the points, and when it did not the search ran to 4000 iterations, ~30,000
    evaluations.)

    Consecutive coincident points are refused: passing them at one instant is the limit of
    ever shorter intervals, where the search has no minimum to stop at.
    """
    big = float(np.max(np.abs(points)))
    q = points / big if big > 0 else points  # no overflow in the differences
    chords = np.linalg.norm(np.diff(q, axis=0), axis=1)
    total = float(chords.sum())
    same = np.flatnonzero(chords <= 1e-12 * total) if total > 0 else np.arange(chords.size)
    if same.size:
        k = int(same[0])
        raise InputError(
            f"points {k} and {k + 1} coincide; the minimum-jerk timing would pass them at the "
            "same instant: drop one, or give via_times",
            key="points",
            value=points.tolist(),
        )
    p = (q - q[0]) / total

    def intervals(logits: np.ndarray) -> np.ndarray:
        full = np.concatenate([[0.0], np.clip(logits, -_LOGIT_BOUND, _LOGIT_BOUND)])
        w = np.exp(full - full.max())
        return w / w.sum()

    evaluations = 0
    best_cost, best_logits = np.inf, np.zeros(0)

    def evaluate(logits: np.ndarray) -> tuple[float, np.ndarray]:
        """J and dJ/dlogits; keeps the best point seen; raises when the budget is spent."""
        nonlocal evaluations, best_cost, best_logits
        if evaluations >= _TIME_SEARCH_MAX_EVALUATIONS:
            raise _SearchBudgetSpent
        evaluations += 1
        h = intervals(logits)
        times = np.concatenate([[0.0], np.cumsum(h)])
        times[-1] = 1.0
        cost, dj_dh = _jerk_cost_and_gradient(p, times)
        if cost < best_cost:
            best_cost, best_logits = cost, np.array(logits, dtype=float)
        return cost, (h * (dj_dh - dj_dh @ h))[1:]  # chain rule through the softmax

    start = np.clip(np.log(chords[1:] / chords[0]), -_LOGIT_BOUND, _LOGIT_BOUND)
    logits = start
    try:
        reference = evaluate(start)[0]
        minimize(
            lambda x: tuple(v / reference for v in evaluate(x)),
            start,
            jac=True,
            method="BFGS",
            options={"gtol": _TIME_SEARCH_GTOL, "maxiter": _TIME_SEARCH_MAX_ITERATIONS},
        )
        logits = _newton_polish(evaluate, best_logits)
    except _SearchBudgetSpent:
        logits = best_logits
    return np.cumsum(intervals(logits))[:-1] * duration


def _newton_polish(evaluate, logits: np.ndarray) -> np.ndarray:
    """A few Newton steps on the exact gradient from ``logits`` (Hessian by central differences
    of the gradient, 2 n + 1 evaluations a step), each taken only where that Hessian is positive
    definite and the step lowers the gradient: BFGS stopped on a tolerance relative to the
    start's cost, which can be far above the optimum's, and its line searches compare costs,
    whose round-off hides the last digits of the optimum; the gradient does not."""
    cost, gradient = evaluate(logits)
    for _ in range(_NEWTON_STEPS):
        if np.max(np.abs(gradient)) <= _NEWTON_GTOL * cost:
            break
        n = logits.size
        hessian = np.empty((n, n))
        for i in range(n):
            e = np.zeros(n)
            e[i] = _NEWTON_FD_STEP
            hessian[:, i] = (evaluate(logits + e)[1] - evaluate(logits - e)[1]) / (
                2 * _NEWTON_FD_STEP
            )
        hessian = (hessian + hessian.T) / 2
        try:
            factor = np.linalg.cholesky(hessian)
        except np.linalg.LinAlgError:
            break
        step = -np.linalg.solve(factor.T, np.linalg.solve(factor, gradient))
        new_cost, new_gradient = evaluate(logits + step)
        if not np.linalg.norm(new_gradient) < np.linalg.norm(gradient):
            break
        logits, cost, gradient = logits + step, new_cost, new_gradient
    return logits


def via_points(points, duration: float, via_times=None, dt: float = 0.01) -> Trajectory:
    """:func:`min_jerk_spline` sampled every ``dt`` [s] as a Trajectory with exact velocity.

    The samples, ceil(duration / dt) + 1, are checked against INKARM_MAX_STEPS (the error
    names ``dt``) and the path's time against INKARM_MAX_COMPUTE_S (naming ``points``) before
    any work."""
    _check_points(points)
    tf = _positive("duration", duration)
    step = _positive("dt", dt)
    steps = tf / step + 1
    budget.require(
        steps, budget.STEPS,
        f"time steps of the minimum-jerk path (duration {tf:g} s / dt {step:g} s)",
        key="dt", value=dt,
    )
    return min_jerk_spline(points, duration, via_times).to_trajectory(dt)
