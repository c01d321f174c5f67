"""A :class:`~inkarm.core.trajectory.Drawing` as ink: strokes whose width falls with the pen's
speed, like ink pooling where the pen is slow (seed 000 sec. 4)."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
from matplotlib.collections import PathCollection
from matplotlib.path import Path

from inkarm.core.trajectory import Drawing
from inkarm.plots.figure import Figure, figure_of, new_axes

WIDTH_LEVELS = 16
"""Line widths are drawn in this many equal steps between the fastest and the slowest width:
at most 1/32 of the range off (0.05 pt with the default widths, a seventh of a pixel at 200
dpi). Each step more costs a run of segments more to draw, and round caps on it."""


def plot_ink(
    drawing: Drawing,
    ax=None,
    *,
    width: tuple[float, float] = (0.6, 2.2),
    colour: str = "black",
) -> Figure:
    """Draw the strokes (x, y in [mm]) on ``ax`` with a line width falling with speed;
    ``width`` = (fastest, slowest) line width in points (the fastest: the 95th percentile of
    the speed over all strokes). On a new figure's equal-aspect axes when ``ax`` is None
    (the caller sets the limits of its own axes). Returns the figure.

    Each segment between two samples gets the width of the mean speed at its ends, rounded
    to one of :data:`WIDTH_LEVELS` steps; the ink is one collection holding one path per
    width, whose pieces are the runs of consecutive segments of that width joined into
    polylines (round joins and caps, as segments drawn one by one). So a page of text is a
    few dozen paths, not a million segments, and is drawn in time linear in its samples.
    """
    new = ax is None
    if new:
        ax = new_axes(None, (6, 6))
    speeds = [s.speed() for s in drawing.strokes]
    top = max(float(np.percentile(np.concatenate(speeds), 95)), 1e-9)
    paths, widths = _ink_paths(drawing, speeds, top, width)
    ax.add_collection(
        PathCollection(
            paths,
            facecolors="none",
            edgecolors=colour,
            linewidths=widths,
            capstyle="round",
            joinstyle="round",
            zorder=3,
        )
    )
    if new:
        ax.set_aspect("equal")
        ax.autoscale_view()
    return figure_of(ax)


def _ink_paths(
    drawing: Drawing, speeds: list[np.ndarray], top: float, width: tuple[float, float]
) -> tuple[list[Path], list[float]]:
    """One compound path per width level in use, and its line width in points."""
    pos = np.vstack([s.pos[:, :2] for s in drawing.strokes])
    v = np.concatenate(speeds)
    ends = np.cumsum([s.n for s in drawing.strokes])
    inside = np.ones(max(len(pos) - 1, 0), dtype=bool)  # segment k: samples k, k + 1
    inside[ends[:-1] - 1] = False  # no segment from one stroke to the next
    slow = 1.0 - np.clip(0.5 * (v[:-1] + v[1:]) / top, 0.0, 1.0)
    level = np.rint(slow * WIDTH_LEVELS).astype(np.int64)
    seg = np.flatnonzero(inside)
    if not len(seg):
        return [], []
    # runs of segments of one level within a stroke: each a polyline of its samples
    starts = np.ones(len(seg), dtype=bool)
    starts[1:] = (seg[1:] != seg[:-1] + 1) | (level[seg[1:]] != level[seg[:-1]])
    first = seg[starts]
    count = np.diff(np.append(np.flatnonzero(starts), len(seg))) + 1  # samples per run
    run_level = level[first]
    order = np.argsort(run_level, kind="stable")  # runs of a level together, in drawing order
    first, count, run_level = first[order], count[order], run_level[order]
    sample = np.repeat(first - (np.cumsum(count) - count), count) + np.arange(count.sum())
    codes = np.full(len(sample), Path.LINETO, dtype=Path.code_type)
    codes[np.cumsum(count) - count] = Path.MOVETO
    verts = pos[sample]
    levels, at = np.unique(run_level, return_index=True)  # each level's first run
    bounds = np.append((np.cumsum(count) - count)[at], len(sample))
    paths = [Path(verts[a:b], codes[a:b]) for a, b in pairwise(bounds.tolist())]
    widths = [width[0] + (width[1] - width[0]) * k / WIDTH_LEVELS for k in levels.tolist()]
    return paths, widths
