"""The ``inkarm tag`` figure (:mod:`inkarm.plans.glyphs`): (a) the random targets in their GA
order, (b) the tag over its semi-tied covariances, (c) the GA's best fitness per generation."""

from __future__ import annotations

import numpy as np
from matplotlib import colormaps
from matplotlib.patches import Ellipse

from inkarm.core.trajectory import Drawing
from inkarm.plans.glyphs import Tag
from inkarm.plots.drawing import plot_ink
from inkarm.plots.figure import Figure, figure_of, new_figure


def tag_figure(tag: Tag, drawing: Drawing, *, title: str = "", fig: Figure | None = None) -> Figure:
    """(a) the random targets and their GA order, (b) the tag over its semi-tied covariances
    (1-sigma ellipses), (c) the GA's best fitness per generation, one line per glyph. Drawn on
    ``fig`` (a new Figure, 10 in wide and as tall as the tag needs, when None); returns it."""
    lo, hi = drawing.bounds()
    allpts = np.vstack(tag.points)
    lo, hi = np.minimum(lo, allpts.min(axis=0)), np.maximum(hi, allpts.max(axis=0))
    pad = 0.08 * (hi[0] - lo[0])
    aspect = (hi[1] - lo[1] + 2 * pad) / (hi[0] - lo[0] + 2 * pad)
    if fig is None:
        fig = new_figure((10, 2 * 10 * aspect + 2.6))
    grid = fig.add_gridspec(3, 1, height_ratios=[aspect, aspect, 0.22])
    ax_ga, ax_tag, ax_fit = (fig.add_subplot(grid[i]) for i in range(3))
    colours = colormaps["tab10"].colors

    for k, pts in enumerate(tag.points):
        ax_ga.plot(*pts.T, "-", color=colours[k % 10], lw=1.0, alpha=0.8)
        ax_ga.plot(*pts.T, "o", color=colours[k % 10], ms=3)
        ax_ga.plot(*pts[0], "o", mfc="none", mec="black", ms=6)
    ax_ga.set_title(
        "(a) random polar targets, ordered by the GA (circle: first)", fontsize=9, loc="left"
    )

    for stroke in tag.plan.strokes:
        for mean, cov in zip(stroke.means, stroke.covs):
            val, vec = np.linalg.eigh(cov)
            angle = np.degrees(np.arctan2(vec[1, 1], vec[0, 1]))
            ax_tag.add_patch(
                Ellipse(
                    mean,
                    2 * np.sqrt(val[1]),
                    2 * np.sqrt(val[0]),
                    angle=angle,
                    facecolor="#f7d774",
                    edgecolor="#d9a400",
                    alpha=0.45,
                    lw=0.5,
                )
            )
        ax_tag.plot(*stroke.means.T, "-", color="#bbbbbb", lw=0.6)
        ax_tag.plot(*stroke.means.T, ".", color="#c0392b", ms=3)
    plot_ink(drawing, ax_tag, width=(0.8, 3.2))
    ax_tag.set_title(f"(b) the tag, {title}", fontsize=9, loc="left")

    for ax in (ax_ga, ax_tag):
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal")
        ax.axis("off")

    for k, evo in enumerate(tag.evolutions):
        ax_fit.plot(evo.history, color=colours[k % 10], lw=1.2)
    ax_fit.set_xlabel("generation", fontsize=8)
    ax_fit.set_ylabel("best fitness", fontsize=8)
    ax_fit.tick_params(labelsize=7)
    ax_fit.set_title(
        "(c) GA with elitism: best fitness per glyph never falls", fontsize=9, loc="left"
    )
    return figure_of(ax_fit)
