"""Cubic splines in NumPy, bit for bit SciPy's ``CubicSpline`` and ``CubicHermiteSpline``
(SciPy 1.17) for the boundary conditions inkarm uses, without importing SciPy (0.2-0.3 s of
start-up for the arm planner's two interpolations).

On breaks x_0 < ... < x_m (h_i = x_{i+1} - x_i) with values y_i and slopes s_i, piece i is

    p_i(t) = c_3 + c_2 u + c_1 u^2 + c_0 u^3,   u = t - x_i                       (1)

    c_3 = y_i,  c_2 = s_i,  c_1 = (m_i - s_i) / h_i - r_i,  c_0 = r_i / h_i,
    m_i = (y_{i+1} - y_i) / h_i,  r_i = (s_i + s_{i+1} - 2 m_i) / h_i              (2)

(Hermite: the slopes are given). An interpolating spline's slopes solve the tridiagonal system
of C2 continuity at the inner breaks,

    h_i s_{i-1} + 2 (h_{i-1} + h_i) s_i + h_{i-1} s_{i+1} = 3 (h_i m_{i-1} + h_{i-1} m_i),  (3)

closed by a clamped end (s = 0) or not-a-knot (the third derivative continuous at x_1 and
x_{m-1}), and solved as LAPACK's dgtsv solves it (Gaussian elimination with partial pivoting,
in the same order of operations, :func:`tridiagonal_solve`). Evaluation sums (1) in SciPy's
order, beyond the ends extrapolating the end pieces. Units: whatever x and y carry.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from inkarm.errors import InputError

BOUNDARIES = ("not-a-knot", "clamped")


def hermite_coefficients(x: np.ndarray, y: np.ndarray, slopes: np.ndarray) -> np.ndarray:
    """The coefficients (4, m, ...) of eq. (2), c_0 first, from breaks ``x`` (m + 1,), values
    ``y`` and ``slopes`` (m + 1, ...)."""
    h = np.diff(x).reshape((-1,) + (1,) * (y.ndim - 1))
    m = np.diff(y, axis=0) / h
    r = (slopes[:-1] + slopes[1:] - 2 * m) / h
    return np.stack((r / h, (m - slopes[:-1]) / h - r, slopes[:-1], y[:-1]))


def tridiagonal_solve(lower: Sequence[float], diagonal: Sequence[float],
                      upper: Sequence[float], rhs: list[list[float]]) -> list[list[float]]:
    """x with T x = rhs for the tridiagonal T (sub-, main and super-diagonal; n - 1, n, n - 1
    entries) and right-hand sides ``rhs`` (n rows of k), by LAPACK dgtsv's elimination with
    partial pivoting and back substitution, operation for operation (Python floats round as
    its compiled Fortran does). T must be non-singular (eq. (3) is, on increasing breaks)."""
    columns = tridiagonal_columns(lower, diagonal, upper, [list(c) for c in zip(*rhs)])
    return [list(row) for row in zip(*columns)] if columns else [[] for _ in rhs]


def tridiagonal_columns(lower: Sequence[float], diagonal: Sequence[float],
                        upper: Sequence[float], columns: list[list[float]]) -> list[list[float]]:
    """:func:`tridiagonal_solve` on right-hand sides given, and solutions returned, as columns
    (k lists of n): T's elimination once, then each column's forward and back sweeps as
    scalar loops, the same operations on each number in the same order (a row of k numbers
    at a time, the Python per number costs several times more)."""
    dl, d, du = list(lower), list(diagonal), list(upper)
    n = len(d)
    swaps, facts = [], []
    for i in range(n - 1):
        swap = not abs(d[i]) >= abs(dl[i])  # (dgtsv's test, NaN included)
        if not swap:  # no interchange
            fact = dl[i] / d[i]
            d[i + 1] = d[i + 1] - fact * du[i]
            dl[i] = 0.0
        else:  # rows i and i + 1 interchanged; dl[i] becomes the fill-in above
            fact = d[i] / dl[i]
            d[i] = dl[i]
            temp = d[i + 1]
            d[i + 1] = du[i] - fact * temp
            if i < n - 2:
                dl[i] = du[i + 1]
                du[i + 1] = -fact * dl[i]
            du[i] = temp
        swaps.append(swap)
        facts.append(fact)
    plain = swaps.index(True) if True in swaps else n - 1  # rows before the first interchange
    back = list(zip(du[n - 3::-1], dl[n - 3::-1], d[n - 3::-1])) if n > 2 else []
    solved = []
    for b in columns:
        low, row = [], b[0]  # forward: ``row`` is b[i] as eliminated so far
        for fact, nxt in zip(facts[:plain], b[1:plain + 1]):
            low.append(row)
            row = nxt - fact * row
        for swap, fact, nxt in zip(swaps[plain:], facts[plain:], b[plain + 1:]):
            if swap:
                low.append(nxt)
                row = row - fact * nxt
            else:
                low.append(row)
                row = nxt - fact * row
        x = [row / d[n - 1]]  # back substitution, from the last row up
        if n > 1:
            x.append((low[n - 2] - du[n - 2] * x[0]) / d[n - 2])
            after, last = x
            for v, (u, lo, di) in zip(low[n - 3::-1], back):
                after, last = last, (v - u * last - lo * after) / di
                x.append(last)
        x.reverse()
        solved.append(x)
    return solved


def spline_slopes(x: np.ndarray, y: np.ndarray, boundary: str) -> np.ndarray:
    """The slopes s (m + 1, ...) of the interpolating cubic spline through (``x``, ``y``):
    eq. (3) with both ends ``boundary`` ("not-a-knot": at least 4 points; "clamped": s = 0 at
    both ends, at least 2)."""
    n = len(x)
    least = 4 if boundary == "not-a-knot" else 2
    if boundary not in BOUNDARIES or n < least:
        raise InputError(f"a {boundary!r} spline needs at least {least} points, got {n}"
                         if boundary in BOUNDARIES else f"expected one of {BOUNDARIES}",
                         key="boundary", value=boundary)
    dx = np.diff(x)
    h = dx.reshape((-1,) + (1,) * (y.ndim - 1))
    m = np.diff(y, axis=0) / h
    b = np.empty((n,) + y.shape[1:])
    b[1:-1] = 3 * (h[1:] * m[:-1] + h[:-1] * m[1:])
    diagonal = np.empty(n)
    diagonal[1:-1] = 2 * (dx[:-1] + dx[1:])
    upper = np.append(0.0, dx[:-1])
    lower = np.append(dx[1:], 0.0)
    if boundary == "clamped":
        diagonal[0] = diagonal[-1] = 1.0
        b[0] = b[-1] = 0.0
    else:
        diagonal[0], upper[0], d = dx[1], x[2] - x[0], x[2] - x[0]
        b[0] = ((h[0] + 2 * d) * h[1] * m[0] + h[0] ** 2 * m[1]) / d
        diagonal[-1], lower[-1], d = dx[-2], x[-1] - x[-3], x[-1] - x[-3]
        b[-1] = (h[-1] ** 2 * m[-2] + (2 * d + h[-1]) * h[-2] * m[-1]) / d
    columns = tridiagonal_columns(lower.tolist(), diagonal.tolist(), upper.tolist(),
                                  b.reshape(n, -1).T.tolist())
    return np.array(columns).T.reshape(b.shape)


class CubicPieces:
    """A piecewise cubic on breaks ``x`` (m + 1,) with coefficients ``c`` (4, m, ...) of
    eq. (1); calling it evaluates it (SciPy's ``PPoly`` with extrapolation)."""

    def __init__(self, x: np.ndarray, c: np.ndarray):
        self.x, self.c = x, c

    def __call__(self, t) -> np.ndarray:
        """Values at ``t`` (T,) [x's unit]: (T, ...), eq. (1) summed in SciPy's order."""
        t = np.asarray(t, dtype=float)
        i = np.clip(np.searchsorted(self.x, t, side="right") - 1, 0, len(self.x) - 2)
        u = (t - self.x[i]).reshape(t.shape + (1,) * (self.c.ndim - 2))
        c0, c1, c2, c3 = self.c[:, i]
        return c3 + c2 * u + c1 * (u * u) + c0 * (u * u * u)


def _points(x, y) -> tuple[np.ndarray, np.ndarray]:
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if x.ndim != 1 or len(x) < 2 or y.shape[:1] != x.shape:
        raise InputError(f"expected increasing breaks (m + 1 >= 2,) and values (m + 1, ...), "
                         f"got shapes {x.shape} and {y.shape}", key="x")
    if not (np.isfinite(x).all() and np.isfinite(y).all() and (np.diff(x) > 0).all()):
        raise InputError("expected finite values on strictly increasing breaks", key="x")
    return x, y


def cubic_spline(x, y, boundary: str = "not-a-knot") -> CubicPieces:
    """The interpolating cubic spline through (``x``, ``y``) along axis 0 (``CubicSpline(x, y,
    axis=0, bc_type=boundary)``): slopes from eq. (3), pieces from eq. (2)."""
    x, y = _points(x, y)
    return CubicPieces(x, hermite_coefficients(x, y, spline_slopes(x, y, boundary)))


def hermite_spline(x, y, slopes) -> CubicPieces:
    """The cubic Hermite interpolant of values ``y`` and ``slopes`` at ``x`` along axis 0
    (``CubicHermiteSpline(x, y, slopes, axis=0)``): eq. (2)."""
    x, y = _points(x, y)
    slopes = np.asarray(slopes, dtype=float)
    if slopes.shape != y.shape or not np.isfinite(slopes).all():
        raise InputError(f"expected finite slopes of shape {y.shape}, got {slopes.shape}",
                         key="slopes")
    return CubicPieces(x, hermite_coefficients(x, y, slopes))
