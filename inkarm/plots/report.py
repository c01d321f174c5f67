"""The report of a drawing run: the ink over the plan, and the tracking error, contact force
and pen speed against time.

:func:`write_report` (``report.png`` of every run) draws the picture straight into pixels
with Pillow and NumPy (:mod:`inkarm.plots.raster`) in about a tenth of the CPU that
matplotlib's import, layout and rendering took (0.08 s against 0.5 s for the default run,
itself about 0.1 s of drawing). :func:`plot_canvas` and :func:`canvas_figure` draw the
ink on matplotlib axes for figures that combine it with others (matplotlib is imported when
they are called). Inputs are plain arrays (time in [s], page positions in [mm], force in [N])
and a canvas (anything with ``image``, row 0 at the top of the page, and ``px_per_mm``).

Both draw only the pixels they show (the zoomed box around ink and plan, a few pixels more):
resampling costs per pixel, so it must not see the whole page. matplotlib's image pipeline
gets them block-averaged down to at most ``max_image_px`` on the longer side.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PIL import Image

from inkarm.analysis.metrics import ink_box, plan_strokes_from_reference
from inkarm.core.run import metric_text
from inkarm.errors import InputError
from inkarm.ink.png import png_pixels
from inkarm.plots import raster
from inkarm.plots.raster import Panel

if TYPE_CHECKING:
    from matplotlib.figure import Figure

PLAN_COLOUR = "tab:red"
INK_CMAP = "gray_r"
INK_SHOWN = 0.05  # darkness above which a pixel counts as ink for the zoom
CROP_MARGIN_PX = 2  # raster pixels drawn beyond the view on each side
MAX_IMAGE_PX = 2048  # longest side of the ink image handed to matplotlib
REPORT_PX = (1650, 975)  # width, height of report.png
# report.png's colours (RGB): matplotlib's tab:red, tab:blue, tab:green, tab:purple, 60 % grey
RED = (214, 39, 40)
BLUE = (31, 119, 180)
GREEN = (44, 160, 44)
PURPLE = (148, 103, 189)
GREY = (153, 153, 153)


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
    from inkarm.plots.figure import figure_of, new_axes

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
    from inkarm.plots.figure import new_figure

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


def ink_panel(image: Image.Image, region: tuple[int, int, int, int], canvas,
              plan_strokes: Sequence[np.ndarray] = (), margin_mm: float = 5.0) -> Panel:
    """Draw the ink of ``canvas`` zoomed to ink and plan (plus ``margin_mm``), the planned
    strokes over it as thin red lines, into the largest box of equal scale in x and y [px/mm]
    centred in ``region`` = (left, top, right, bottom) [px] of ``image``; returns its panel.

    The raster under the view, as the grey levels of canvas.png, is resampled to the box by
    Pillow (antialiased: averaged when shrunk, interpolated when enlarged)."""
    ppm = canvas.px_per_mm
    n_rows, n_cols = canvas.image.shape
    x0, x1, y0, y1 = _extent_of_interest(canvas, plan_strokes, margin_mm)
    left, top, right, bottom = region
    scale = min((right - left) / max(x1 - x0, 1e-9), (bottom - top) / max(y1 - y0, 1e-9))
    w, h = max(round((x1 - x0) * scale), 1), max(round((y1 - y0) * scale), 1)
    u, v = left + (right - left - w) // 2, top + (bottom - top - h) // 2
    panel = Panel((u, v, u + w, v + h), (x0, x1, y0, y1))
    # the view in raster pixels: column = x ppm, row = n_rows - y ppm
    cols, rows = (x0 * ppm, x1 * ppm), (n_rows - y1 * ppm, n_rows - y0 * ppm)
    c0, r0 = max(math.floor(cols[0]), 0), max(math.floor(rows[0]), 0)
    c1 = min(max(math.ceil(cols[1]), c0 + 1), n_cols)
    r1 = min(max(math.ceil(rows[1]), r0 + 1), n_rows)
    ink = Image.fromarray(png_pixels(canvas.image[r0:r1, c0:c1])).resize(
        (w, h), Image.Resampling.BILINEAR, box=(cols[0] - c0, rows[0] - r0, cols[1] - c0,
                                                 rows[1] - r0), reducing_gap=2.0)
    image.paste(ink.convert("RGB"), (u, v))
    raster.frame(image, panel, xlabel="x [mm]", ylabel="y [mm]", grid=False)
    for stroke in plan_strokes:
        stroke = np.asarray(stroke, float)
        raster.polyline(image, panel, stroke[:, 0], stroke[:, 1], RED)
    if len(plan_strokes):
        raster.legend(image, panel, [("plan", RED)])
    return panel


def time_panels(image: Image.Image, region: tuple[int, int, int, int], times, series,
                drawing) -> list[Panel]:
    """Panels stacked in ``region`` (left, top, right, bottom) [px] sharing the time axis
    ``times`` [s], one per entry of ``series``: (y label, [(values, colour, width [px],
    legend label or None)]), the spans where ``drawing`` is True shaded grey; only the
    lowest shows the time numbers and label."""
    left, top, right, bottom = region
    gap = 14
    height = (bottom - top - gap * (len(series) - 1)) / len(series)
    edges = np.diff(np.concatenate(([0], drawing.astype(np.int8), [0])))
    starts, stops = times[np.flatnonzero(edges == 1)], times[np.flatnonzero(edges == -1) - 1]
    panels = []
    for k, (ylabel, lines) in enumerate(series):
        box = (left, round(top + k * (height + gap)), right, round(top + k * (height + gap)
                                                                   + height))
        panel = Panel(box, (float(times[0]), float(times[-1]),
                            *raster.data_limits(*(values for values, *_ in lines))))
        raster.spans(image, panel, starts, stops)
        last = k == len(series) - 1
        raster.frame(image, panel, ylabel=ylabel, x_numbers=last,
                     xlabel="time [s]" if last else None)
        for values, colour, width, _ in lines:
            raster.polyline(image, panel, times, values, colour, width)
        named = [(label, colour) for _, colour, _, label in lines if label]
        if named:
            raster.legend(image, panel, named)
        panels.append(panel)
    return panels


def report_image(
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
    size_px: tuple[int, int] = REPORT_PX,
) -> Image.Image:
    """The report of a run as an RGB image of ``size_px`` (width, height): the ink over the
    plan on the left (:func:`ink_panel`); on the right, against time, the tracking error
    ||r - p|| in [mm] (blue while drawing, grey otherwise), the contact force in [N] and the
    pen-tip and reference speeds ||dp/dt||, ||dr/dt|| in [mm/s], the drawing phases shaded
    grey (:func:`time_panels`). ``title`` and ``metrics`` (e.g.
    :func:`inkarm.analysis.metrics.compute_metrics`) head it. :func:`write_report` saves it.

    Args:
        times_s: Sample times (N,) in [s].
        reference_mm, tip_mm: Reference and pen tip (N, 2 or 3) in page [mm].
        force_n: Pen-paper normal force (N,) in [N].
        drawing: Boolean (N,), True while the phase is "draw".
        plan_strokes: Planned strokes ((K, 2) in [mm]); by default the reference over each
            drawing run.
    """
    times = np.asarray(times_s, float)
    reference = np.asarray(reference_mm, float)
    tip = np.asarray(tip_mm, float)
    force = np.asarray(force_n, float)
    mask = np.asarray(drawing, bool)
    n = times.shape[0]
    for name, arr in (("reference_mm", reference), ("tip_mm", tip), ("force_n", force),
                      ("drawing", mask)):
        if arr.shape[0] != n:
            raise InputError(f"report_image: {name} has {arr.shape[0]} samples, times_s has {n}")
    if n < 2:
        raise InputError(f"report_image: need at least 2 samples, got {n}")
    if plan_strokes is None:
        plan_strokes = plan_strokes_from_reference(reference, mask)

    error = np.linalg.norm(reference[:, :2] - tip[:, :2], axis=1)
    tip_speed = np.linalg.norm(np.gradient(tip[:, :2], times, axis=0), axis=1)
    ref_speed = np.linalg.norm(np.gradient(reference[:, :2], times, axis=0), axis=1)

    width, height = size_px
    image = Image.new("RGB", (width, height), (255, 255, 255))
    lines = [title or "drawing run"]
    if metrics:
        items = [f"{key} = {value:.3g}" if math.isfinite(value) else
                 f"{key} {metric_text(metrics, key)}" for key, value in metrics.items()]
        lines += ["   ".join(items[i : i + 4]) for i in range(0, len(items), 4)]
    top = raster.heading(image, lines) + 12
    bottom = height - 62
    ink_panel(image, (95, top, round(0.43 * width), bottom), canvas, plan_strokes)
    time_panels(image, (round(0.5 * width), top, width - 20, bottom), times, [
        ("tracking error [mm]", [(np.where(mask, np.nan, error), GREY, 1, None),
                                 (np.where(mask, error, np.nan), BLUE, 2, None)]),
        ("contact force [N]", [(force, GREEN, 2, None)]),
        ("speed [mm/s]", [(tip_speed, PURPLE, 3, "pen tip"),
                          (ref_speed, RED, 1, "reference")]),
    ], mask)
    return image


def write_report(path: str | Path, **kwargs) -> Path:
    """Save :func:`report_image` (``kwargs``: its keyword arguments) as a PNG at ``path`` (e.g.
    ``report.png``), written whole under a hidden name and renamed; returns the path."""
    from inkarm.io.outputs import atomic_file

    path = Path(path)
    with atomic_file(path) as partial:
        report_image(**kwargs).save(partial, format="PNG", compress_level=1)  # (as to_png)
    return path
