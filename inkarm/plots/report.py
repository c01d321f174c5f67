"""Figures of a drawing run: the ink over the plan, and the tracking error, contact force and
pen speed against time.

Figures are plain :class:`matplotlib.figure.Figure` objects (no pyplot, no backend chosen; see
:mod:`inkarm.plots.figure`). Inputs are plain arrays (time in [s], page positions in [mm], force in [N]) and a canvas
(anything with ``image``, row 0 at the top of the page, and ``px_per_mm``).

The ink panel draws only the pixels it shows (the zoomed box around ink and plan, a few pixels
more), block-averaged down to at most ``max_image_px`` on its longer side: matplotlib's image
pipeline costs tens of bytes per pixel drawn, so it must not see the whole page.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from inkarm.analysis.metrics import ink_box, plan_strokes_from_reference
from inkarm.core.run import metric_text
from inkarm.errors import InputError
from inkarm.plots.figure import Figure, figure_of, new_axes, new_figure, save_figure

PLAN_COLOUR = "tab:red"
INK_CMAP = "gray_r"
INK_SHOWN = 0.05  # darkness above which a pixel counts as ink for the zoom
CROP_MARGIN_PX = 2  # raster pixels drawn beyond the view on each side
MAX_IMAGE_PX = 2048  # longest side of the ink image handed to matplotlib


def _extent_of_interest(
    canvas, plan_strokes, margin_mm: float
) -> tuple[float, float, float, float]:
    """(x0, x1, y0, y1) in [mm]: the box around the ink and the plan plus ``margin_mm``,
    clipped to the page; the whole page when there is neither."""
    ppm = canvas.px_per_mm
    image = canvas.image
    n_rows, n_cols = image.shape
    page = (0.0, n_cols / ppm, 0.0, n_rows / ppm)
    xs = [np.asarray(s, float)[:, 0] for s in plan_strokes]
    ys = [np.asarray(s, float)[:, 1] for s in plan_strokes]
    box = ink_box(image, INK_SHOWN, strict=True)
    if box is not None:  # the centres of the ink's extreme pixels
        r0, r1, c0, c1 = box
        xs.append(np.array([c0 + 0.5, c1 - 0.5]) / ppm)
        ys.append((n_rows - np.array([r1 - 0.5, r0 + 0.5])) / ppm)
    x = np.concatenate(xs) if xs else np.empty(0)
    y = np.concatenate(ys) if ys else np.empty(0)
    if x.size == 0:
        return page
    return (
        max(page[0], x.min() - margin_mm),
        min(page[1], x.max() + margin_mm),
        max(page[2], y.min() - margin_mm),
        min(page[3], y.max() + margin_mm),
    )


def _view_image(
    image: np.ndarray, ppm: float, view: tuple[float, float, float, float], max_px: int
) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """The pixels of the page raster ``image`` (row 0 at the top, ``ppm`` px/mm) that cover
    ``view`` = (x0, x1, y0, y1) in [mm] plus :data:`CROP_MARGIN_PX`, and their extent
    (left, right, bottom, top) in [mm]. A crop longer than ``max_px`` on a side is
    block-averaged by the smallest integer factor that brings it within (the extent then
    covers the whole blocks, a few pixels more or less at the far edges)."""
    n_rows, n_cols = image.shape
    x0, x1, y0, y1 = view
    c0 = max(0, int(np.floor(x0 * ppm)) - CROP_MARGIN_PX)
    c1 = min(n_cols, int(np.ceil(x1 * ppm)) + CROP_MARGIN_PX)
    r0 = max(0, int(np.floor(n_rows - y1 * ppm)) - CROP_MARGIN_PX)
    r1 = min(n_rows, int(np.ceil(n_rows - y0 * ppm)) + CROP_MARGIN_PX)
    c1, r1 = max(c1, c0 + 1), max(r1, r0 + 1)
    crop = image[r0:r1, c0:c1]
    block = -(-max(crop.shape) // max(int(max_px), 1))
    if block > 1:
        h, w = crop.shape[0] // block, crop.shape[1] // block
        if h and w:  # drop the partial blocks at the bottom and right
            r1, c1 = r0 + h * block, c0 + w * block
            crop = np.empty((h, w), np.float32)
            for i in range(0, h, 64):  # a few rows of blocks at a time
                rows = image[r0 + i * block : r0 + min(i + 64, h) * block, c0:c1]
                crop[i : i + 64] = rows.reshape(-1, block, w, block).mean(axis=(1, 3))
    return crop, (c0 / ppm, c1 / ppm, (n_rows - r1) / ppm, (n_rows - r0) / ppm)


def plot_canvas(
    canvas,
    ax=None,
    *,
    plan_strokes: Sequence[np.ndarray] = (),
    zoom: bool = True,
    margin_mm: float = 5.0,
    max_image_px: int = MAX_IMAGE_PX,
) -> Figure:
    """Draw the ink of ``canvas`` in page coordinates [mm] on ``ax`` (a new figure's when
    None), the planned strokes ((K, 2) polylines in [mm]) over it as thin coloured lines,
    zoomed to the ink and plan unless ``zoom`` is False. Returns the figure.

    Only the raster under the view is drawn (plus a few pixels), block-averaged when longer
    than ``max_image_px`` on a side, so that memory and time follow the view, not the page."""
    ax = new_axes(ax, (5, 6))
    ppm = canvas.px_per_mm
    image = canvas.image
    n_rows, n_cols = image.shape
    x0, x1, y0, y1 = (
        _extent_of_interest(canvas, plan_strokes, margin_mm)
        if zoom
        else (0.0, n_cols / ppm, 0.0, n_rows / ppm)
    )
    pixels, extent = _view_image(image, ppm, (x0, x1, y0, y1), max_image_px)
    ax.imshow(
        pixels,
        cmap=INK_CMAP,
        vmin=0.0,
        vmax=1.0,
        origin="upper",
        extent=extent,
        interpolation="antialiased",
    )
    for index, stroke in enumerate(plan_strokes):
        stroke = np.asarray(stroke, float)
        ax.plot(
            stroke[:, 0],
            stroke[:, 1],
            color=PLAN_COLOUR,
            lw=0.4,
            alpha=0.7,
            label="plan" if index == 0 else None,
        )
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    if len(plan_strokes):
        ax.legend(loc="upper right", fontsize="small", frameon=False)
    return figure_of(ax)


def canvas_figure(
    canvas,
    *,
    plan_strokes: Sequence[np.ndarray] = (),
    zoom: bool = True,
) -> Figure:
    """A new Figure of :func:`plot_canvas` of ``canvas`` (and the plan), 6 in wide and as
    tall as the zoomed page needs."""
    x0, x1, y0, y1 = (
        _extent_of_interest(canvas, plan_strokes, 5.0)
        if zoom
        else (
            0.0,
            canvas.image.shape[1] / canvas.px_per_mm,
            0.0,
            canvas.image.shape[0] / canvas.px_per_mm,
        )
    )
    aspect = min(max((y1 - y0) / max(x1 - x0, 1e-9), 0.25), 2.0)
    fig = new_figure((6.0, 6.0 * aspect + 0.8), layout="constrained")
    return plot_canvas(canvas, fig.add_subplot(), plan_strokes=plan_strokes, zoom=zoom)


def _shade(ax, times: np.ndarray, drawing: np.ndarray) -> None:
    """Shade the time spans where ``drawing`` is True."""
    edges = np.diff(np.concatenate(([0], drawing.astype(np.int8), [0])))
    for start, stop in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
        ax.axvspan(times[start], times[stop - 1], color="0.9", lw=0)


def report_figure(
    *,
    canvas,
    times_s,
    reference_mm,
    tip_mm,
    force_n,
    drawing,
    plan_strokes: Sequence[np.ndarray] | None = None,
    metrics: Mapping[str, float] | None = None,
    title: str | None = None,
    fig: Figure | None = None,
) -> Figure:
    """The report figure of a run: the ink over the plan on the left; on the right, against
    time, the tracking error ||r - p|| in [mm], the contact force in [N] and the pen-tip and
    reference speeds in [mm/s], the drawing phases shaded grey. ``metrics`` (e.g.
    :func:`inkarm.analysis.metrics.compute_metrics`) are printed under the title. Drawn on
    ``fig`` (a new 11 x 6.5 in Figure when None); returns the figure. :func:`write_report`
    saves it.

    Args:
        times_s: Sample times (N,) in [s].
        reference_mm, tip_mm: Reference and pen tip (N, 2 or 3) in page [mm].
        force_n: Pen-paper normal force (N,) in [N].
        drawing: Boolean (N,), True while the phase is "draw".
        plan_strokes: Planned strokes ((K, 2) in [mm]); by default the reference over each
            drawing run.
        fig: An empty Figure (or SubFigure) to draw on.
    """
    times = np.asarray(times_s, float)
    reference = np.asarray(reference_mm, float)
    tip = np.asarray(tip_mm, float)
    force = np.asarray(force_n, float)
    mask = np.asarray(drawing, bool)
    n = times.shape[0]
    for name, arr in (
        ("reference_mm", reference),
        ("tip_mm", tip),
        ("force_n", force),
        ("drawing", mask),
    ):
        if arr.shape[0] != n:
            raise InputError(f"report_figure: {name} has {arr.shape[0]} samples, times_s has {n}")
    if n < 2:
        raise InputError(f"report_figure: need at least 2 samples, got {n}")
    if plan_strokes is None:
        plan_strokes = plan_strokes_from_reference(reference, mask)

    error = np.linalg.norm(reference[:, :2] - tip[:, :2], axis=1)
    tip_speed = np.linalg.norm(np.gradient(tip[:, :2], times, axis=0), axis=1)
    ref_speed = np.linalg.norm(np.gradient(reference[:, :2], times, axis=0), axis=1)

    if fig is None:
        fig = new_figure((11, 6.5), layout="constrained")
    grid = fig.add_gridspec(3, 2, width_ratios=(1.0, 1.25))
    plot_canvas(canvas, fig.add_subplot(grid[:, 0]), plan_strokes=plan_strokes)
    panels = [fig.add_subplot(grid[0, 1])]
    panels += [fig.add_subplot(grid[i, 1], sharex=panels[0]) for i in (1, 2)]
    for ax in panels:
        _shade(ax, times, mask)
        ax.grid(True, lw=0.3)
    panels[0].plot(times, np.where(mask, error, np.nan), lw=0.8, color="tab:blue")
    panels[0].plot(times, np.where(mask, np.nan, error), lw=0.6, color="0.6")
    panels[0].set_ylabel("tracking error [mm]")
    panels[1].plot(times, force, lw=0.8, color="tab:green")
    panels[1].set_ylabel("contact force [N]")
    panels[2].plot(times, ref_speed, lw=0.6, color=PLAN_COLOUR, ls="--", label="reference")
    panels[2].plot(times, tip_speed, lw=0.8, color="tab:purple", label="pen tip")
    panels[2].set_ylabel("speed [mm/s]")
    panels[2].set_xlabel("time [s]")
    panels[2].legend(loc="upper right", fontsize="small", frameon=False)
    for ax in panels[:2]:
        ax.tick_params(labelbottom=False)
    heading = title or "drawing run"
    if metrics:
        items = [f"{key} = {value:.3g}" if math.isfinite(value) else
                 f"{key} {metric_text(metrics, key)}" for key, value in metrics.items()]
        heading += "".join("\n" + "   ".join(items[i : i + 4]) for i in range(0, len(items), 4))
    fig.suptitle(heading, fontsize="medium")
    return figure_of(panels[0])


def write_report(path: str | Path, *, dpi: float = 150, **kwargs) -> Path:
    """Save :func:`report_figure` (``kwargs``: its keyword arguments) to ``path`` (e.g.
    ``report.png``) at ``dpi``; returns the path."""
    return save_figure(report_figure(**kwargs), path, dpi=dpi)
