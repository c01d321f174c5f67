"""Height fields the force loop feeds forward: a calibrated map as prior, and one learnt while
drawing where the pen has been.

Both answer ``height(x_mm, y_mm)`` once per control period in plain Python (no NumPy call: a
NumPy scalar operation costs more than the whole lookup), page [mm] in, depth along the paper
normal out [m] (positive: deeper beyond the model's sheet, as the force loop's correction).

:class:`MapPrior` is a :class:`inkarm.robots.calibration.HeightMap` (height z of the real sheet
above the model's [mm]) as a depth: ``-z / 1000`` [m], interpolated bilinearly as the map
itself does (clamped to its grid outside)::

    z = (1-s)(1-t) z[j,i] + s(1-t) z[j,i+1] + (1-s) t z[j+1,i] + s t z[j+1,i+1]

:class:`LearntField` is a kernel regression on a regular grid of spacing ``h`` [mm]
(Nadaraya-Watson with the tent kernel B, the bilinear hat of one cell, and a prior of weight
w0 at zero)::

    S_c = sum_k B_c(p_k) r_k        W_c = sum_k B_c(p_k)          (each node c, samples k)
    r(p) = sum_c B_c(p) S_c / (w0 + W_c)

so a node that has seen many samples holds their kernel-weighted mean, one that has seen none
holds 0 (the prior), and the field between nodes is bilinear (the weights B_c(p) of the four
corners of p's cell sum to 1). A sample costs four dictionary updates; the grid is sparse (only
the nodes the pen came near exist), so it needs no bounds.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from typing import TYPE_CHECKING

from inkarm.errors import InputError

if TYPE_CHECKING:
    from inkarm.robots.calibration import HeightMap


class MapPrior:
    """A calibrated :class:`HeightMap` as the depth [m] the pen must go beyond the model's sheet
    to touch the real one, ``-map.height(x, y) / 1000`` (module docstring), in plain Python."""

    __slots__ = ("x", "xmax", "xmin", "y", "ymax", "ymin", "z")

    def __init__(self, height_map: HeightMap):
        self.x = [float(v) for v in height_map.x_mm]
        self.y = [float(v) for v in height_map.y_mm]
        self.z = [[-float(v) / 1000.0 for v in row] for row in height_map.z_mm]
        self.xmin, self.xmax = self.x[0], self.x[-1]
        self.ymin, self.ymax = self.y[0], self.y[-1]

    def height(self, x_mm: float, y_mm: float) -> float:
        """Depth [m] of the real sheet at page point (``x_mm``, ``y_mm``) [mm]."""
        i, s = _cell(self.x, min(max(x_mm, self.xmin), self.xmax))
        j, t = _cell(self.y, min(max(y_mm, self.ymin), self.ymax))
        z = self.z
        i1 = i + 1 if i + 1 < len(self.x) else i
        j1 = j + 1 if j + 1 < len(self.y) else j
        return ((1 - s) * (1 - t) * z[j][i] + s * (1 - t) * z[j][i1]
                + (1 - s) * t * z[j1][i] + s * t * z[j1][i1])


def _cell(grid: list[float], v: float) -> tuple[int, float]:
    """The grid interval i holding ``v`` (clamped already) and the fraction s of the way from
    grid[i] to grid[i+1] (0 on a one-line grid)."""
    i = bisect_right(grid, v) - 1
    if i >= len(grid) - 1:
        i = max(len(grid) - 2, 0)
    if len(grid) == 1:
        return 0, 0.0
    return i, (v - grid[i]) / (grid[i + 1] - grid[i])


class LearntField:
    """The residual depth [m] learnt from samples on a sparse grid (module docstring).

    Args:
        cell_mm: Grid spacing h [mm]: the kernel reaches one cell each way, so details shorter
            than about 2 h are smoothed away.
        prior_weight: w0, in samples: how many samples at a node it takes to hold half their
            mean.
    """

    __slots__ = ("count", "inv", "nodes", "w0")

    def __init__(self, cell_mm: float, prior_weight: float = 1.0):
        if not cell_mm > 0:
            raise InputError(f"expected a grid spacing > 0 mm, got {cell_mm}",
                             key="surface_cell_mm", value=cell_mm)
        self.inv = 1.0 / cell_mm
        self.w0 = prior_weight
        self.nodes: dict[tuple[int, int], list[float]] = {}  # node -> [S_c, W_c]
        self.count = 0

    def add(self, x_mm: float, y_mm: float, r: float) -> None:
        """One sample ``r`` [m] at page point (``x_mm``, ``y_mm``): its tent weights go to the
        four corners of its cell."""
        u, v = x_mm * self.inv, y_mm * self.inv
        i, j = math.floor(u), math.floor(v)
        s, t = u - i, v - j
        nodes = self.nodes
        for key, b in (((i, j), (1 - s) * (1 - t)), ((i + 1, j), s * (1 - t)),
                       ((i, j + 1), (1 - s) * t), ((i + 1, j + 1), s * t)):
            node = nodes.get(key)
            if node is None:
                nodes[key] = [b * r, b]
            else:
                node[0] += b * r
                node[1] += b
        self.count += 1

    def height(self, x_mm: float, y_mm: float) -> float:
        """r(p) [m] at page point (``x_mm``, ``y_mm``): 0 far from every sample."""
        if not self.nodes:
            return 0.0
        u, v = x_mm * self.inv, y_mm * self.inv
        i, j = math.floor(u), math.floor(v)
        s, t = u - i, v - j
        nodes, w0, out = self.nodes, self.w0, 0.0
        for key, b in (((i, j), (1 - s) * (1 - t)), ((i + 1, j), s * (1 - t)),
                       ((i, j + 1), (1 - s) * t), ((i + 1, j + 1), s * t)):
            node = nodes.get(key)
            if node is not None:
                out += b * node[0] / (w0 + node[1])
        return out

    def describe(self) -> str:
        """The field in words: nodes and samples."""
        return f"a height field of {len(self.nodes)} nodes from {self.count} samples"


__all__ = ["LearntField", "MapPrior"]
