"""Peaks of a 1-D signal as :func:`scipy.signal.find_peaks` finds them (its ``height`` and
``prominence``, ``wlen`` None), in NumPy: the same indices bit for bit, without importing
scipy.signal (a quarter of a second of start-up, scipy.stats with it).

Definitions (SciPy's):

* a **peak** is a run of equal samples x[l..r] (1 <= l <= r <= N - 2) with both neighbours
  x[l - 1] and x[r + 1] lower; it is reported at its middle sample (l + r) // 2;
* its **prominence** is x[p] - max(m_left, m_right), m_left the minimum of x over (j, p], j the
  nearest sample left of p higher than x[p] (or the start), m_right likewise to the right.

The nearest higher sample is found by binary lifting over sparse tables of block maxima
(block minima give m_left and m_right on the way): O(N log N) for all the peaks at once,
where SciPy walks each peak's bases sample by sample.
"""

from __future__ import annotations

import numpy as np


def local_maxima(x: np.ndarray) -> np.ndarray:
    """Indices (int, increasing) of the peaks of ``x``: runs of equal samples higher than
    both neighbours, at their middle sample; not a run that touches the first or last
    sample."""
    x = np.asarray(x, dtype=float)
    if x.size < 3:
        return np.zeros(0, dtype=np.intp)
    starts = np.concatenate([[0], np.flatnonzero(x[1:] != x[:-1]) + 1])
    ends = np.append(starts[1:] - 1, x.size - 1)
    level = x[starts]
    inner = np.arange(1, starts.size - 1)
    peak = inner[(level[inner - 1] < level[inner]) & (level[inner + 1] < level[inner])]
    return (starts[peak] + ends[peak]) // 2


def _block_tables(x: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Maxima and minima of x[i : i + 2^k] for every level k with 2^k <= N (index i)."""
    highs, lows = [x], [x]
    width = 1
    while 2 * width <= x.size:
        highs.append(np.maximum(highs[-1][:-width], highs[-1][width:]))
        lows.append(np.minimum(lows[-1][:-width], lows[-1][width:]))
        width *= 2
    return highs, lows


def prominences(x: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    """Prominence of each of ``peaks`` (indices into ``x``): x[p] - max(m_left, m_right),
    m_left / m_right the lowest sample between p and the nearest higher sample (or the end)
    on that side, as :func:`scipy.signal.peak_prominences` with ``wlen`` None."""
    x = np.asarray(x, dtype=float)
    peaks = np.asarray(peaks, dtype=np.intp)
    height = x[peaks]
    highs, lows = _block_tables(x)
    left, left_low = peaks.copy(), height.copy()  # x[left : p + 1] <= x[p] so far
    right, right_low = peaks.copy(), height.copy()  # x[p : right + 1] <= x[p] so far
    for level in range(len(highs) - 1, -1, -1):
        width = 1 << level
        start = left - width  # the block x[left - width : left]
        fits = start >= 0
        at = np.where(fits, start, 0)
        fits &= highs[level][at] <= height
        left_low = np.where(fits, np.minimum(left_low, lows[level][at]), left_low)
        left = np.where(fits, start, left)
        start = right + 1  # the block x[right + 1 : right + 1 + width]
        fits = start + width <= x.size
        at = np.where(fits, start, 0)
        fits &= highs[level][at] <= height
        right_low = np.where(fits, np.minimum(right_low, lows[level][at]), right_low)
        right = np.where(fits, right + width, right)
    return height - np.maximum(left_low, right_low)


def find_peaks(x: np.ndarray, height: float | None = None,
               prominence: float | None = None) -> np.ndarray:
    """Indices (int, increasing) of the peaks of ``x`` (:func:`local_maxima`) at least
    ``height`` high and ``prominence`` prominent (:func:`prominences`): the first value of
    ``scipy.signal.find_peaks(x, height=height, prominence=prominence)``."""
    x = np.asarray(x, dtype=float)
    peaks = local_maxima(x)
    if height is not None:
        peaks = peaks[height <= x[peaks]]
    if prominence is not None:
        peaks = peaks[prominence <= prominences(x, peaks)]
    return peaks
