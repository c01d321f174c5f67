"""Charts drawn straight into pixels with Pillow and NumPy, without matplotlib: the few pieces
a run's report needs (a panel mapping data to pixels, round-number ticks, grid, polylines,
shaded spans, labels, a legend).

Importing matplotlib and laying out a figure costs tens of times the drawing of a short run;
these pieces cost about a millisecond each. Positions are in pixels of a
:class:`PIL.Image.Image` (x to the right, y down); a :class:`Panel` maps data (y up) into
its box.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np
from PIL import Image, ImageDraw, ImageFont

INK = (0, 0, 0)
GRID = (205, 205, 205)
SPAN = (230, 230, 230)
TICK_PX = 5  # length of a tick mark
STEPS = (1.0, 2.0, 2.5, 5.0, 10.0)  # tick steps per decade


@cache
def font(size_px: int) -> ImageFont.FreeTypeFont:
    """Pillow's built-in scalable font (needs Pillow >= 10.1) at ``size_px`` pixels."""
    return ImageFont.load_default(size=size_px)


@dataclass(frozen=True)
class Panel:
    """A plotting box ``box`` = (left, top, right, bottom) in [px] of an image showing the data
    range ``limits`` = (x0, x1, y0, y1), y growing upwards."""

    box: tuple[int, int, int, int]
    limits: tuple[float, float, float, float]

    def pixels(self, x, y) -> np.ndarray:
        """(N, 2) pixel positions (u, v) of the data points (x, y):
        u = left + (x - x0) / (x1 - x0) (right - left), v = bottom - (y - y0) / (y1 - y0)
        (bottom - top)."""
        left, top, right, bottom = self.box
        x0, x1 = _widened(*self.limits[:2])
        y0, y1 = _widened(*self.limits[2:])
        u = left + (np.asarray(x, float) - x0) * ((right - left) / (x1 - x0))
        v = bottom - (np.asarray(y, float) - y0) * ((bottom - top) / (y1 - y0))
        return np.column_stack(np.broadcast_arrays(u, v))


def _widened(lo: float, hi: float) -> tuple[float, float]:
    """``lo``, ``hi``, or a unit around them where they are equal (a constant plotted)."""
    return (lo, hi) if hi > lo else (lo - 0.5, hi + 0.5)


def nice_step(span: float, count: int = 5) -> float:
    """The smallest step s = m 10^k (m in :data:`STEPS`) with ``span`` / s <= ``count``."""
    raw = max(span, 1e-12) / count
    decade = 10.0 ** math.floor(math.log10(raw))
    return next(m * decade for m in STEPS if m * decade >= raw * (1 - 1e-9))


def ticks(lo: float, hi: float, count: int = 5) -> tuple[np.ndarray, float]:
    """The multiples of :func:`nice_step` within [lo, hi], and the step."""
    step = nice_step(hi - lo, count)
    first = math.ceil(lo / step - 1e-9)
    values = step * np.arange(first, math.floor(hi / step + 1e-9) + 1)
    return values, step


def tick_label(value: float, step: float) -> str:
    """``value`` with as many decimals as ``step`` needs (2.5 needs one more than 2)."""
    decimals = max(0, -math.floor(math.log10(step) + 1e-9))
    if not math.isclose(step / 10.0 ** math.floor(math.log10(step) + 1e-9) % 1.0, 0.0,
                        abs_tol=1e-6):
        decimals += 1
    return f"{0.0 if abs(value) < step * 1e-6 else value:.{decimals}f}"


def data_limits(*series, pad: float = 0.05) -> tuple[float, float]:
    """(lo, hi) around the finite values of ``series``, widened by ``pad`` of the range each
    side (by 1 around a constant; (0, 1) without any finite value)."""
    values = np.concatenate([np.ravel(np.asarray(s, float)) for s in series])
    values = values[np.isfinite(values)]
    if values.size == 0:
        return 0.0, 1.0
    lo, hi = float(values.min()), float(values.max())
    margin = pad * (hi - lo) if hi > lo else 1.0
    return lo - margin, hi + margin


