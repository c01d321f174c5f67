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
    speed = np.concatenate([s.speed() for s in drawing.strokes])
    level = _width_levels(speed, max(float(np.percentile(speed, 95)), 1e-9))
    del speed
    paths, widths = _ink_paths(drawing, level, width)
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


def _width_levels(speed: np.ndarray, top: float) -> np.ndarray:
    """The width level (int8, 0 .. :data:`WIDTH_LEVELS`) of each segment between samples
    k and k + 1 of ``speed`` (N,): rint(L (1 - clip(mean speed / top, 0, 1)))."""
    slow = speed[:-1] + speed[1:]
    slow *= 0.5
    slow /= top
    np.clip(slow, 0.0, 1.0, out=slow)
    np.subtract(1.0, slow, out=slow)
    slow *= WIDTH_LEVELS
    return np.rint(slow, out=slow).astype(np.int8)


def _ink_paths(
    drawing: Drawing, level: np.ndarray, width: tuple[float, float]
) -> tuple[list[Path], list[float]]:
    """One compound path per width level in use, and its line width in points; ``level``
    (N - 1,): :func:`_width_levels` of the segments, strokes one after the other. Arrays of
    the samples' size are few at a time (a page of text is a million samples)."""
    ends = np.cumsum([s.n for s in drawing.strokes])
    inside = np.ones(len(level), dtype=bool)
    inside[ends[:-1] - 1] = False  # no segment from one stroke to the next
    if not inside.any():
        return [], []
    # runs of segments of one level within a stroke: each a polyline of its samples
    new_run = np.ones(len(level), dtype=bool)  # a run may start at k
    new_run[1:] = ~inside[:-1] | (level[1:] != level[:-1])
    first = np.flatnonzero(inside & new_run)
    new_run[:-1] = ~inside[1:] | new_run[1:]  # ... and end at k
    new_run[-1] = True
    count = np.flatnonzero(inside & new_run) - first + 2  # samples per run
    run_level = level[first].astype(np.int64)
    del level, inside, new_run
    order = np.argsort(run_level, kind="stable")  # runs of a level together, in drawing order
    first, count, run_level = first[order], count[order], run_level[order]
    start = np.cumsum(count) - count  # each run's first vertex
    sample = np.ones(int(count.sum()), dtype=np.intp)  # the sample of each vertex
    sample[start] = first
    sample[start[1:]] -= first[:-1] + count[:-1] - 1
    np.cumsum(sample, out=sample)
    codes = np.full(len(sample), Path.LINETO, dtype=Path.code_type)
    codes[start] = Path.MOVETO
    verts = np.empty((len(sample), 2))
    for c in range(2):
        verts[:, c] = np.concatenate([s.pos[:, c] for s in drawing.strokes])[sample]
    del sample
    levels, at = np.unique(run_level, return_index=True)  # each level's first run
    bounds = np.append(start[at], len(verts))
    paths = [Path(verts[a:b], codes[a:b]) for a, b in pairwise(bounds.tolist())]
    widths = [width[0] + (width[1] - width[0]) * k / WIDTH_LEVELS for k in levels.tolist()]
    return paths, widths
