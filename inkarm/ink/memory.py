"""The raster's size and memory: pixel counts of a page and the budget check made before a
canvas allocates anything.

A canvas holds three float32 rasters of the page (12 bytes per pixel), and a whole run
(drawing, metrics, canvas.png, report) peaks at about :data:`RASTER_BYTES_PER_PX` per page pixel
above the interpreter's baseline; :func:`require_raster_memory` refuses a page whose estimate
(:func:`raster_bytes`) exceeds the memory budget (``INKARM_MAX_MEMORY_MB``, see
:mod:`inkarm.core.budget`).
"""

from __future__ import annotations

import math

from inkarm.core.budget import require_memory
from inkarm.errors import InputError
from inkarm.ink.checks import require_positive

# Peak memory of a whole drawing run per page pixel, in bytes: the canvas's three float32
# rasters (12 bytes, written in full at construction) and the 8-bit grey image of canvas.png
# (1 byte), rounded up. benchmarks/bench_memory.py measures the default scenario (run and
# written, report included) at 10, 20 and 40 px/mm: peak RSS = about 210 MB + 12.7 to 13.1
# bytes x page pixels (the constant: 133 MB of imports, MuJoCo's model, the log, the figure).
# Metrics and report work on the ink's bounding box, so they add memory in proportion to the
# ink.
RASTER_BYTES_PER_PX = 14.0


def raster_shape(size_mm: tuple[float, float], px_per_mm: float) -> tuple[int, int]:
    """(rows, cols) of the raster of a page of ``size_mm`` = (width, height) in [mm] at
    ``px_per_mm``: ``round(height * px_per_mm)``, ``round(width * px_per_mm)``. Refuses
    non-positive or non-finite sizes and resolutions, and a raster whose pixel count is not a
    finite number, with an InputError naming the field."""
    width_mm, height_mm = (float(v) for v in size_mm)
    require_positive("Canvas", width_mm=width_mm, height_mm=height_mm, px_per_mm=px_per_mm)
    rows, cols = height_mm * px_per_mm, width_mm * px_per_mm
    if not math.isfinite(rows * cols):
        raise InputError(
            f"Canvas: a raster of {width_mm:g} x {height_mm:g} mm at {px_per_mm:g} px/mm has "
            f"{cols:.3g} x {rows:.3g} pixels, beyond any memory", key="px_per_mm",
            value=px_per_mm)
    return round(rows), round(cols)


def raster_bytes(size_mm: tuple[float, float], px_per_mm: float) -> float:
    """Estimated peak memory in [bytes] that a drawing run spends on the raster of a page of
    ``size_mm`` (width, height) in [mm] at ``px_per_mm``: :data:`RASTER_BYTES_PER_PX` per
    pixel (the canvas, canvas.png; not the interpreter's own baseline)."""
    rows, cols = raster_shape(size_mm, px_per_mm)
    return RASTER_BYTES_PER_PX * float(rows) * float(cols)


def require_raster_memory(size_mm: tuple[float, float], px_per_mm: float) -> None:
    """Refuse (:class:`inkarm.core.budget.BudgetError`, key ``ink.px_per_mm``) a page whose
    :func:`raster_bytes` exceed the memory budget ``INKARM_MAX_MEMORY_MB``."""
    rows, cols = raster_shape(size_mm, px_per_mm)
    width_mm, height_mm = (float(v) for v in size_mm)
    require_memory(
        raster_bytes(size_mm, px_per_mm),
        f"the ink raster of a {width_mm:g} x {height_mm:g} mm page at {px_per_mm:g} px/mm "
        f"({cols:,} x {rows:,} pixels, {RASTER_BYTES_PER_PX:g} bytes each for a run)",
        key="ink.px_per_mm", value=px_per_mm)
