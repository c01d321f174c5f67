"""The via times of a minimum-jerk path through several via-points: the timing search.

Given the points, the jerk cost of the piecewise quintic through them
(:mod:`inkarm.models.minjerk_spline`) depends on when each via-point is passed;
:func:`optimal_times` picks the times of least cost, by quasi-Newton descent on the exact
gradient (:func:`_jerk_cost_and_gradient`, from the Hermite form of each piece's cost) and a
few Newton steps, in a bounded number of evaluations whatever the digits of the points.

Units: positions in [mm], times in [s], jerk cost in [mm^2/s^5].
"""

from __future__ import annotations

import numpy as np

from inkarm.errors import InputError

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
TIME_SEARCH_MAX_EVALUATIONS = 400
_LOGIT_BOUND = 30.0  # intervals within a ratio e^60 of each other: h^-5 stays finite


def _jerk_cost_and_gradient(points: np.ndarray, times: np.ndarray) -> tuple[float, np.ndarray]:
    """Jerk cost J of the minimum-jerk spline through ``points`` at ``times`` (the spline of
    :func:`inkarm.models.minjerk_spline._spline_through`), and dJ/dh_k for each interval
    h_k = times[k+1] - times[k] with the other intervals held.

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


def optimal_times(points: np.ndarray, duration: float) -> np.ndarray:
    """Via times [s] minimising the jerk cost (used for two via-points or more).

    The problem is normalised first, as the optimal times do not change under a translation or
    scaling of the points (J scales with their square) and scale with the duration: points
    relative to the first one over the path's chord length, duration 1. The intervals are the
    softmax of logits (the first held at 0), which keeps the times ordered, started from
    chord-length-proportional times. BFGS on the exact gradient of
    :func:`_jerk_cost_and_gradient` stops on a gradient of 1e-9 times the start's cost (or
    when its line search can no longer lower J above round-off), and :func:`_newton_polish`
    takes it to 1e-11 times the optimum's. No test compares costs to an absolute tolerance,
    and a hard cap of ``TIME_SEARCH_MAX_EVALUATIONS`` evaluations bounds the work whatever
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
        if evaluations >= TIME_SEARCH_MAX_EVALUATIONS:
            raise _SearchBudgetSpent
        evaluations += 1
        h = intervals(logits)
        times = np.concatenate([[0.0], np.cumsum(h)])
        times[-1] = 1.0
        cost, dj_dh = _jerk_cost_and_gradient(p, times)
        if cost < best_cost:
            best_cost, best_logits = cost, np.array(logits, dtype=float)
        return cost, (h * (dj_dh - dj_dh @ h))[1:]  # chain rule through the softmax

    from scipy.optimize import minimize  # here: importing minjerk plans costs no SciPy

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
