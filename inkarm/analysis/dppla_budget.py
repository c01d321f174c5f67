"""Budgets of DPPLA (:mod:`inkarm.analysis.dppla`; :mod:`inkarm.core.budget`): its memory in
[bytes] and inner steps (candidate segment starts tried, a few ns each), estimated before any
table is allocated.

The estimates (:func:`exact_cost`, :func:`banded_cost`) are checked against
``INKARM_MAX_MEMORY_MB`` and ``INKARM_MAX_DPPLA_STEPS`` (:data:`inkarm.core.budget.DPPLA_STEPS`);
a DP over either is refused with a :class:`~inkarm.core.budget.BudgetError` naming the
estimate and the setting.
"""

from __future__ import annotations

import math

import numpy as np

from inkarm.analysis.dppla_dp import CHUNK, exact_windows, windows
from inkarm.core.budget import DPPLA_STEPS, require, require_memory
from inkarm.errors import InputError

_COST_TEMPORARIES = 24
"""Arrays of (n, p) floats that :class:`~inkarm.analysis.dppla_segments.SegmentCost`
allocates while evaluating n errors."""
_LOOP_STEPS = 5000
"""Inner steps that one Python-level iteration of a DP (a row of the exact DP, a layer of the
banded one) costs in overhead, about 15 us."""


def _exact_layers(j: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, ...]:
    """(m0, m1, start) of the exact DP's row j: layers m0..m1 hold j, candidates from start."""
    m0 = np.maximum(np.searchsorted(hi, j, side="left"), 1)
    m1 = np.searchsorted(lo, j, side="right") - 1
    return m0, m1, lo[m0 - 1]


def _cost_bytes(w: int, p: int, error: str) -> float:
    """Bytes of a :class:`~inkarm.analysis.dppla_segments.SegmentCost` on w samples in p
    dimensions (its prefix sums)."""
    per_sample = 3 * p + 4 if error == "interpolation" else p * p + 2 * p + 2
    return 8.0 * per_sample * (w + 1)


def exact_cost(k: int, w: int, p: int = 2, error: str = "interpolation",
               prune: bool = True) -> tuple[float, float]:
    """(inner steps, bytes) of the exact DP of k segments on w samples in p dimensions: the
    (k+1, w) tables, the largest row of candidates and the segment errors' temporaries."""
    lo, hi = exact_windows(k, w, prune)
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
    lo, hi = windows(k, w, band if window else None)
    widths = np.maximum(hi[1:] - lo[1:] + 1, 0).astype(float)
    steps = float(np.sum(widths)) * band + _LOOP_STEPS * k
    widest = float(np.max(widths, initial=0.0))
    chunk = max(CHUNK // band, 1)
    n_bytes = (8.0 * float(np.sum(widths))  # parents
               + 16.0 * (widest + 2 * chunk) * band  # cached errors, and their copy
               + 8.0 * _COST_TEMPORARIES * chunk * band * p  # one chunk of errors
               + 24.0 * widest * band + 16.0 * widest  # one layer's candidates
               + _cost_bytes(w, p, error))
    return steps, n_bytes


def band_width(band, w: int, k: int) -> int:
    """The banded DP's band: the given one (a positive integer) or the paper's 2 w / k."""
    if band is None:
        return math.ceil(2 * w / k)
    if not isinstance(band, (int, np.integer)) or isinstance(band, bool) or band < 1:
        raise InputError(f"dppla band: expected a positive integer number of samples, got {band!r}")
    return int(band)


def dppla_cost(k: int, w: int, p: int = 2, *, banded: bool = False, band: int | None = None,
               window: bool = True, error: str = "interpolation") -> tuple[float, float, str]:
    """(inner steps, bytes, what) of :func:`~inkarm.analysis.dppla.dppla` with these settings
    on w samples in p dimensions, estimated before any work (:func:`exact_cost`,
    :func:`banded_cost`)."""
    if not banded:
        steps, n_bytes = exact_cost(k, w, p, error)
        return steps, n_bytes, (f"exact DPPLA of {w} samples in {k} segments (O(k w^2); the "
                                "banded DP is O(w^2 / k))")
    width = min(band_width(band, w, k), w - 1)  # no segment is longer than w - 1 samples
    steps, n_bytes = banded_cost(k, w, width, window, p, error)
    return steps, n_bytes, f"banded DPPLA of {w} samples in {k} segments, band {width}"


def check_budget(k: int, w: int, p: int = 2, **settings) -> None:
    """Refuse (:class:`~inkarm.core.budget.BudgetError`) a :func:`~inkarm.analysis.dppla.dppla`
    whose estimated memory exceeds ``INKARM_MAX_MEMORY_MB`` or whose inner steps exceed
    ``INKARM_MAX_DPPLA_STEPS``; ``settings`` as for :func:`dppla_cost`."""
    steps, n_bytes, what = dppla_cost(k, w, p, **settings)
    require_memory(n_bytes, what)
    require(steps, DPPLA_STEPS, what)


def require_exact(k: int, w: int, p: int, error: str, prune: bool = True) -> None:
    """Refuse, as :func:`check_budget`, an exact DP of up to k segments (``prune=False``: every
    segment count filled, as :func:`~inkarm.analysis.dppla.dppla_tolerance` needs)."""
    steps, n_bytes = exact_cost(k, w, p, error, prune)
    what = f"exact DPPLA of {w} samples in up to {k} segments"
    require_memory(n_bytes, what)
    require(steps, DPPLA_STEPS, what)
