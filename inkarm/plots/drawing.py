"""A :class:`~inkarm.core.trajectory.Drawing` as ink: strokes whose width falls with the pen's
speed, like ink pooling where the pen is slow (seed 000 sec. 4)."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection

from inkarm.core.trajectory import Drawing
from inkarm.plots.figure import Figure, figure_of, new_axes


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
    (the caller sets the limits of its own axes). Returns the figure."""
    new = ax is None
    if new:
        ax = new_axes(None, (6, 6))
    speeds = np.concatenate([s.speed() for s in drawing.strokes])
    top = max(float(np.percentile(speeds, 95)), 1e-9)
    for s in drawing.strokes:
        v = s.speed()
        segments = np.stack([s.pos[:-1, :2], s.pos[1:, :2]], axis=1)
        slow = 1.0 - np.clip(0.5 * (v[:-1] + v[1:]) / top, 0.0, 1.0)
        widths = width[0] + (width[1] - width[0]) * slow
        ax.add_collection(
            LineCollection(segments, linewidths=widths, colors=colour, capstyle="round", zorder=3)
        )
    if new:
        ax.set_aspect("equal")
        ax.autoscale_view()
    return figure_of(ax)
