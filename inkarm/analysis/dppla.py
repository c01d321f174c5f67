"""Optimal piecewise-linear adaptive sampling of a trajectory: DPPLA (seed 001, sec. 3).

A sampled trajectory X(n), n = 0..w-1, in p dimensions is approximated by k linear segments
whose end points (the *targets*) are samples of the trajectory, the first and the last sample
included. The break points 0 = n_0 < n_1 < ... < n_k = w-1 minimise the summed squared error

    delta(k, w) = sum_n || X_theta(n) - X(n) ||^2                      (seed 001, sec. 3)

found by dynamic programming over the Bellman recursion (:mod:`inkarm.analysis.dppla_dp`)

    delta(k, j) = min_{n_k < j} { d(n_k, j) + delta(k-1, n_k) }.

Segment error (the paper's definition, ``error="interpolation"``): the model inside a segment
is the chord *traversed uniformly in the chord parameter*,

    Y(n) = X(i) + (X(j) - X(i)) (tau_n - tau_i) / (tau_j - tau_i),   i <= n <= j,
    d(i, j) = sum_{n=i}^{j} || Y(n) - X(n) ||^2,

with tau_n = n (the paper's time-stamp index) unless sample times are given. A sample is
compared with the point of the chord at the same instant, so the error also counts timing
(tangential) deviations, not only the distance to the chord's line. ``error="perpendicular"``
uses the squared distance of each sample to the chord's (infinite) line instead: a purely
geometric error that ignores timing. Both take O(1) per segment
(:class:`inkarm.analysis.dppla_segments.SegmentCost`).

Banded DP: the paper bounds the segment start by lb = max(i - band, 0) with band = 2 w / k.
That bound alone still costs O(k w band) = O(w^2), not the O(w^2 / k) the paper claims; the
claim holds when, in addition, the m-th break point stays within +-band of its place in the
uniform segmentation, m (w-1)/k: each of the k layers then has O(band) rows of O(band)
candidates, O(k band^2) = O(w^2 / k). :func:`dppla` with ``banded=True`` applies both
restrictions, so it may miss the optimum when targets crowd far from the uniform segmentation
(``DPPLAResult.optimal_in_band`` says whether it did, when checked); ``window=False`` keeps
only the paper's literal bound on the segment length (O(k w band) = O(w^2) time).

Budgets: before any table is allocated, the DP's memory and inner steps are estimated and
checked (:mod:`inkarm.analysis.dppla_budget`); a DP over either is refused with a
:class:`~inkarm.core.budget.BudgetError` naming the estimate and the setting.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from inkarm.analysis.dppla_budget import band_width, check_budget, require_exact
from inkarm.analysis.dppla_dp import backtrack, backtrack_banded, bellman, bellman_banded
from inkarm.analysis.dppla_segments import SegmentCost
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError

EXACT_BUDGET = 2e7
"""Largest k w^2 / 2 (inner DP steps) for which the exact DP counts as cheap: a banded result
is then checked against it by default (and :mod:`inkarm.plans.restyle` prefers it)."""


@dataclass(frozen=True)
class DPPLAResult:
    """The optimal k-segment approximation of a trajectory.

    Attributes:
        breakpoints: (k+1,) sample indices of the targets: 0 = n_0 < ... < n_k = w-1.
        cost: Summed squared error delta(k, w) in [units of X]^2.
        rms: Root mean square error sqrt(cost / w) in [units of X].
        banded: Whether the banded DP produced it.
        band: The band in samples (banded DP only).
        optimal_in_band: For the banded DP, whether its cost equals the exact optimum's,
            decided by running the exact DP as a certificate; None when that was not run
            (k w^2 / 2 above ``EXACT_BUDGET`` and ``verify`` not forced), and always True
            for the exact DP.
    """

    breakpoints: np.ndarray
    cost: float
    rms: float
    banded: bool = False
    band: int | None = None
    optimal_in_band: bool | None = True

    @property
    def k(self) -> int:
        """Number of segments."""
        return len(self.breakpoints) - 1


def segments_for_compression(rho: float, w: int, p: int) -> int:
    """Number of segments k for the compression rate ``rho`` (seed 001, sec. 3):

        rho = 1 - |{n_i}| / |{X(n)}| * (p + 1) / p,

    |{n_i}| = k + 1 targets among w samples in p dimensions; the factor (p+1)/p charges each
    target its time stamp. k + 1 is rounded to the nearest integer, at least 2 targets.
    """
    if not (isinstance(rho, (int, float)) and 0.0 < rho < 1.0):
        raise InputError(f"compression rate: must lie in (0, 1), got {rho!r}")
    if w < 2:
        raise InputError(f"compression rate: needs at least 2 samples, got {w}")
    targets = round((1.0 - rho) * w * p / (p + 1))
    return int(min(max(targets, 2), w)) - 1


def compression_rate(k: int, w: int, p: int) -> float:
    """The compression rate rho of k segments on w samples in p dimensions (seed 001, sec. 3)."""
    return 1.0 - (k + 1) / w * (p + 1) / p


def _check_samples(x, weights, tau) -> tuple[np.ndarray, np.ndarray | None]:
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2:
        raise InputError(f"dppla samples: expected shape (w, p), got {x.shape}")
    if x.shape[0] < 2:
        raise InputError(f"dppla samples: need at least 2 samples, got {x.shape[0]}")
    if not np.all(np.isfinite(x)):
        bad = tuple(int(v) for v in np.argwhere(~np.isfinite(x))[0])
        raise InputError(f"dppla samples: NaN or inf at index {bad}")
    if weights is not None:
        wt = np.asarray(weights, dtype=float)
        if wt.shape != (x.shape[1],) or np.any(~np.isfinite(wt)) or np.any(wt < 0):
            raise InputError(
                f"dppla weights: expected {x.shape[1]} non-negative finite channel weights, got {weights!r}"
            )
        x = x * np.sqrt(wt)
    if tau is not None:
        tau = np.asarray(tau, dtype=float)
        if tau.shape != (x.shape[0],) or np.any(np.diff(tau) <= 0):
            raise InputError(f"dppla tau: expected {x.shape[0]} strictly increasing values")
    return x, tau


def _check_k(k, w: int) -> int:
    if not isinstance(k, (int, np.integer)) or isinstance(k, bool):
        raise InputError(f"dppla k: expected an integer number of segments, got {k!r}")
    if not 1 <= k <= w - 1:
        raise InputError(
            f"dppla k: {k} segments need {k + 1} distinct samples but the trajectory has {w}; "
            f"expected 1 <= k <= {w - 1}"
        )
    return int(k)


def dppla(
    x,
    k: int,
    *,
    banded: bool = False,
    band: int | None = None,
    window: bool = True,
    weights=None,
    tau=None,
    error: str = "interpolation",
    verify: bool | None = None,
) -> DPPLAResult:
    """Optimal k-segment piecewise-linear approximation with end points on the trajectory.

    Args:
        x: (w, p) samples, e.g. positions in [mm] optionally with time or pressure channels.
        k: Number of segments, 1 <= k <= w-1 (see :func:`segments_for_compression`).
        banded: Use the banded DP (segments at most ``band`` samples long and each break point
            within ``band`` of the uniform segmentation): O(w^2 / k) instead of O(k w^2).
        band: Band in samples; default the paper's 2 w / k (rounded up).
        window: For the banded DP, also keep break point m within ``band`` of m (w-1)/k; False
            bounds only the segment length (the paper's literal lb), in O(w^2).
        weights: Optional (p,) non-negative per-channel weights of the squared error.
        tau: Optional (w,) strictly increasing chord parameter (e.g. sample times in [s]);
            default the sample index n as in the paper. Only used by the interpolation error.
        error: "interpolation" (the paper's) or "perpendicular"; see the module docstring.
        verify: For the banded DP, run the exact DP to fill ``optimal_in_band``: True always,
            False never, None when k w^2 / 2 <= ``EXACT_BUDGET``.
    """
    x, tau = _check_samples(x, weights, tau)
    w, p = x.shape
    k = _check_k(k, w)
    check_budget(k, w, p, banded=banded, band=band, window=window, error=error)
    if not banded:
        cost = SegmentCost(x, tau, error)
        _, parent = bellman(cost, k, even_ties=True)
        breakpoints = backtrack(parent, k, w)
        total = float(np.sum(cost(breakpoints[:-1], breakpoints[1:])))
        return DPPLAResult(breakpoints, total, math.sqrt(total / w))
    band = band_width(band, w, k)
    if verify:
        check_budget(k, w, p, error=error)
    cost = SegmentCost(x, tau, error)
    total, parents, lo = bellman_banded(cost, k, min(band, w - 1), window)
    if not np.isfinite(total):
        raise InputError(
            f"dppla band: {band} samples is too narrow to cover {w} samples with {k} segments "
            f"(need band >= {math.ceil((w - 1) / k)})"
        )
    in_band = None
    if verify or (verify is None and k * w * w / 2 <= EXACT_BUDGET):
        exact, _ = bellman(cost, k)
        optimum = float(exact[k, w - 1])
        in_band = total <= optimum + 1e-9 * max(optimum, 1.0)
    breakpoints = backtrack_banded(parents, lo, k, w)
    return DPPLAResult(breakpoints, total, math.sqrt(total / w), True, band, in_band)


def dppla_tolerance(
    x, rms: float, *, weights=None, tau=None, error: str = "interpolation"
) -> DPPLAResult:
    """The exact DPPLA with the fewest segments whose RMS error sqrt(delta / w) is <= ``rms``.

    The exact DP yields delta(m, w) for every m <= k_max at once; k_max doubles until the
    tolerance is met, so the work is at most about four times that of the exact DP at the
    final k.
    """
    x, tau = _check_samples(x, weights, tau)
    if not (isinstance(rms, (int, float)) and np.isfinite(rms) and rms >= 0):
        raise InputError(f"dppla tolerance: expected a non-negative RMS error, got {rms!r}")
    w, p = x.shape
    cost = SegmentCost(x, tau, error)
    k_max = 1
    while True:
        k_max = min(2 * k_max, w - 1)
        require_exact(k_max, w, p, error, prune=False)
        delta, parent = bellman(cost, k_max, prune=False)
        ok = np.flatnonzero(delta[1:, w - 1] <= rms * rms * w * (1 + 1e-12))
        if ok.size or k_max == w - 1:
            k = int(ok[0]) + 1 if ok.size else w - 1
            total = float(delta[k, w - 1])
            return DPPLAResult(backtrack(parent, k, w), total, math.sqrt(total / w))


def trajectory_channels(traj: Trajectory, time: bool = False, pressure: bool = False) -> np.ndarray:
    """Samples of a stroke for :func:`dppla`: (w, p) columns pos [mm], then optionally t [s]
    and pressure; weigh the channels with ``dppla(..., weights=...)`` (units differ)."""
    columns = [traj.pos]
    if time:
        columns.append(traj.t[:, None])
    if pressure:
        if traj.pressure is None:
            raise InputError("dppla channels: pressure requested but the trajectory has none")
        columns.append(traj.pressure[:, None])
    return np.hstack(columns)


def reconstruct(x, breakpoints, tau=None) -> np.ndarray:
    """The piecewise-linear model X_theta(n): (w, p), linear in tau between the targets."""
    x = np.asarray(x, dtype=float)
    x2 = x[:, None] if x.ndim == 1 else x
    tau = np.arange(len(x2), dtype=float) if tau is None else np.asarray(tau, dtype=float)
    bp = np.asarray(breakpoints)
    return np.column_stack([np.interp(tau, tau[bp], c[bp]) for c in x2.T])
