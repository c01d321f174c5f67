"""Optimal piecewise-linear adaptive sampling of a trajectory: DPPLA (seed 001, sec. 3).

A sampled trajectory X(n), n = 0..w-1, in p dimensions is approximated by k linear segments
whose end points (the *targets*) are samples of the trajectory, the first and the last sample
included. The break points 0 = n_0 < n_1 < ... < n_k = w-1 minimise the summed squared error

    delta(k, w) = sum_n || X_theta(n) - X(n) ||^2                      (seed 001, sec. 3)

found by dynamic programming over the Bellman recursion

    delta(k, j) = min_{n_k < j} { d(n_k, j) + delta(k-1, n_k) }.

Segment error (the paper's definition, ``error="interpolation"``): the model inside a segment
is the chord *traversed uniformly in the chord parameter*,

    Y(n) = X(i) + (X(j) - X(i)) (tau_n - tau_i) / (tau_j - tau_i),   i <= n <= j,
    d(i, j) = sum_{n=i}^{j} || Y(n) - X(n) ||^2,

with tau_n = n (the paper's time-stamp index) unless sample times are given. A sample is
compared with the point of the chord at the same instant, so the error also counts timing
(tangential) deviations, not only the distance to the chord's line. ``error="perpendicular"``
uses the squared distance of each sample to the chord's (infinite) line instead: a purely
geometric error that ignores timing.

Both errors take O(1) per segment from prefix sums: of tau, tau^2, x, tau x and |x|^2 for the
interpolation error; of x and x x^T for the perpendicular one. The exact DP loops in Python
over the end sample j only, every candidate start i and every segment count at once with
NumPy (each segment error computed once; O(k w) memory); the banded DP loops over the
segment count m only.

Banded DP: the paper bounds the segment start by lb = max(i - band, 0) with band = 2 w / k.
That bound alone still costs O(k w band) = O(w^2), not the O(w^2 / k) the paper claims; the
claim holds when, in addition, the m-th break point stays within +-band of its place in the
uniform segmentation, m (w-1)/k: each of the k layers then has O(band) rows of O(band)
candidates, O(k band^2) = O(w^2 / k). :func:`dppla` with ``banded=True`` applies both
restrictions, so it may miss the optimum when targets crowd far from the uniform segmentation
(``DPPLAResult.optimal_in_band`` says whether it did, when checked); ``window=False`` keeps
only the paper's literal bound on the segment length (O(k w band) = O(w^2) time).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError

ERRORS = ("interpolation", "perpendicular")
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


class SegmentCost:
    """O(1) segment errors d(i, j) from prefix sums, vectorised over index arrays.

    Args:
        x: (w, p) samples (already weighted).
        tau: (w,) strictly increasing chord parameter (default: the index n, as in the paper).
        error: "interpolation" (seed 001) or "perpendicular".
    """

    def __init__(self, x: np.ndarray, tau: np.ndarray | None = None, error: str = "interpolation"):
        if error not in ERRORS:
            raise InputError(f"dppla error: expected one of {ERRORS}, got {error!r}")
        w = x.shape[0]
        # Centring only conditions the prefix sums; the errors are translation invariant.
        x = x - x.mean(axis=0)
        tau = np.arange(w, dtype=float) if tau is None else np.asarray(tau, dtype=float)
        tau = (tau - tau[0]) / max(tau[-1] - tau[0], np.finfo(float).tiny) * (w - 1)
        tau = tau - tau.mean()
        self.x, self.tau, self.error, self.w = x, tau, error, w

        def prefix(a: np.ndarray) -> np.ndarray:
            return np.concatenate([np.zeros((1,) + a.shape[1:]), np.cumsum(a, axis=0)])

        self.sx = prefix(x)
        if error == "interpolation":
            self.st = prefix(tau)
            self.stt = prefix(tau * tau)
            self.stx = prefix(tau[:, None] * x)
            self.sxx = prefix(np.einsum("np,np->n", x, x))
        else:
            self.sxxt = prefix(x[:, :, None] * x[:, None, :])

    def row(self, start: int, j: int) -> np.ndarray:
        """d(i, j) for i = start..j-1: one DP row, indexed by slices rather than index arrays."""
        return self(slice(start, j), j)

    def __call__(self, i, j) -> np.ndarray:
        """d(i, j) for broadcastable integer arrays with i < j (both end samples included),
        shaped as they broadcast; ``i`` may also be a slice of start indices."""
        starts = np.arange(i.start, i.stop) if isinstance(i, slice) else np.asarray(i)
        j = np.asarray(j)
        c = (j - starts + 1).astype(float)
        a, b = self.x[i], self.x[j]
        s_x = self.sx[j + 1] - self.sx[i]
        if self.error == "perpendicular":
            return self._perpendicular(i, j, c, a, b, s_x)
        t_i = self.tau[i]
        span = self.tau[j] - t_i
        s_t = self.st[j + 1] - self.st[i]
        s_tt = self.stt[j + 1] - self.stt[i]
        s_tx = self.stx[j + 1] - self.stx[i]
        s_xx = self.sxx[j + 1] - self.sxx[i]
        # s_n = (tau_n - tau_i) / (tau_j - tau_i) is the chord parameter of sample n.
        sum_s = (s_t - c * t_i) / span
        sum_ss = (s_tt - 2.0 * t_i * s_t + c * t_i * t_i) / (span * span)
        sum_sx = (s_tx - t_i[..., None] * s_x) / span[..., None]
        d = b - a
        # sum ||x_n - a - s_n d||^2 expanded into the prefix sums.
        cost = (
            s_xx
            - 2.0 * _dot(a, s_x)
            + c * _dot(a, a)
            - 2.0 * _dot(d, sum_sx)
            + 2.0 * _dot(d, a) * sum_s
            + _dot(d, d) * sum_ss
        )
        return np.maximum(cost, 0.0)

    def _perpendicular(self, i, j, c, a, b, s_x) -> np.ndarray:
        s_xxt = self.sxxt[j + 1] - self.sxxt[i]
        d = b - a
        norm = np.sqrt(_dot(d, d))
        u = np.divide(d, norm[..., None], out=np.zeros_like(d), where=norm[..., None] > 0)
        # sum ||x_n - a||^2 - (u . (x_n - a))^2; a zero chord leaves the distance to the point a.
        total = np.trace(s_xxt, axis1=-2, axis2=-1) - 2.0 * _dot(a, s_x) + c * _dot(a, a)
        ua = _dot(u, a)
        along = (
            np.einsum("...p,...pq,...q->...", u, s_xxt, u) - 2.0 * ua * _dot(u, s_x) + c * ua * ua
        )
        return np.maximum(total - along, 0.0)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...p,...p->...", a, b)


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


def _windows(k: int, w: int, band: int | None) -> tuple[np.ndarray, np.ndarray]:
    """Rows each layer m = 0..k may end on: [lo_m, hi_m] (inclusive), within ``band`` of the
    uniform segmentation unless ``band`` is None."""
    m = np.arange(k + 1)
    lo = m.copy()  # m segments need m+1 samples before ...
    hi = (w - 1) - (k - m)  # ... and k-m more samples after.
    if band is not None:
        centre = m * (w - 1) / k
        lo = np.maximum(lo, np.ceil(centre - band).astype(int))
        hi = np.minimum(hi, np.floor(centre + band).astype(int))
    return lo, hi


def _bellman(cost: SegmentCost, k: int, prune: bool = True):
    """Exact DP: fill delta(m, j) and the arg-min parents one row j at a time, every start i
    and every layer m at once (seed 001, sec. 3). Each segment error is computed once.

    ``prune`` drops states that cannot reach (k, w-1); without it delta(m, w-1) is filled for
    every m <= k (used to pick k from an error tolerance).
    """
    w = cost.w
    if prune:
        lo, hi = _windows(k, w, None)
    else:
        lo, hi = np.arange(k + 1), np.full(k + 1, w - 1)
    delta = np.full((k + 1, w), np.inf)
    parent = np.full((k + 1, w), -1, dtype=np.int64)
    delta[0, 0] = 0.0
    for j in range(1, w):
        # Layers whose window holds row j form a contiguous range (lo and hi are monotone).
        m0 = max(int(np.searchsorted(hi, j, side="left")), 1)
        m1 = int(np.searchsorted(lo, j, side="right")) - 1
        start = int(lo[m0 - 1])
        total = delta[m0 - 1 : m1, start:j] + cost.row(start, j)
        best = np.argmin(total, axis=1)
        delta[m0 : m1 + 1, j] = total[np.arange(m1 - m0 + 1), best]
        parent[m0 : m1 + 1, j] = start + best
    return delta, parent


def _bellman_banded(cost: SegmentCost, k: int, band: int, window: bool):
    """Banded DP: segments at most ``band`` samples long (the paper's lb = max(j - band, 0))
    and, with ``window``, break point m within ``band`` of m (w-1)/k.

    The errors d(j - r, j), r = 1..band, of every row are computed once, in one vectorised
    call (w band = O(w^2 / k) of them, and as much memory); each layer then only gathers.
    """
    w = cost.w
    lo, hi = _windows(k, w, band if window else None)
    back = np.arange(1, band + 1)
    j_all = np.arange(w)[:, None]
    i_all = j_all - back[None, :]
    valid = i_all >= 0
    errors = np.full((w, band), np.inf)
    errors[valid] = cost(i_all[valid], np.broadcast_to(j_all, i_all.shape)[valid])
    delta = np.full((k + 1, w), np.inf)
    parent = np.full((k + 1, w), -1, dtype=np.int64)
    delta[0, 0] = 0.0
    for m in range(1, k + 1):
        j = np.arange(lo[m], hi[m] + 1)
        i = np.maximum(j[:, None] - back[None, :], 0)
        # delta(m-1, i) is inf outside layer m-1's window, errors are inf where i < 0.
        total = delta[m - 1, i] + errors[j]
        best = np.argmin(total, axis=1)
        rows = np.arange(len(j))
        delta[m, j] = total[rows, best]
        parent[m, j] = i[rows, best]
    return delta, parent


def _backtrack(parent: np.ndarray, k: int, w: int) -> np.ndarray:
    points = [w - 1]
    for m in range(k, 0, -1):
        points.append(int(parent[m, points[-1]]))
    return np.array(points[::-1])


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
    w = x.shape[0]
    k = _check_k(k, w)
    cost = SegmentCost(x, tau, error)
    if not banded:
        delta, parent = _bellman(cost, k)
        total = float(delta[k, w - 1])
        return DPPLAResult(_backtrack(parent, k, w), total, math.sqrt(total / w))
    if band is None:
        band = math.ceil(2 * w / k)
    if not isinstance(band, (int, np.integer)) or band < 1:
        raise InputError(f"dppla band: expected a positive integer number of samples, got {band!r}")
    band = int(band)
    delta, parent = _bellman_banded(cost, k, band, window)
    total = float(delta[k, w - 1])
    if not np.isfinite(total):
        raise InputError(
            f"dppla band: {band} samples is too narrow to cover {w} samples with {k} segments "
            f"(need band >= {math.ceil((w - 1) / k)})"
        )
    in_band = None
    if verify or (verify is None and k * w * w / 2 <= EXACT_BUDGET):
        exact, _ = _bellman(cost, k)
        optimum = float(exact[k, w - 1])
        in_band = total <= optimum + 1e-9 * max(optimum, 1.0)
    return DPPLAResult(_backtrack(parent, k, w), total, math.sqrt(total / w), True, band, in_band)


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
    w = x.shape[0]
    cost = SegmentCost(x, tau, error)
    k_max = 1
    while True:
        k_max = min(2 * k_max, w - 1)
        delta, parent = _bellman(cost, k_max, prune=False)
        ok = np.flatnonzero(delta[1:, w - 1] <= rms * rms * w * (1 + 1e-12))
        if ok.size or k_max == w - 1:
            k = int(ok[0]) + 1 if ok.size else w - 1
            total = float(delta[k, w - 1])
            return DPPLAResult(_backtrack(parent, k, w), total, math.sqrt(total / w))


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