def frame(image: Image.Image, panel: Panel, *, xlabel: str | None = None,
          ylabel: str | None = None, x_numbers: bool = True, grid: bool = True,
          size_px: int = 16) -> None:
    """Grid at the ticks (unless not ``grid``), the box, tick marks and numbers on the left and bottom edges, and
    the axis labels (``ylabel`` turned a quarter) of ``panel`` on ``image``."""
    draw = ImageDraw.Draw(image)
    left, top, right, bottom = panel.box
    x0, x1, y0, y1 = panel.limits
    small = font(size_px)
    xs, x_step = ticks(x0, x1, max(2, (right - left) // 110))
    ys, y_step = ticks(y0, y1, max(2, (bottom - top) // 60))
    for u, _ in panel.pixels(xs, y0):
        if grid:
            draw.line([(u, top), (u, bottom)], fill=GRID)
        draw.line([(u, bottom), (u, bottom + TICK_PX)], fill=INK)
    for y, (_, v) in zip(ys, panel.pixels(x0, ys)):
        if grid:
            draw.line([(left, v), (right, v)], fill=GRID)
        draw.line([(left - TICK_PX, v), (left, v)], fill=INK)
        draw.text((left - TICK_PX - 3, v), tick_label(float(y), y_step), INK, small,
                  anchor="rm")
    if x_numbers:
        for x, (u, _) in zip(xs, panel.pixels(xs, y0)):
            draw.text((u, bottom + TICK_PX + 2), tick_label(float(x), x_step), INK, small,
                      anchor="ma")
    draw.rectangle(panel.box, outline=INK)
    label = font(size_px + 2)
    if xlabel:
        draw.text(((left + right) / 2, bottom + TICK_PX + size_px + 8), xlabel, INK, label,
                  anchor="ma")
    if ylabel:
        width = max(int(label.getlength(max(ylabel.split("\n"), key=len))) + 4, 1)
        strip = Image.new("L", (width, size_px + 8), 0)
        ImageDraw.Draw(strip).text((width / 2, (size_px + 8) / 2), ylabel, 255, label,
                                   anchor="mm")
        strip = strip.rotate(90, expand=True)
        widest = max((small.getlength(tick_label(float(y), y_step)) for y in ys), default=0)
        at = (int(left - TICK_PX - widest - 10 - strip.width), (top + bottom - strip.height) // 2)
        image.paste(INK, (*at, at[0] + strip.width, at[1] + strip.height), strip)


def polyline(image: Image.Image, panel: Panel, x, y, colour, width: int = 1) -> None:
    """The line through the points (x, y) of ``panel``, broken where a value is NaN (not
    clipped: the panel's limits are expected to hold the points)."""
    points = panel.pixels(x, y)
    finite = np.isfinite(points).all(axis=1)
    edges = np.diff(np.concatenate(([0], finite.astype(np.int8), [0])))
    draw = ImageDraw.Draw(image)
    for start, stop in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
        run = [tuple(p) for p in points[start:stop].tolist()]
        draw.line(run * 2 if len(run) == 1 else run, fill=colour, width=width,
                  joint="curve" if width > 1 else None)


def spans(image: Image.Image, panel: Panel, starts, stops, colour=SPAN) -> None:
    """Shade the x intervals [starts[i], stops[i]] of ``panel`` over its whole height."""
    draw = ImageDraw.Draw(image)
    _, top, _, bottom = panel.box
    for a, b in zip(panel.pixels(starts, 0.0)[:, 0], panel.pixels(stops, 0.0)[:, 0]):
        draw.rectangle((a, top + 1, b, bottom - 1), fill=colour)


def legend(image: Image.Image, panel: Panel, entries, size_px: int = 15) -> None:
    """(label, colour) entries as short coloured lines and their labels, top right of
    ``panel``."""
    draw = ImageDraw.Draw(image)
    small = font(size_px)
    right, top = panel.box[2] - 8, panel.box[1] + 6
    for row, (label, colour) in enumerate(entries):
        v = top + row * (size_px + 4) + size_px / 2
        end = right - small.getlength(label) - 6
        draw.line([(end - 28, v), (end, v)], fill=colour, width=2)
        draw.text((right, v), label, INK, small, anchor="rm")


def heading(image: Image.Image, lines, top: int = 6, size_px: int = 17) -> int:
    """``lines`` of text centred at the top of ``image``; returns the row below them."""
    draw = ImageDraw.Draw(image)
    for line in lines:
        draw.text((image.width / 2, top), line, INK, font(size_px), anchor="ma")
        top += size_px + 5
    return top


__all__ = ["Panel", "data_limits", "font", "frame", "heading", "legend", "nice_step",
           "polyline", "spans", "tick_label", "ticks"]
