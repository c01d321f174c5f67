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

Memory: the exact DP keeps the (k+1, w) tables of delta and parents, O(k w). The banded DP
keeps only the band: the parents of each layer's window (O(k band) with the window), the
previous layer's delta and the segment errors of the rows in the current window, computed in
chunks as the windows advance (each error still computed once).

Budgets (:mod:`inkarm.core.budget`): before any table is allocated, the DP's memory is
estimated (:func:`exact_cost`, :func:`banded_cost`) and checked against
``INKARM_MAX_MEMORY_MB``, and its inner steps (candidate segment starts tried, a few ns each)
against ``INKARM_MAX_DPPLA_STEPS`` (:data:`DPPLA_STEPS`); a DP over either is refused with a
:class:`~inkarm.core.budget.BudgetError` naming the estimate and the setting.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from inkarm.core.budget import DPPLA_STEPS, require, require_memory
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError

ERRORS = ("interpolation", "perpendicular")
EXACT_BUDGET = 2e7
"""Largest k w^2 / 2 (inner DP steps) for which the exact DP counts as cheap: a banded result
is then checked against it by default (and :mod:`inkarm.plans.restyle` prefers it)."""
"""Inner steps (candidate segment starts) of one DPPLA: a few seconds at 2-4 ns a step."""
_CHUNK = 1 << 14
"""Segment errors computed per vectorised call by the banded DP (bounds its temporaries)."""
_COST_TEMPORARIES = 24
"""Arrays of (n, p) floats that :class:`SegmentCost` allocates while evaluating n errors."""
_LOOP_STEPS = 5000
"""Inner steps that one Python-level iteration of a DP (a row of the exact DP, a layer of the
banded one) costs in overhead, about 15 us."""


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


def _exact_windows(k: int, w: int, prune: bool) -> tuple[np.ndarray, np.ndarray]:
    if prune:
        return _windows(k, w, None)
    return np.arange(k + 1), np.full(k + 1, w - 1)


def _exact_layers(j: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, ...]:
    """(m0, m1, start) of the exact DP's row j: layers m0..m1 hold j, candidates from start."""
    m0 = np.maximum(np.searchsorted(hi, j, side="left"), 1)
    m1 = np.searchsorted(lo, j, side="right") - 1
    return m0, m1, lo[m0 - 1]


def _cost_bytes(w: int, p: int, error: str) -> float:
    """Bytes of a :class:`SegmentCost` on w samples in p dimensions (its prefix sums)."""
    per_sample = 3 * p + 4 if error == "interpolation" else p * p + 2 * p + 2
    return 8.0 * per_sample * (w + 1)


def exact_cost(k: int, w: int, p: int = 2, error: str = "interpolation",
               prune: bool = True) -> tuple[float, float]:
    """(inner steps, bytes) of the exact DP of k segments on w samples in p dimensions: the
    (k+1, w) tables, the largest row of candidates and the segment errors' temporaries."""
    lo, hi = _exact_windows(k, w, prune)
    j = np.arange(1, w)
    m0, m1, start = _exact_layers(j, lo, hi)
    rects = np.maximum(m1 - m0 + 1, 0).astype(float) * (j - start)
    steps = float(np.sum(rects)) + _LOOP_STEPS * (w - 1)
    widest = float(np.max(j - start)) if w > 1 else 0.0
    n_bytes = (16.0 * (k + 1) * w + 16.0 * float(np.max(rects, initial=0.0))
               + 8.0 * _COST_TEMPORARIES * widest * p + _cost_bytes(w, p, error))
    return steps, n_bytes


