"""Minimum-jerk paths through several via-points: the piecewise quintic (Flash & Hogan 1985).

From rest at the first point through the via-points to rest at the last, the path of least
jerk cost (:mod:`inkarm.models.minjerk`) is a quintic per interval, C^4 at each via-point (only
the fifth derivative jumps): :func:`min_jerk_spline` solves its linear conditions for given
via times, or chooses the times first (one via-point: the closed form of
:func:`inkarm.models.minjerk.optimal_via_time`; several: the search of
:mod:`inkarm.models.minjerk_timing`).

Units: positions in [mm], times in [s].

Budgets (:mod:`inkarm.core.budget`): the path through m points solves a dense linear system
of 6 (m - 1) unknowns, and choosing the via times (none given, m >= 4) runs up to
``TIME_SEARCH_MAX_EVALUATIONS`` (400) cost evaluations, each a dense solve of 2 (m - 2)
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

from inkarm.core import budget
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError
from inkarm.models.minjerk import check_positive, optimal_via_time, time_grid
from inkarm.models.minjerk_timing import TIME_SEARCH_MAX_EVALUATIONS, optimal_times


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
        t = time_grid(self.duration, dt)
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
        seconds += TIME_SEARCH_MAX_EVALUATIONS * SEARCH_EVALUATION_S * m**2
    return seconds


def _require_time(m: int, search: bool) -> None:
    search = search and m >= 4
    how = "choosing the via times (up to " if search else "given via times ("
    work = (f"{TIME_SEARCH_MAX_EVALUATIONS} dense solves of {2 * (m - 2)} unknowns; give "
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
    the best real root of :func:`inkarm.models.minjerk.via_time_polynomial`, for several by a
    bounded gradient search started from chord-length-proportional times
    (:func:`inkarm.models.minjerk_timing.optimal_times`; consecutive coincident points are
    then refused).

    Its time (:func:`spline_seconds`) is checked against INKARM_MAX_COMPUTE_S first.
    """
    p = _check_points(points)
    tf = check_positive("duration", duration)
    _require_time(p.shape[0], via_times is None)
    n_via = p.shape[0] - 2
    if via_times is None:
        if n_via == 0:
            inner = np.zeros(0)
        elif n_via == 1:
            inner = np.array([optimal_via_time(p[0], p[1], p[2], tf)])
        else:
            inner = optimal_times(p, tf)
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


def via_points(points, duration: float, via_times=None, dt: float = 0.01) -> Trajectory:
    """:func:`min_jerk_spline` sampled every ``dt`` [s] as a Trajectory with exact velocity.

    The samples, ceil(duration / dt) + 1, are checked against INKARM_MAX_STEPS (the error
    names ``dt``) and the path's time against INKARM_MAX_COMPUTE_S (naming ``points``) before
    any work."""
    _check_points(points)
    tf = check_positive("duration", duration)
    step = check_positive("dt", dt)
    steps = tf / step + 1
    budget.require(
        steps, budget.STEPS,
        f"time steps of the minimum-jerk path (duration {tf:g} s / dt {step:g} s)",
        key="dt", value=dt,
    )
    return min_jerk_spline(points, duration, via_times).to_trajectory(dt)
