"""The restyle figure (:mod:`inkarm.plans.restyle`): the trace, its DPPLA targets with their
1-sigma ellipses, and the LQT's re-drawing, in page [mm]."""

from __future__ import annotations

import numpy as np

from inkarm.core.trajectory import Drawing
from inkarm.plans.restyle import Restyled
from inkarm.plots.figure import Figure, figure_of, new_axes


def plot_restyle(trace: Drawing, restyled: Restyled, ax=None) -> Figure:
    """Trace (grey), DPPLA targets with 1-sigma ellipses (red) and the LQT result (black), on
    ``ax`` (a new 7 x 7 in figure's when None); returns the figure."""
    ax = new_axes(ax, (7, 7))
    for n, s in enumerate(trace.strokes):
        ax.plot(s.pos[:, 0], s.pos[:, 1], color="0.7", lw=2.5, label="trace" if n == 0 else None)
    angle = np.linspace(0, 2 * np.pi, 40)
    circle = np.column_stack([np.cos(angle), np.sin(angle)])
    for n, stroke in enumerate(restyled.plan.strokes):
        for tg in stroke.targets:
            vals, vecs = np.linalg.eigh(tg.cov[:2, :2])
            ellipse = circle @ (vecs * np.sqrt(vals)).T + tg.mean[:2]
            ax.plot(ellipse[:, 0], ellipse[:, 1], color="C3", lw=0.6, alpha=0.7)
        ax.plot(
            stroke.means[:, 0],
            stroke.means[:, 1],
            "o",
            color="C3",
            ms=3,
            label="DPPLA targets" if n == 0 else None,
        )
    for n, s in enumerate(restyled.drawing.strokes):
        ax.plot(
            s.pos[:, 0], s.pos[:, 1], color="k", lw=1.0, label="restyled (LQT)" if n == 0 else None
        )
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.legend(fontsize=8)
    return figure_of(ax)
