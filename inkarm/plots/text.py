"""The ``inkarm write`` figure (:mod:`inkarm.plans.text`): the font's strokes in light grey,
the Gaussian targets as dots, and the handstyle's ink on top, in page [mm].

The axes limits are set before anything is drawn, and the font and the ink are each one
collection of a few compound paths (:func:`inkarm.plots.drawing.plot_ink`), so the figure is
built and drawn in time linear in the text's length (a page of text is thousands of strokes
and a million samples)."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import PathCollection
from matplotlib.path import Path

from inkarm.core.trajectory import Drawing
from inkarm.plans.fidelity import TextFidelity
from inkarm.plans.textplan import TextPlan
from inkarm.plots.drawing import plot_ink
from inkarm.plots.figure import Figure, figure_of, new_axes


def plot_text(
    tp: TextPlan,
    drawing: Drawing,
    ax=None,
    *,
    title: str = "",
    fidelity: TextFidelity | None = None,
) -> Figure:
    """Font strokes in light grey, the Gaussian targets as dots, the stylised ink on top, on
    ``ax`` (a new figure's, 10 in wide and as tall as the text, when None); returns the
    figure. The title is ``title`` followed, when ``fidelity`` is given
    (:func:`inkarm.plans.fidelity.text_fidelity`), by both directions of the distance
    between ink and font and the larger of the two."""
    lo, hi = drawing.bounds()
    pad = 0.3 * tp.font.height
    w, h = hi[0] - lo[0] + 2 * pad, hi[1] - lo[1] + 2 * pad
    fig_w = 10.0
    ax = new_axes(ax, (fig_w, max(1.5, fig_w * h / w + 0.4)))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)  # fixed limits: no autoscaling as artists are added
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    font = [s for g in tp.glyphs for s in g.strokes if len(s)]
    if font:  # one path of all the font's polylines: drawn at once, not polyline by polyline
        codes = np.full(sum(len(s) for s in font), Path.LINETO, dtype=Path.code_type)
        codes[np.cumsum([len(s) for s in font]) - [len(s) for s in font]] = Path.MOVETO
        ax.add_collection(
            PathCollection(
                [Path(np.vstack(font), codes)],
                facecolors="none",
                edgecolors="#d4d4d4",
                linewidths=4.0,
                capstyle="round",
                joinstyle="round",
                zorder=1,
            ),
            autolim=False,
        )
    means = [stroke.means for stroke in tp.plan.strokes]
    gaps = np.concatenate([np.linalg.norm(np.diff(m, axis=0), axis=1) for m in means] + [[]])
    spacing = float(np.median(gaps)) if gaps.size else tp.font.height
    dot = float(np.clip(10.0 * spacing / tp.font.height, 0.6, 2.2))  # dense targets, small dots
    if means:
        ax.plot(*np.vstack(means).T, "o", color="#e74c3c", ms=dot, mew=0, alpha=0.8, zorder=2)
    plot_ink(drawing, ax)
    ax.set_aspect("equal")
    ax.axis("off")
    if fidelity is not None:
        title = "; ".join(t for t in (title, f"from the font: {fidelity.summary()}") if t)
    if title:
        ax.set_title(title, fontsize=9, loc="left", color="#555555")
    return figure_of(ax)
