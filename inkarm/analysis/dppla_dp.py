"""The dynamic programmes of DPPLA (seed 001, sec. 3; :mod:`inkarm.analysis.dppla`): the
Bellman recursion

    delta(k, j) = min_{n_k < j} { d(n_k, j) + delta(k-1, n_k) },

exact (:func:`bellman`) and banded (:func:`bellman_banded`), and the break points read back
from their parents. d(i, j) [units of X]^2 is a
:class:`~inkarm.analysis.dppla_segments.SegmentCost`.

The exact DP loops in Python over the end sample j only, every candidate start i and every
segment count at once with NumPy (each segment error computed once; O(k w) memory); the
banded DP loops over the segment count m only.

Memory: the exact DP keeps the (k+1, w) tables of delta and parents, O(k w). The banded DP
keeps only the band: the parents of each layer's window (O(k band) with the window), the
previous layer's delta and the segment errors of the rows in the current window, computed in
chunks as the windows advance (each error still computed once).
"""

from __future__ import annotations

import numpy as np

from inkarm.analysis.dppla_segments import SegmentCost

CHUNK = 1 << 14
"""Segment errors computed per vectorised call by the banded DP (bounds its temporaries)."""


def windows(k: int, w: int, band: int | None) -> tuple[np.ndarray, np.ndarray]:
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


def exact_windows(k: int, w: int, prune: bool) -> tuple[np.ndarray, np.ndarray]:
    """The exact DP's windows: those of :func:`windows` without a band when ``prune``, else
    every row for every layer."""
    if prune:
        return windows(k, w, None)
    return np.arange(k + 1), np.full(k + 1, w - 1)


def bellman(cost: SegmentCost, k: int, prune: bool = True, even_ties: bool = False):
    """Exact DP: fill delta(m, j) and the arg-min parents one row j at a time, every start i
    and every layer m at once (seed 001, sec. 3). Each segment error is computed once.

    ``prune`` drops states that cannot reach (k, w-1); without it delta(m, w-1) is filled for
    every m <= k (used to pick k from an error tolerance). ``even_ties`` adds
    :func:`tie_break`'s term to every segment (delta then holds it too).
    """
    w = cost.w
    lo, hi = exact_windows(k, w, prune)
    tie = tie_break(cost) if even_ties else 0.0
    delta = np.full((k + 1, w), np.inf)
    parent = np.full((k + 1, w), -1, dtype=np.int64)
    delta[0, 0] = 0.0
    for j in range(1, w):
        # Layers whose window holds row j form a contiguous range (lo and hi are monotone).
        m0 = max(int(np.searchsorted(hi, j, side="left")), 1)
        m1 = int(np.searchsorted(lo, j, side="right")) - 1
        start = int(lo[m0 - 1])
        row = cost.row(start, j)
        if even_ties:
            row += tie * np.square(j - np.arange(start, j, dtype=float))
        total = delta[m0 - 1 : m1, start:j] + row
        best = np.argmin(total, axis=1)
        delta[m0 : m1 + 1, j] = total[np.arange(m1 - m0 + 1), best]
        parent[m0 : m1 + 1, j] = start + best
    return delta, parent


TIE_BREAK = 1e-9
"""Weight of the tie-break of the exact DP, relative to the samples' summed squared spread."""


def tie_break(cost: SegmentCost) -> float:
    """The weight eps of a term eps (j - i)^2 added to each segment's error in the exact DP.

    Where many break points fit equally well (a straight run: every chord error is zero up to
    rounding), the arg-min would take the first, piling the targets at the start and leaving
    one long last segment that the LQT overshoots; the term picks the evenest of the equal
    fits. It is 1e-9 of the samples' spread over w^2, so it never outweighs a real error: the
    DP's error is recomputed from the chosen break points without it."""
    spread = float(cost.sxx[-1]) if cost.error == "interpolation" else float(
        np.trace(cost.sxxt[-1]))
    return TIE_BREAK * spread / max(cost.w - 1, 1) ** 2


def _error_rows(cost: SegmentCost, r0: int, r1: int, back: np.ndarray) -> np.ndarray:
    """Segment errors d(j - r, j) of rows j = r0..r1-1 and r in ``back``, (r1 - r0, band);
    inf where j - r < 0."""
    j_all = np.arange(r0, r1)[:, None]
    i_all = j_all - back[None, :]
    valid = i_all >= 0
    errors = np.full(i_all.shape, np.inf)
    errors[valid] = cost(i_all[valid], np.broadcast_to(j_all, i_all.shape)[valid])
    return errors


def bellman_banded(cost: SegmentCost, k: int, band: int, window: bool):
    """Banded DP: segments at most ``band`` samples long (the paper's lb = max(j - band, 0))
    and, with ``window``, break point m within ``band`` of m (w-1)/k.

    Layer m only ends on rows [lo_m, hi_m] (both monotone in m), so only those are kept: the
    previous layer's delta, the parents of every layer's window (O(k band) with ``window``)
    and the errors d(j - r, j), r = 1..band, of the rows in the current window, computed in
    chunks of about ``CHUNK`` errors as the window advances (each row once).

    Returns (delta(k, w-1), parents, lo): the parent of (m, j) is
    ``parents[m - 1][j - lo[m]]``.
    """
    w = cost.w
    lo, hi = windows(k, w, band if window else None)
    back = np.arange(1, band + 1)
    chunk = max(CHUNK // band, 1)
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


def backtrack(parent: np.ndarray, k: int, w: int) -> np.ndarray:
    points = [w - 1]
    for m in range(k, 0, -1):
        points.append(int(parent[m, points[-1]]))
    return np.array(points[::-1])


def backtrack_banded(parents: list[np.ndarray], lo: np.ndarray, k: int, w: int) -> np.ndarray:
    points = [w - 1]
    for m in range(k, 0, -1):
        points.append(int(parents[m - 1][points[-1] - lo[m]]))
    return np.array(points[::-1])
