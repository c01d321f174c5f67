"""Figures of a sweep: a metric against one parameter (lines, mean over the other parameters
and seeds with their min-max band), against two (a heat map of the mean), and the ensemble's
ink overlaid (the share of runs that inked each pixel). Runs that failed have no metric (NaN)
and are left out of the means."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from inkarm.plots.figure import Figure, figure_of, new_axes


def _positions(values: Sequence) -> tuple[np.ndarray, list, bool]:
    """Numeric x positions of ``values`` and the sorted distinct values; text values are
    placed at 0, 1, 2, ... (categorical)."""
    numeric = all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)
    levels = sorted(set(values), key=lambda v: (str(type(v)), v))
    if numeric:
        return np.asarray(values, float), levels, True
    index = {v: i for i, v in enumerate(levels)}
    return np.array([index[v] for v in values], float), levels, False


def _label(value) -> str:
    """A parameter value for a legend or tick: numbers to 4 significant digits."""
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def _as_float(values: Sequence) -> np.ndarray:
    return np.array([np.nan if v is None else float(v) for v in values])


def plot_metric_lines(x: Sequence, y: Sequence, *, group: Sequence | None = None,
                      xlabel: str = "", ylabel: str = "", group_label: str = "",
                      ax=None) -> Figure:
    """``y`` (one value per run, None for a failed run) against ``x``: per distinct x the mean
    (a line with markers) and the min-max band over the runs there; one line per distinct
    value of ``group`` when given. Returns the figure."""
    ax = new_axes(ax, (6.0, 4.0))
    pos, levels, numeric = _positions(list(x))
    values = _as_float(y)
    groups = list(group) if group is not None else [None] * len(values)
    for g in sorted(set(groups), key=lambda v: (str(type(v)), v if v is not None else 0)):
        mask = np.array([gi == g for gi in groups])
        xs = np.unique(pos[mask])
        cells = [values[mask & (pos == xv)] for xv in xs]
        finite = [c[np.isfinite(c)] for c in cells]
        mean = np.array([c.mean() if c.size else np.nan for c in finite])
        low = np.array([c.min() if c.size else np.nan for c in finite])
        high = np.array([c.max() if c.size else np.nan for c in finite])
        label = None if g is None else f"{group_label} = {_label(g)}"
        line, = ax.plot(xs, mean, "o-", ms=3, label=label)
        if any(c.size > 1 for c in finite):
            ax.fill_between(xs, low, high, color=line.get_color(), alpha=0.2, lw=0)
    if not numeric:
        ax.set_xticks(range(len(levels)), [_label(v) for v in levels])
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if group is not None:
        ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return figure_of(ax)


def plot_metric_heatmap(x: Sequence, y: Sequence, z: Sequence, *, xlabel: str = "",
                        ylabel: str = "", zlabel: str = "", ax=None) -> Figure:
    """The mean of ``z`` (None for a failed run) over the runs at each (x, y), as a heat map
    on the distinct values of ``x`` and ``y``; when the points do not fill a grid (a random
    design) each run is a dot coloured by its ``z``. Returns the figure."""
    ax = new_axes(ax, (6.0, 4.5))
    px, xlevels, xnum = _positions(list(x))
    py, ylevels, ynum = _positions(list(y))
    values = _as_float(z)
    xs, ys = np.unique(px), np.unique(py)
    grid = np.full((ys.size, xs.size), np.nan)
    filled = 0
    for i, yv in enumerate(ys):
        for j, xv in enumerate(xs):
            cell = values[(px == xv) & (py == yv)]
            filled += cell.size > 0
            cell = cell[np.isfinite(cell)]
            if cell.size:
                grid[i, j] = cell.mean()
    if filled == xs.size * ys.size:
        mesh = ax.pcolormesh(xs, ys, grid, shading="nearest", cmap="viridis")
    else:
        mesh = ax.scatter(px, py, c=values, cmap="viridis", s=25)
    figure_of(ax).colorbar(mesh, ax=ax, label=zlabel)
    if not xnum:
        ax.set_xticks(range(len(xlevels)), [_label(v) for v in xlevels])
    if not ynum:
        ax.set_yticks(range(len(ylevels)), [_label(v) for v in ylevels])
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    return figure_of(ax)


def plot_ink_overlay(crops: Sequence[tuple[tuple[int, int, int, int], np.ndarray]],
                     page_rows: int, px_per_mm: float, *, ink_grey: int = 230,
                     title: str = "", ax=None) -> Figure:
    """The ink of an ensemble overlaid: ``crops`` are (box (r0, r1, c0, c1), 8-bit grey crop)
    of each run's page (``page_rows`` rows at ``px_per_mm``, row 0 at the top); each pixel
    shows the share of runs whose grey there is below ``ink_grey``. Returns the figure."""
    ax = new_axes(ax, (6.0, 5.0))
    boxes = np.array([box for box, _ in crops]) if crops else np.zeros((0, 4), int)
    if len(boxes) == 0:
        ax.text(0.5, 0.5, "no ink", ha="center", va="center", transform=ax.transAxes)
        return figure_of(ax)
    r0, c0 = boxes[:, 0].min(), boxes[:, 2].min()
    r1, c1 = boxes[:, 1].max(), boxes[:, 3].max()
    count = np.zeros((r1 - r0, c1 - c0))
    for (a0, a1, b0, b1), grey in crops:
        count[a0 - r0:a1 - r0, b0 - c0:b1 - c0] += np.asarray(grey) < ink_grey
    extent = (c0 / px_per_mm, c1 / px_per_mm, (page_rows - r1) / px_per_mm,
              (page_rows - r0) / px_per_mm)
    image = ax.imshow(count / len(crops), cmap="Greys", vmin=0.0, vmax=1.0, extent=extent,
                      interpolation="nearest")
    figure_of(ax).colorbar(image, ax=ax, label="share of runs with ink")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(title or f"ink of {len(crops)} runs")
    return figure_of(ax)
