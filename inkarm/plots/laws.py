"""Control laws compared on one drawing (:mod:`inkarm.jobs.compare_laws`): the pen's paths over
the reference and its DPPLA targets, the speed profiles, and the overshoot against the
reference's curvature (seed 001, Fig. 3). Arrays in, a Figure out; page [mm], [s]."""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence

import numpy as np

from inkarm.plots.figure import Figure, new_figure

Strokes = Sequence[np.ndarray]


def _colours(labels) -> dict[str, str]:
    return {label: f"C{n}" for n, label in enumerate(labels)}


def plot_law_comparison(
    reference: Strokes,
    targets_xy: np.ndarray,
    paths: Mapping[str, Strokes],
    times: Mapping[str, Strokes],
    speeds: Mapping[str, Strokes],
    curvature: np.ndarray,
    overshoot: Mapping[str, np.ndarray],
    reference_time: Strokes | None = None,
    reference_speed: Strokes | None = None,
    zoom: tuple[float, float, float] | None = None,
    bins: Sequence[float] | None = None,
    window_s: tuple[float, float] | None = None,
    fig: Figure | None = None,
) -> Figure:
    """Three panels on ``fig`` (a new 12 x 9 in figure when None): the paths on top, the speed
    profiles and the overshoot against curvature below; returns the figure.

    Args:
        reference: Per stroke, the reference path (K, 2) [mm], drawn grey.
        targets_xy: The DPPLA targets (m, 2) [mm], drawn as red dots.
        paths: Per law label, per stroke, the pen's path (K, 2) [mm].
        times, speeds: Per law label, per stroke, the time [s] and the pen's speed [mm/s]; each
            stroke is drawn from its own start, strokes 0.25 s apart (or, with
            ``reference_time``, from the plan's stroke starts), so the laws line up whatever
            their moves between strokes.
        curvature: The reference's curvature at each measured target [1/mm].
        overshoot: Per law label, the overshoot at those targets [mm].
        reference_time, reference_speed: Per stroke, the plan's time from the stroke's start
            [s] and speed [mm/s] (dashed).
        zoom: (x, y, half-width) [mm] of an inset on the paths (a corner), or None.
        bins: Curvature bin edges [1/mm]: the mean overshoot per bin is drawn as steps.
        window_s: The time span of the speed panel [s], or all of it.
    """
    fig = fig or new_figure((12.0, 9.0), layout="constrained")
    grid = fig.add_gridspec(2, 2, height_ratios=(1.1, 1.0))
    ax_path = fig.add_subplot(grid[0, :])
    ax_speed = fig.add_subplot(grid[1, 0])
    ax_over = fig.add_subplot(grid[1, 1])
    colour = _colours(paths)

    def draw_paths(ax, width: float) -> None:
        for n, stroke in enumerate(reference):
            ax.plot(stroke[:, 0], stroke[:, 1], color="0.75", lw=4 * width,
                    solid_capstyle="round", label="reference (the plan)" if n == 0 else None,
                    zorder=1)
        for label, strokes in paths.items():
            for n, stroke in enumerate(strokes):
                ax.plot(stroke[:, 0], stroke[:, 1], color=colour[label], lw=width,
                        label=label if n == 0 else None, zorder=2)
        ax.plot(targets_xy[:, 0], targets_xy[:, 1], "o", color="C3", ms=3.5 * width ** 0.5,
                label="DPPLA targets", zorder=3, mfc="none")

    draw_paths(ax_path, 1.0)
    ax_path.set_aspect("equal")
    ax_path.set_xlabel("x [mm]", labelpad=1)
    ax_path.set_ylabel("y [mm]")
    ax_path.set_title("paths over the reference and its targets")
    ax_path.legend(fontsize=7, loc="upper left", bbox_to_anchor=(0.0, -0.09), ncol=3,
                   frameon=False)
    if zoom is not None:
        x, y, half = zoom
        inset = ax_path.inset_axes((0.74, 0.52, 0.25, 0.46))
        draw_paths(inset, 1.4)
        inset.set_xlim(x - half, x + half)
        inset.set_ylim(y - half, y + half)
        inset.set_aspect("equal")
        inset.tick_params(labelsize=6)
        ax_path.indicate_inset_zoom(inset, edgecolor="0.4")

    gap = 0.25
    starts: list[float] = []
    if reference_time is not None:
        start = 0.0
        for t in reference_time:
            starts.append(start)
            start += float(t[-1] - t[0]) + gap
    if reference_time is not None and reference_speed is not None:
        for n, (t, v) in enumerate(zip(reference_time, reference_speed)):
            ax_speed.plot(starts[n] + t - t[0], v, color="k", lw=1.2, ls="--",
                          label="the plan" if n == 0 else None, zorder=3)
    for label in paths:
        start = 0.0
        for n, (t, v) in enumerate(zip(times[label], speeds[label])):
            if n < len(starts):
                start = starts[n]
            ax_speed.plot(start + t - t[0], v, color=colour[label], lw=1.0,
                          label=label if n == 0 else None)
            start += float(t[-1] - t[0]) + gap
    if window_s is not None:
        ax_speed.set_xlim(*window_s)
    ax_speed.set_xlabel("time along the strokes [s]")
    ax_speed.set_ylabel("pen speed [mm/s]")
    ax_speed.set_title("speed profiles")
    ax_speed.legend(fontsize=7)

    curvature = np.asarray(curvature, dtype=float)
    low = max(float(curvature[curvature > 0].min()) if (curvature > 0).any() else 1e-3, 1e-4)
    shown = np.maximum(curvature, low)
    for label, values in overshoot.items():
        ax_over.plot(shown, values, "o", color=colour[label], ms=3.5, alpha=0.6, mfc="none")
        if bins is not None:
            edges = np.asarray(bins, dtype=float)
            finite = np.where(np.isinf(edges), max(float(shown.max()) * 1.5, edges[-2] * 2), edges)
            finite[0] = max(finite[0], low * 0.8)
            means = [float(np.mean(values[(curvature >= a) & (curvature < b)]))
                     if ((curvature >= a) & (curvature < b)).any() else np.nan
                     for a, b in itertools.pairwise(edges)]
            ax_over.stairs(means, finite, color=colour[label], lw=1.8, label=label,
                           baseline=None)
    ax_over.set_xscale("log")
    ax_over.set_xlabel("curvature of the reference at the target [1/mm]")
    ax_over.set_ylabel("overshoot [mm]")
    ax_over.set_title("overshoot against curvature (dots: targets; steps: bin means)")
    ax_over.legend(fontsize=7)
    return fig


__all__ = ["plot_law_comparison"]
