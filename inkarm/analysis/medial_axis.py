"""The discrete medial axis of a binary raster, computed at its set pixels only.

The depth of a set pixel p is its Euclidean distance to the nearest unset pixel,

    D(p) = min { ||q - p|| : q unset } = sqrt(min { dy^2 + dx^2 : p + (dy, dx) unset })   [px],

every position outside the raster counting as unset (eq. 1). It is computed exactly, on
integers, at the set pixels only (:func:`squared_depths`): its square root is the very value
that ``scipy.ndimage.distance_transform_edt`` gives (the square root of the same integer, in
float64). The work follows the set pixels, not the raster: each row's runs of set pixels give
(2) at once, and (3) visits a pixel about D(p) times, dropping it once resolved (most lie at a
line's edge).

The medial axis is the set pixels whose depth is the maximum of their 3 x 3 neighbourhood
(unset pixels have depth 0; a neighbour outside the raster is left out: it adds nothing, the
pixel's own depth being >= 1), within 1e-9: the ridge of the distance transform. It is tested
on the integers D^2: for D^2 = a < b, sqrt(b) - sqrt(a) >= 1 / (2 sqrt(b)) > 1e-9 (plus
rounding) for every raster under 10^6 pixels a side, so ``D(p) >= max - 1e-9`` and
``D^2(p) >= max D^2`` select the same pixels.
"""

from __future__ import annotations

import numpy as np


def squared_depths(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """D^2 in [px^2] (module docstring, eq. 1), int64, at the set pixels of the 2-D boolean
    ``mask`` in row-major order, everything outside ``mask`` unset. Returns (D^2, the pixels'
    flat indices in the raster bordered by one unset pixel, that bordered raster (flat, int64:
    g of (2) at the set pixels, 0 elsewhere; scratch for the caller), its width).

    In two exact steps on integers (the decomposition of Saito and Toriwaki):

        g(r, c) = min { |dx| : (r, c + dx) unset }                       (2)
        D(r, c)^2 = min over dy of  dy^2 + g(r + dy, c)^2                (3)

    (the nearest unset pixel of row r + dy is g(r + dy, c) columns away). (2) from each row's
    runs of set pixels: the pixel i of a run [s, e) is min(i - s + 1, e - i) from its ends. In
    (3) a pixel is done at the first |dy| with dy^2 >= its best so far, and g = 0 at unset
    pixels; a set pixel's scan stops at the latest one row outside ``mask``: a border of one
    unset pixel is all the padding needed."""
    h, w = mask.shape
    width = w + 2
    bordered = np.zeros((h + 2, width), bool)
    bordered[1:-1, 1:-1] = mask
    at = np.flatnonzero(bordered)
    n = at.size
    first = np.empty(n, bool)  # the first pixel of a run (the border splits the rows' runs)
    first[:1] = True
    np.not_equal(at[1:], at[:-1] + 1, out=first[1:])
    starts = np.flatnonzero(first)
    run = np.cumsum(first) - 1
    ends = np.append(starts[1:], n)
    i = np.arange(n)
    g = np.minimum(i - starts[run] + 1, ends[run] - i)  # (2)
    raster = np.zeros(bordered.size, np.int64)
    raster[at] = g
    best = g * g
    todo, dy = i, 1
    while todo.size:  # (3)
        todo = todo[dy * dy < best[todo]]
        here = at[todo]
        near = np.minimum(raster[here - dy * width], raster[here + dy * width])
        best[todo] = np.minimum(best[todo], dy * dy + near * near)
        dy += 1
    return best, at, raster, width


def medial_axis(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols), in row-major order, of the set pixels of the 2-D boolean ``mask`` on its
    medial axis: D^2 >= the max of the 3 x 3 neighbourhood's (module docstring)."""
    best, at, raster, width = squared_depths(mask)
    raster[at] = best  # D^2 at the set pixels, 0 elsewhere
    top = np.zeros_like(best)
    for step in (-width - 1, -width, -width + 1, -1, 1, width - 1, width, width + 1):
        np.maximum(top, raster[at + step], out=top)
    rows, cols = np.divmod(at[best >= top], width)
    return rows - 1, cols - 1
