"""The plan figure (after seed 000, Fig. 4 and 6): targets, mean path, samples, speed.

Top panel, the page in [mm]: each Gaussian target as its 1-sigma ellipse (filled) and
2-sigma ellipse (dashed), the sampled trajectories in grey, the mean path in black, and the
points of human-line and minimum-jerk strokes as dots. Bottom panel: the speed in [mm/s]
against the drawing's time in [s], one colour per stroke, samples in grey. 3-D plans are
drawn in their x-y projection.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.patches import Ellipse

from inkarm.plans.realise import PlanResult
from inkarm.plots.figure import Figure, figure_of, new_figure, save_figure

STROKE_COLOURS = ("#d98c00", "#2a7ab0", "#c0392b", "#3c9d5d", "#8e44ad", "#7f8c8d")
SAMPLE_GREY = "#9a9a9a"


def _ellipse(ax, mean: np.ndarray, cov: np.ndarray, n_sigma: float, colour: str, **style) -> None:
    eigval, eigvec = np.linalg.eigh(cov[:2, :2])
    angle = np.degrees(np.arctan2(eigvec[1, 1], eigvec[0, 1]))
    width, height = 2.0 * n_sigma * np.sqrt(np.maximum(eigval[::-1], 0.0))
    ax.add_patch(Ellipse(mean[:2], width, height, angle=angle, edgecolor=colour, **style))


def plan_figure(
    result: PlanResult, title: str | None = None, fig: Figure | None = None
) -> Figure:
    """The figure of the realised plan, drawn on ``fig`` (a new Figure, 7 in wide and as tall
    as the page needs, when None); returns it."""
    lo, hi = (b[:2] for b in result.drawing.bounds())
    for s in result.strokes:
        if s.samples.size:
            lo = np.minimum(lo, s.samples[..., :2].min(axis=(0, 1)))
            hi = np.maximum(hi, s.samples[..., :2].max(axis=(0, 1)))
        if s.stroke.plan is not None:
            sig = np.sqrt(np.max(np.linalg.eigvalsh(s.stroke.plan.covs[:, :2, :2]), axis=1))
            lo = np.minimum(lo, np.min(s.stroke.plan.means[:, :2] - 2 * sig[:, None], axis=0))
            hi = np.maximum(hi, np.max(s.stroke.plan.means[:, :2] + 2 * sig[:, None], axis=0))
    span = np.maximum(hi - lo, 1.0)
    width = 7.0
    page_height = float(np.clip(width * span[1] / span[0], 2.5, 8.0))
    if fig is None:
        fig = new_figure((width, page_height + 2.2))
    ax, ax_speed = fig.subplots(2, 1, gridspec_kw={"height_ratios": [page_height, 2.0]})
    times = [s.t for s in result.drawing.strokes]
    for i, (s, t) in enumerate(zip(result.strokes, times)):
        colour = STROKE_COLOURS[i % len(STROKE_COLOURS)]
        if s.stroke.plan is not None:
            for mean, cov in zip(s.stroke.plan.means, s.stroke.plan.covs):
                _ellipse(ax, mean, cov, 1.0, colour, facecolor=colour, alpha=0.25, lw=1.0)
                _ellipse(ax, mean, cov, 2.0, colour, facecolor="none", ls="--", lw=0.8)
            ax.plot(*s.stroke.plan.means[:, :2].T, "+", color=colour, ms=6)
        else:
            ax.plot(*s.stroke.points[:, :2].T, "o", color=colour, ms=4, mfc="none")
        for sample in s.samples:
            ax.plot(*sample[:, :2].T, color=SAMPLE_GREY, lw=0.5, alpha=0.6)
            v = np.linalg.norm(np.gradient(sample, t, axis=0), axis=1)
            ax_speed.plot(t, v, color=SAMPLE_GREY, lw=0.5, alpha=0.5)
        ax.plot(*s.mean.pos[:, :2].T, color="black", lw=1.6)
        label = s.stroke.name or f"stroke {i}"
        ax_speed.plot(t, s.mean.speed(), color=colour, lw=1.5, label=label)
    ax.set_aspect("equal")
    margin = 0.05 * span.max()
    ax.set_xlim(lo[0] - margin, hi[0] + margin)
    ax.set_ylim(lo[1] - margin, hi[1] + margin)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(title if title is not None else result.plan.title)
    ax_speed.set_xlabel("t [s]")
    ax_speed.set_ylabel("speed [mm/s]")
    ax_speed.set_ylim(bottom=0.0)
    if len(result.strokes) > 1:
        ax_speed.legend(
            fontsize="small",
            frameon=False,
            ncol=min(len(result.strokes), 4),
            loc="lower right",
            bbox_to_anchor=(1.0, 1.0),
        )
    return figure_of(ax)


def save_plan_figure(result: PlanResult, stem: str | Path) -> list[Path]:
    """Write :func:`plan_figure` to ``stem``.png (150 dpi) and ``stem``.svg; returns their
    paths."""
    fig = plan_figure(result)
    return [save_figure(fig, f"{stem}.png", dpi=150), save_figure(fig, f"{stem}.svg", dpi=150)]
