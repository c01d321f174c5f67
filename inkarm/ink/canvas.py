"""The ink raster: a sheet of paper that the simulated pen marks while it touches it.

Page frame: origin at the paper's lower-left corner, x to the right, y up, in [mm]. The raster
has ``round(width_mm * px_per_mm)`` columns and ``round(height_mm * px_per_mm)`` rows, row 0 at
the top of the page; pixel (i, j) has its centre at

    x = (j + 1/2) / px_per_mm,    y = (n_rows - i - 1/2) / px_per_mm        [mm].

The plant calls :meth:`Canvas.touch` at every physics step while the pen tip touches the paper
and :meth:`Canvas.lift` when contact ends. Successive touch points are joined by anti-aliased
capsules (the set of points within a radius of a segment, the radius varying linearly along
it), so a fast stroke is a continuous line however far the pen moves in one step. To keep a
physics step cheap, a segment is only rasterised once the pen has moved ``max_segment_mm`` or
the ink width or opacity has changed noticeably since the last rasterised point; the pending
end point is flushed on lift. The chord error this introduces on a curve of radius R is
``max_segment_mm**2 / (8 R)`` (0.016 mm for the default 0.5 mm on a 2 mm radius). Capsules
are queued and rasterised in batches (at a lift, when the raster is read, or every 64), the
very pixels one at a time would give, at a fraction of numpy's per-call cost.

Darkness is an opacity in [0, 1]. Strokes composite as ``1 - (1 - a)(1 - b)`` (two layers of
ink let through the product of their transmittances, so darkness never exceeds 1); within one
stroke the coverage is the maximum over its capsules, so that the heavily overlapping capsules
laid at successive steps do not darken their own anti-aliased edges.

Ink models (:mod:`inkarm.ink.inks`) turn the contact force [N] and the pen speed [mm/s] into
a line width [mm] and an opacity. A model that textures strokes (the pencil,
:class:`inkarm.ink.inks.TexturedInk`) gets the stroke's path and forces at the lift, and its
result replaces the stroke before it is composited; other models cost nothing extra per touch.

Memory: see :mod:`inkarm.ink.memory`; the constructor refuses a page whose estimated raster
memory exceeds the budget before it allocates anything.

This module also re-exports the ink models, the memory estimates and :func:`png_pixels`, so
``from inkarm.ink.canvas import Canvas, MarkerInk, require_raster_memory`` keeps working.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from inkarm.errors import InputError
from inkarm.ink.brush import BrushInk
from inkarm.ink.checks import FORCE_SCALE_RANGE_N, WIDTH_RANGE_MM, require_positive
from inkarm.ink.inks import INK_MODELS, InkModel, TexturedInk, make_ink
from inkarm.ink.marker import MarkerInk
from inkarm.ink.memory import (
    RASTER_BYTES_PER_PX,
    raster_bytes,
    raster_shape,
    require_raster_memory,
)
from inkarm.ink.pencil import PencilInk
from inkarm.ink.png import _GREY_LEVELS, png_pixels

__all__ = [
    "A4_MM", "FORCE_SCALE_RANGE_N", "INK_MODELS", "RASTER_BYTES_PER_PX", "WIDTH_RANGE_MM",
    "BrushInk", "Canvas", "InkModel", "MarkerInk", "PencilInk", "TexturedInk", "make_ink",
    "pixel_centres_mm", "png_pixels", "raster_bytes", "raster_shape", "require_raster_memory",
]

A4_MM = (210.0, 297.0)
# Capsules rasterised together (Canvas._rasterise_queue): enough to spread numpy's per-call
# cost, few enough that the padded (K, H, W) arrays stay small.
_QUEUE_LENGTH = 64
# ... and at most this many padded pixels K * H * W (about 24 bytes each in the temporaries), so
# that a batch of wide capsules at a fine resolution does not allocate hundreds of MB.
_QUEUE_PIXELS = 1 << 21


class Canvas:
    """An ink raster in page coordinates (see the module docstring for the pixel convention).

    Args:
        size_mm: Page (width, height) in [mm].
        px_per_mm: Raster resolution in [px/mm].
        ink: An ink model or the name of one (default "marker").
        max_segment_mm: Longest pen travel in [mm] left un-rasterised between physics steps.
        speed_tau_s: Time constant in [s] of the first-order low-pass filter on the pen speed
            given to the ink model (a physics step's finite difference is noisy).

    Raises:
        InputError: a size, resolution or parameter out of range (naming it).
        BudgetError: a page whose estimated raster memory (:func:`raster_bytes`) exceeds the
            budget ``INKARM_MAX_MEMORY_MB``; checked before anything is allocated.
    """

    def __init__(
        self,
        size_mm: tuple[float, float] = A4_MM,
        px_per_mm: float = 10.0,
        ink: InkModel | str = "marker",
        max_segment_mm: float = 0.5,
        speed_tau_s: float = 0.02,
    ) -> None:
        width_mm, height_mm = (float(v) for v in size_mm)
        require_positive(
            "Canvas",
            width_mm=width_mm,
            height_mm=height_mm,
            px_per_mm=px_per_mm,
            max_segment_mm=max_segment_mm,
            speed_tau_s=speed_tau_s,
        )
        self.size_mm = (width_mm, height_mm)
        self.px_per_mm = float(px_per_mm)
        self.ink: InkModel = make_ink(ink) if isinstance(ink, str) else ink
        self._textured = isinstance(self.ink, TexturedInk)
        self.max_segment_mm = float(max_segment_mm)
        self.speed_tau_s = float(speed_tau_s)
        self.shape = raster_shape((width_mm, height_mm), self.px_per_mm)
        if min(self.shape) < 1:
            raise InputError(f"Canvas: size_mm {size_mm} at {px_per_mm} px/mm has no pixels")
        require_raster_memory((width_mm, height_mm), self.px_per_mm)
        # Zeroed lazily by the OS: only the pages a drawing touches are ever faulted in (a 60 mm
        # letter: about 3 of an A4 page's 75 MB; writing them all up front cost 70 ms a run).
        self._base = np.zeros(self.shape, np.float32)  # strokes already lifted
        self._stroke = np.zeros(self.shape, np.float32)  # the stroke in progress
        self._image = np.zeros(self.shape, np.float32)  # 1 - (1 - base)(1 - stroke)
        # capsules (u0, v0, u1, v1, rad0, rad1, opacity, r0, r1, c0, c1) not yet in _stroke
        self._queue: list[tuple[float, ...]] = []
        self._queue_hw = (0, 0)  # largest box (rows, cols) in the queue
        self._stroke_box: list[int] | None = None  # [r0, r1, c0, c1) touched by the stroke
        self._stale_box: list[int] | None = None  # where _image lags behind _stroke
        self._dirty_box: list[int] | None = None  # touched since take_dirty_box()
        self._inked_box: list[int] | None = None  # every capsule since the page was blank
        self._revision = 0
        self.n_strokes = 0
        self._reset_pen()

    # -- the plant's interface ------------------------------------------------------------

    def touch(self, p_mm, force_n: float, t: float) -> None:
        """The pen tip touches the page at ``p_mm`` = (x, y) in [mm] with normal force
        ``force_n`` in [N] at time ``t`` in [s]. Call once per physics step while in contact."""
        x, y, force, t = float(p_mm[0]), float(p_mm[1]), float(force_n), float(t)
        if not (force >= 0.0 and math.isfinite(force)):
            raise InputError(f"Canvas.touch: force_n must be finite and >= 0, got {force_n!r}")
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(t)):
            raise InputError(f"Canvas.touch: non-finite p_mm ({x}, {y}) or t = {t}")
        if self._last is None:  # pen down: wait for the next step to know the speed
            if self._path is not None:
                self._path.append((x, y, force))
            self._last = (x, y, t)
            self._first_force = force
            self._pending = None
            return
        lx, ly, lt = self._last
        if t < lt:
            raise InputError(f"Canvas.touch: time went backwards, t = {t} < previous {lt}")
        if self._path is not None:
            self._path.append((x, y, force))
        dt = t - lt
        if dt > 0.0:
            raw = math.hypot(x - lx, y - ly) / dt
            if self._speed is None:
                self._speed = raw
            else:
                self._speed += (1.0 - math.exp(-dt / self.speed_tau_s)) * (raw - self._speed)
        if self._first_force is not None:
            width, opacity = self.ink.mark(self._first_force, self._speed or 0.0)
            self._stamp(lx, ly, width, lx, ly, width, opacity)
            self._stamped = (lx, ly, width, opacity)
            self._first_force = None
        self._last = (x, y, t)
        width, opacity = self.ink.mark(force, self._speed or 0.0)
        sx, sy, sw, sa = self._stamped
        if opacity <= 0.0:  # below the ink's threshold: finish what was laid, lay nothing
            if self._pending is not None:
                px, py, pw, pa = self._pending
                self._stamp(sx, sy, sw, px, py, pw, pa)
                self._pending = None
            self._stamped = (x, y, width, 0.0)
            return
        moved2 = (x - sx) ** 2 + (y - sy) ** 2
        if (
            moved2 >= self.max_segment_mm**2
            or abs(width - sw) * self.px_per_mm >= 0.5
            or abs(opacity - sa) >= 0.05
        ):
            self._stamp(sx, sy, sw, x, y, width, opacity)
            self._stamped = (x, y, width, opacity)
            self._pending = None
        else:
            self._pending = (x, y, width, opacity)

    def lift(self) -> None:
        """The pen left the paper: finish the stroke in progress (no-op when none is)."""
        if self._last is None:
            return
        if self._first_force is not None:  # a single touch: a dot, the pen at rest
            x, y, _ = self._last
            width, opacity = self.ink.mark(self._first_force, 0.0)
            self._stamp(x, y, width, x, y, width, opacity)
        elif self._pending is not None:
            sx, sy, sw, _ = self._stamped
            x, y, width, opacity = self._pending
            self._stamp(sx, sy, sw, x, y, width, opacity)
        if self._path:
            self._texture_stroke()
        self._refresh()
        if self._stroke_box is not None:
            r0, r1, c0, c1 = self._stroke_box
            self._base[r0:r1, c0:c1] = self._image[r0:r1, c0:c1]
            self._stroke[r0:r1, c0:c1] = 0.0
        self._stroke_box = None
        self.n_strokes += 1
        self._reset_pen()

    @property
    def in_contact(self) -> bool:
        """Whether a stroke is in progress (touched since the last lift)."""
        return self._last is not None

    def clear(self) -> None:
        """Blank the page (and forget any stroke in progress)."""
        self._queue.clear()
        self._queue_hw = (0, 0)
        for buf in (self._base, self._stroke, self._image):
            buf.fill(0.0)
        self._stroke_box = self._stale_box = None
        self._dirty_box = [0, self.shape[0], 0, self.shape[1]]
        self._inked_box = None
        self._revision += 1
        self.n_strokes = 0
        self._reset_pen()

    # -- reading the ink --------------------------------------------------------------------

    @property
    def revision(self) -> int:
        """A counter that grows at every change of the raster."""
        self._rasterise_queue()
        return self._revision

    @property
    def image(self) -> np.ndarray:
        """Darkness in [0, 1], shape (rows, cols), row 0 at the top of the page (a read-only
        view of the live raster: copy it to keep a snapshot)."""
        self._refresh()
        view = self._image.view()
        view.flags.writeable = False
        return view

    def pixel_centres_mm(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Page coordinates in [mm], shape (M, 2), of the centres of pixels (rows, cols)."""
        return pixel_centres_mm(rows, cols, self.shape[0], self.px_per_mm)

    def ink_points_mm(self, threshold: float = 0.5) -> np.ndarray:
        """Centres in [mm], shape (M, 2), of the pixels whose darkness is >= ``threshold``."""
        rows, cols = np.nonzero(self.image >= threshold)
        return self.pixel_centres_mm(rows, cols)

    def to_png(self, path: str | Path) -> Path:
        """Write the page as a PNG, black ink on white, and return its path.

        8-bit greyscale (PNG colour type 0, Pillow mode "L"), row 0 at the top: the grey levels
        that ``matplotlib.image.imsave(path, image, cmap="gray_r", vmin=0, vmax=1)`` wrote as
        R = G = B of an opaque RGBA image (see :func:`png_pixels`), written with Pillow. One
        byte per page pixel besides the canvas: white, and the box that every capsule since the
        page was blank lies in converted by :func:`png_pixels` (outside it the page is 0).
        """
        from PIL import Image

        path = Path(path)
        image = self.image
        grey = np.full(self.shape, _GREY_LEVELS[0], np.uint8)
        if self._inked_box is not None:
            r0, r1, c0, c1 = self._inked_box
            grey[r0:r1, c0:c1] = png_pixels(image[r0:r1, c0:c1])
        Image.fromarray(grey).save(path, format="PNG")  # 2-D uint8: mode "L"
        return path

    def take_dirty_box(self) -> tuple[int, int, int, int] | None:
        """The pixel box (r0, r1, c0, c1), half-open, changed since the previous call, or None
        when nothing changed. For one consumer (the texture uploader) only."""
        self._rasterise_queue()
        box, self._dirty_box = self._dirty_box, None
        return None if box is None else tuple(box)

    # -- rasterisation ----------------------------------------------------------------------

    def _refresh(self) -> None:
        """Bring the composite image up to date with the stroke in progress."""
        self._rasterise_queue()
        if self._stale_box is None:
            return
        r0, r1, c0, c1 = self._stale_box
        stroke, base = self._stroke[r0:r1, c0:c1], self._base[r0:r1, c0:c1]
        self._image[r0:r1, c0:c1] = 1.0 - (1.0 - base) * (1.0 - stroke)
        self._stale_box = None

    def _texture_stroke(self) -> None:
        """Replace the stroke just finished with the ink's texture of it (TexturedInk), on
        the stroke's box grown by a pixel (the texture's blur)."""
        self._rasterise_queue()
        if self._stroke_box is None:  # nothing laid (below the ink's threshold)
            return
        r0, r1, c0, c1 = self._stroke_box
        box = [max(r0 - 1, 0), min(r1 + 1, self.shape[0]), max(c0 - 1, 0),
               min(c1 + 1, self.shape[1])]
        r0, r1, c0, c1 = box
        path = np.asarray(self._path, dtype=float)
        ppm = self.px_per_mm
        points_px = np.column_stack([path[:, 0] * ppm - 0.5,
                                     self.shape[0] - path[:, 1] * ppm - 0.5])
        textured = self.ink.texture_stroke(  # type: ignore[attr-defined]
            points_px, path[:, 2], self._stroke[r0:r1, c0:c1].copy(), (r0, c0), ppm,
            self.n_strokes)
        self._stroke[r0:r1, c0:c1] = textured
        for name in ("_stroke_box", "_stale_box", "_dirty_box", "_inked_box"):
            setattr(self, name, _union(getattr(self, name), box))
        self._revision += 1

    def _reset_pen(self) -> None:
        self._path: list[tuple[float, float, float]] | None = [] if self._textured else None
        self._last: tuple[float, float, float] | None = None
        self._stamped: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
        self._pending: tuple[float, float, float, float] | None = None
        self._speed: float | None = None  # low-passed pen speed in [mm/s], None before known
        self._first_force: float | None = None  # the pen-down force, until its point is laid

    def _stamp(
        self, x0: float, y0: float, w0: float, x1: float, y1: float, w1: float, opacity: float
    ) -> None:
        """Max-composite into the stroke the capsule from (x0, y0) of width w0 to (x1, y1) of
        width w1 (all in [mm]) with anti-aliased coverage times ``opacity``.

        The capsule is queued and its pixels computed with the rest of the queue
        (:meth:`_rasterise_queue`) when the raster is next read, at a lift, or once
        ``_QUEUE_LENGTH`` capsules wait: numpy's cost per call, not per pixel, dominates a
        capsule of a few hundred pixels, and the maximum does not depend on the order."""
        ppm = self.px_per_mm
        n_rows, n_cols = self.shape
        # pixel-index coordinates: u along columns, v along rows (pixel centres at integers)
        u0, u1 = x0 * ppm - 0.5, x1 * ppm - 0.5
        v0, v1 = n_rows - y0 * ppm - 0.5, n_rows - y1 * ppm - 0.5
        rad0, rad1 = 0.5 * w0 * ppm, 0.5 * w1 * ppm
        reach = max(rad0, rad1) + 1.0
        c0 = max(0, math.floor(min(u0, u1) - reach))
        c1 = min(n_cols, math.ceil(max(u0, u1) + reach) + 1)
        r0 = max(0, math.floor(min(v0, v1) - reach))
        r1 = min(n_rows, math.ceil(max(v0, v1) + reach) + 1)
        if c0 >= c1 or r0 >= r1 or opacity <= 0.0:
            return
        height, width = max(self._queue_hw[0], r1 - r0), max(self._queue_hw[1], c1 - c0)
        if self._queue and (len(self._queue) + 1) * height * width > _QUEUE_PIXELS:
            self._rasterise_queue()  # wide capsules: a smaller batch (the same pixels)
            height, width = r1 - r0, c1 - c0
        self._queue.append((u0, v0, u1, v1, rad0, rad1, opacity, r0, r1, c0, c1))
        self._queue_hw = (height, width)
        if len(self._queue) >= _QUEUE_LENGTH:
            self._rasterise_queue()

    def _rasterise_queue(self) -> None:
        """Max-composite the queued capsules into the stroke, all at once on (K, H, W) arrays
        padded to the largest box, and account for them in the boxes and the revision.

        Coverage of pixel centre p (pixel units) by the capsule from a to b with radii r_a, r_b:
        s = clip((p - a) . (b - a) / |b - a|^2, 0, 1) (the nearest point of the segment),
        c = clip(r_a + s (r_b - r_a) + 1/2 - |p - a - s (b - a)|, 0, 1) times the opacity:
        the coverage ramps over one pixel across the edge, about the pixel's area inside. A
        capsule shorter than 1e-6 px is a disc of the larger radius."""
        if not self._queue:
            return
        caps = np.array(self._queue)
        self._queue.clear()
        self._queue_hw = (0, 0)
        u0, v0, u1, v1, rad0, rad1, opacity = caps[:, :7].T
        r0, r1, c0, c1 = caps[:, 7:].astype(np.intp).T
        box = [int(r0.min()), int(r1.max()), int(c0.min()), int(c1.max())]
        self._stroke_box = _union(self._stroke_box, box)
        self._stale_box = _union(self._stale_box, box)
        self._dirty_box = _union(self._dirty_box, box)
        self._inked_box = _union(self._inked_box, box)
        self._revision += len(caps)
        du, dv = u1 - u0, v1 - v0
        length2 = du * du + dv * dv
        segment = length2 > 1e-12
        safe2 = np.where(segment, length2, 1.0)
        along_u = np.where(segment, du / safe2, 0.0)
        along_v = np.where(segment, dv / safe2, 0.0)
        slope = np.where(segment, rad1 - rad0, 0.0)
        base = np.where(segment, rad0, np.maximum(rad0, rad1)) + 0.5

        def column(values: np.ndarray) -> np.ndarray:
            return values.astype(np.float32)[:, None, None]

        # pixel centres relative to the capsule's start: (K, 1, W) and (K, H, 1)
        pu = _offsets(c0 - u0, int((c1 - c0).max()))[:, None, :]
        pv = _offsets(r0 - v0, int((r1 - r0).max()))[:, :, None]
        s = pu * column(along_u) + pv * column(along_v)
        np.clip(s, 0.0, 1.0, out=s)
        ex, ey = pu - s * column(du), pv - s * column(dv)
        coverage = s * column(slope)
        coverage += column(base)
        coverage -= np.sqrt(ex * ex + ey * ey)
        np.clip(coverage, 0.0, 1.0, out=coverage)
        coverage *= column(opacity)
        for k in range(len(caps)):
            stroke = self._stroke[r0[k] : r1[k], c0[k] : c1[k]]
            np.maximum(stroke, coverage[k, : r1[k] - r0[k], : c1[k] - c0[k]], out=stroke)


def pixel_centres_mm(rows, cols, n_rows: int, px_per_mm: float) -> np.ndarray:
    """Page coordinates in [mm], shape (M, 2), of raster pixels (rows, cols) of a raster with
    ``n_rows`` rows at ``px_per_mm``, row 0 at the top (the convention of :class:`Canvas`)."""
    rows = np.asarray(rows, dtype=float)
    cols = np.asarray(cols, dtype=float)
    return np.column_stack(((cols + 0.5) / px_per_mm, (n_rows - rows - 0.5) / px_per_mm))


def _offsets(starts: np.ndarray, n: int) -> np.ndarray:
    """Rows ``starts[k] + j`` for j < n in float32, (K, n), each exactly as
    ``np.arange(starts[k], starts[k] + n, dtype=np.float32)`` computes it (first two values
    rounded from double, then first + j * (second - first) in float32), so that the batched
    capsules give the very pixels one capsule at a time would."""
    first = starts.astype(np.float32)[:, None]
    second = (starts + 1.0).astype(np.float32)[:, None]
    rows = first + np.arange(n, dtype=np.float32) * (second - first)
    rows[:, :1] = first
    rows[:, 1:2] = second
    return rows


def _union(box: list[int] | None, other: list[int]) -> list[int]:
    if box is None:
        return list(other)
    return [
        min(box[0], other[0]),
        max(box[1], other[1]),
        min(box[2], other[2]),
        max(box[3], other[3]),
    ]
