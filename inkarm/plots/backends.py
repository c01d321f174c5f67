"""The same jobs drawn by different robots, side by side: one row per job, one column per
backend, each panel the ink over the plan with the metrics every backend shares."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from inkarm.core.run import metric_text
from inkarm.errors import InputError
from inkarm.plots.figure import Figure, new_figure
from inkarm.plots.report import plot_canvas


@dataclass(frozen=True, eq=False)
class BackendPanel:
    """One backend's run of one job: its label, its ink canvas, the planned strokes ((K, 2)
    page [mm]) and its metrics (:mod:`inkarm.analysis.metrics` keys)."""

    label: str
    canvas: object
    plan_strokes: Sequence[np.ndarray]
    metrics: Mapping[str, float] = field(default_factory=dict)
    status: str = "ok"


def _summary(panel: BackendPanel) -> str:
    m = panel.metrics
    if not m:
        return f"{panel.label}: {panel.status}"
    status = "" if panel.status == "ok" else f" ({panel.status})"
    return (f"{panel.label}{status}\nink chamfer {metric_text(m, 'ink_chamfer_mm')}, tracking "
            f"RMS {metric_text(m, 'tracking_rms_mm', spec='.2f')},\ngaps "
            f"{metric_text(m, 'gap_mm', spec='.1f')}")


def backends_figure(rows: Sequence[tuple[str, Sequence[BackendPanel]]], fig=None) -> Figure:
    """A grid of :func:`inkarm.plots.report.plot_canvas` panels: ``rows`` of (job title,
    panels of its backends). Draws on ``fig`` when given; returns the Figure."""
    if not rows or any(not panels for _, panels in rows):
        raise InputError("backends_figure: expected at least one job with one panel")
    n_cols = max(len(panels) for _, panels in rows)
    if fig is None:
        fig = new_figure((4.2 * n_cols, 4.2 * len(rows)), layout="constrained")
    grid = fig.subplots(len(rows), n_cols, squeeze=False)
    for r, (title, panels) in enumerate(rows):
        for c in range(n_cols):
            ax = grid[r][c]
            if c >= len(panels):
                ax.set_axis_off()
                continue
            panel = panels[c]
            plot_canvas(panel.canvas, ax, plan_strokes=panel.plan_strokes)
            ax.set_title(f"{title}: {_summary(panel)}", fontsize="small")
    return fig