def banded_cost(k: int, w: int, band: int, window: bool = True, p: int = 2,
                error: str = "interpolation") -> tuple[float, float]:
    """(inner steps, bytes) of the banded DP: parents of every layer's window, one chunk of
    segment errors and the candidates of one layer."""
    lo, hi = _windows(k, w, band if window else None)
    widths = np.maximum(hi[1:] - lo[1:] + 1, 0).astype(float)
    steps = float(np.sum(widths)) * band + _LOOP_STEPS * k
    widest = float(np.max(widths, initial=0.0))
    chunk = max(_CHUNK // band, 1)
    n_bytes = (8.0 * float(np.sum(widths))  # parents
               + 16.0 * (widest + 2 * chunk) * band  # cached errors, and their copy
               + 8.0 * _COST_TEMPORARIES * chunk * band * p  # one chunk of errors
               + 24.0 * widest * band + 16.0 * widest  # one layer's candidates
               + _cost_bytes(w, p, error))
    return steps, n_bytes


def _band(band, w: int, k: int) -> int:
    """The banded DP's band: the given one (a positive integer) or the paper's 2 w / k."""
    if band is None:
        return math.ceil(2 * w / k)
    if not isinstance(band, (int, np.integer)) or isinstance(band, bool) or band < 1:
        raise InputError(f"dppla band: expected a positive integer number of samples, got {band!r}")
    return int(band)


def dppla_cost(k: int, w: int, p: int = 2, *, banded: bool = False, band: int | None = None,
               window: bool = True, error: str = "interpolation") -> tuple[float, float, str]:
    """(inner steps, bytes, what) of :func:`dppla` with these settings on w samples in p
    dimensions, estimated before any work (:func:`exact_cost`, :func:`banded_cost`)."""
    if not banded:
        steps, n_bytes = exact_cost(k, w, p, error)
        return steps, n_bytes, (f"exact DPPLA of {w} samples in {k} segments (O(k w^2); the "
                                "banded DP is O(w^2 / k))")
    width = min(_band(band, w, k), w - 1)  # no segment is longer than w - 1 samples
    steps, n_bytes = banded_cost(k, w, width, window, p, error)
    return steps, n_bytes, f"banded DPPLA of {w} samples in {k} segments, band {width}"


def check_budget(k: int, w: int, p: int = 2, **settings) -> None:
    """Refuse (:class:`~inkarm.core.budget.BudgetError`) a :func:`dppla` whose estimated
    memory exceeds ``INKARM_MAX_MEMORY_MB`` or whose inner steps exceed
    ``INKARM_MAX_DPPLA_STEPS``; ``settings`` as for :func:`dppla_cost`."""
    steps, n_bytes, what = dppla_cost(k, w, p, **settings)
    require_memory(n_bytes, what)
    require(steps, DPPLA_STEPS, what)


def _require_exact(k: int, w: int, p: int, error: str, prune: bool = True) -> None:
    steps, n_bytes = exact_cost(k, w, p, error, prune)
    what = f"exact DPPLA of {w} samples in up to {k} segments"
    require_memory(n_bytes, what)
    require(steps, DPPLA_STEPS, what)


def _bellman(cost: SegmentCost, k: int, prune: bool = True):
    """Exact DP: fill delta(m, j) and the arg-min parents one row j at a time, every start i
    and every layer m at once (seed 001, sec. 3). Each segment error is computed once.

    ``prune`` drops states that cannot reach (k, w-1); without it delta(m, w-1) is filled for
    every m <= k (used to pick k from an error tolerance).
    """
    w = cost.w
    lo, hi = _exact_windows(k, w, prune)
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


def _error_rows(cost: SegmentCost, r0: int, r1: int, back: np.ndarray) -> np.ndarray:
    """Segment errors d(j - r, j) of rows j = r0..r1-1 and r in ``back``, (r1 - r0, band);
    inf where j - r < 0."""
    j_all = np.arange(r0, r1)[:, None]
    i_all = j_all - back[None, :]
    valid = i_all >= 0
    errors = np.full(i_all.shape, np.inf)
    errors[valid] = cost(i_all[valid], np.broadcast_to(j_all, i_all.shape)[valid])
    return errors


def _bellman_banded(cost: SegmentCost, k: int, band: int, window: bool):
    """Banded DP: segments at most ``band`` samples long (the paper's lb = max(j - band, 0))
    and, with ``window``, break point m within ``band`` of m (w-1)/k.

    Layer m only ends on rows [lo_m, hi_m] (both monotone in m), so only those are kept: the
    previous layer's delta, the parents of every layer's window (O(k band) with ``window``)
    and the errors d(j - r, j), r = 1..band, of the rows in the current window, computed in
    chunks of about ``_CHUNK`` errors as the window advances (each row once).

    Returns (delta(k, w-1), parents, lo): the parent of (m, j) is
    ``parents[m - 1][j - lo[m]]``.
    """
    w = cost.w
    lo, hi = _windows(k, w, band if window else None)
    back = np.arange(1, band + 1)
    chunk = max(_CHUNK // band, 1)
    cache, c_lo, c_hi = np.empty((0, band)), int(lo[1]), int(lo[1])  # error rows [c_lo, c_hi)
    prev, p_lo = np.array([0.0]), 0  # delta(0, j): 0 at j = 0, inf elsewhere
    parents = []
    for m in range(1, k + 1):
        a, b = int(lo[m]), int(hi[m]) + 1
        if a >= c_hi:
            cache, c_lo, c_hi = np.empty((0, band)), a, a
        elif a > c_lo:
            cache, c_lo = cache[a - c_lo :], a
        if b > c_hi:
            top = min(w, max(b, c_hi + chunk))
            pieces = [_error_rows(cost, r, min(r + chunk, top), back)
                      for r in range(c_hi, top, chunk)]
            cache, c_hi = np.concatenate([cache, *pieces]), top
        # delta(m-1, i) for i = j-1, ..., j-band: layer m-1's window padded with inf (also
        # where i < 0, where the errors are inf too), read as a sliding window: row j - a,
        # column r - 1 is padded[j - r - p_lo + band].
        padded = np.full(max(len(prev), b - 1 - p_lo) + band, np.inf)
        padded[band : band + len(prev)] = prev
        candidates = np.ndarray((b - a, band), float, padded, (a - p_lo + band - 1) * 8, (8, -8))
        total = candidates + cache[a - c_lo : b - c_lo]
        best = np.argmin(total, axis=1)
        prev, p_lo = total[np.arange(b - a), best], a
        parents.append(np.maximum(np.arange(a - 1, b - 1) - best, 0))
    return float(prev[w - 1 - p_lo]), parents, lo


def _backtrack(parent: np.ndarray, k: int, w: int) -> np.ndarray:
    points = [w - 1]
    for m in range(k, 0, -1):
        points.append(int(parent[m, points[-1]]))
    return np.array(points[::-1])


def _backtrack_banded(parents: list[np.ndarray], lo: np.ndarray, k: int, w: int) -> np.ndarray:
    points = [w - 1]
    for m in range(k, 0, -1):
        points.append(int(parents[m - 1][points[-1] - lo[m]]))
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
    w, p = x.shape
    k = _check_k(k, w)
    check_budget(k, w, p, banded=banded, band=band, window=window, error=error)
    if not banded:
        cost = SegmentCost(x, tau, error)
        delta, parent = _bellman(cost, k)
        total = float(delta[k, w - 1])
        return DPPLAResult(_backtrack(parent, k, w), total, math.sqrt(total / w))
    band = _band(band, w, k)
    if verify:
        check_budget(k, w, p, error=error)
    cost = SegmentCost(x, tau, error)
    total, parents, lo = _bellman_banded(cost, k, min(band, w - 1), window)
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
    breakpoints = _backtrack_banded(parents, lo, k, w)
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
        _require_exact(k_max, w, p, error, prune=False)
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
