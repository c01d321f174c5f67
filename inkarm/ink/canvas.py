"""The ink raster: a sheet of paper that the simulated pen marks while it touches it.

Page frame: origin at the paper's lower-left corner, x to the right, y up, in [mm]. The raster
has ``round(width_mm * px_per_mm)`` columns and ``round(height_mm * px_per_mm)`` rows, row 0 at
the top of the page; pixel (i, j) has its centre at

    x = (j + 1/2) / px_per_mm,    y = (n_rows - i - 1/2) / px_per_mm        [mm].

The plant calls :meth:`Canvas.touch` at every physics step while the pen tip touches the paper
and :meth:`Canvas.lift` when contact ends, or :meth:`Canvas.touch_many` with a control period's
steps (the same canvas, with a fraction of the Python per step). Successive touch points are joined by anti-aliased
capsules (the set of points within a radius of a segment, the radius varying linearly along
it), so a fast stroke is a continuous line however far the pen moves in one step. To keep a
physics step cheap, a segment is only rasterised once the pen has moved ``max_segment_mm`` or
the ink width or opacity has changed noticeably since the last rasterised point; the pending
end point is flushed on lift. The chord error this introduces on a curve of radius R is
``max_segment_mm**2 / (8 R)`` (0.016 mm for the default 0.5 mm on a 2 mm radius). Capsules
are queued and rasterised together (:mod:`inkarm.ink.capsules`: at a lift, when the raster is
read, or every 256, in batches of alike boxes), the very pixels one at a time would give, at a
fraction of numpy's per-call cost. The composite image is brought up to date when it is read
and at a lift; a stroke that nobody reads before its lift is composited once, in place.

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
from inkarm.ink.capsules import CAPSULE_FIELDS, rasterise
from inkarm.ink.checks import FORCE_SCALE_RANGE_N, WIDTH_RANGE_MM, require_positive
from inkarm.ink.compiled_pen import pen_module, touch_rows
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
# Capsules queued before they are rasterised (Canvas._rasterise_queue), their fields flat, then
# rasterised in batches of _BATCH alike boxes: enough to spread numpy's per-call cost, few enough
# that the padded (K, H, W) arrays stay small.
_QUEUE_LENGTH = 256
_QUEUE_FLOATS = _QUEUE_LENGTH * CAPSULE_FIELDS
_BATCH = 64
# ... and at most this many padded pixels K * H * W (about 24 bytes each in the temporaries), so
# that a batch of wide capsules at a fine resolution does not allocate hundreds of MB.
_QUEUE_PIXELS = 1 << 21
# The pen between physics steps (Canvas._touch_rows): in contact; the last touch (x, y) [mm] and
# t [s]; the low-passed speed [mm/s] (None before known); the pen-down force [N] until its point
# is laid (else None); the last laid point (x, y, width [mm], opacity); whether a pending end
# waits, and it (x, y, width, opacity); the last dt [s] and the speed filter's gain at it.
_PEN_UP = (False, 0.0, 0.0, 0.0, None, None, 0.0, 0.0, 0.0, 0.0, False, 0.0, 0.0, 0.0, 0.0,
           None, 0.0)


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
        self._stroke = np.zeros(self.shape, np.float32)  # the stroke in progress
        self._image = np.zeros(self.shape, np.float32)  # 1 - (1 - base)(1 - stroke)
        # capsules not yet in _stroke, their fields (inkarm.ink.capsules) one after the other
        self._queue: list[float] = []
        self._stroke_box: list[int] | None = None  # [r0, r1, c0, c1) touched by the stroke
        # The ink before this stroke (the base) in _base, only inside _saved_box; None: the image
        # has not been composited since the stroke began, so it is that ink itself. _base is
        # made at the first composite during a stroke (a reader mid-stroke; else never).
        self._saved_box: list[int] | None = None
        self._base: np.ndarray | None = None
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
        force = float(force_n)
        if not (force >= 0.0 and math.isfinite(force)):
            raise InputError(f"Canvas.touch: force_n must be finite and >= 0, got {force_n!r}")
        self._touch_rows(((force, float(p_mm[0]), float(p_mm[1]), float(t)),), False)

    def touch_many(self, steps) -> None:
        """The calls of a control period's physics steps ``steps`` = ((force [N], x [mm],
        y [mm], t [s]), ...) (floats, or an (n, 4) array) in one: :meth:`touch` at each step
        whose force is positive, :meth:`lift` at the others (a no-op out of contact); the same
        canvas as those calls one at a time (:func:`inkarm.sim.compiled.feed`). A marker's pen
        runs in C where it can (:mod:`inkarm.ink.compiled_pen`: the same bits)."""
        if not self._pen[0]:  # out of contact: nothing to do unless a step touches
            for step in steps:
                if step[0] > 0.0:
                    break
            else:
                return
        pen = pen_module() if type(self.ink) is MarkerInk and self._path is None else None
        if pen is None:
            self._touch_rows(np.asarray(steps, float).tolist()
                             if isinstance(steps, np.ndarray) else steps, True)
        else:
            touch_rows(self, pen, steps, _QUEUE_FLOATS)

    def _touch_rows(self, rows, lifts: bool) -> None:
        """:meth:`touch` for each (force [N] >= 0, x [mm], y [mm], t [s]) of ``rows`` (floats);
        ``lifts``: :meth:`lift` instead where the force is not positive. The pen's state
        (``_pen``) is held in local variables meanwhile, stored back even when a row is refused.

        The pen speed is a first-order low pass of the finite difference over dt, gain
        1 - exp(-dt / speed_tau_s); a capsule from the last laid point (sx, sy, width sw,
        opacity sa) is queued once the pen moved ``max_segment_mm`` or the width or opacity
        changed by half a pixel or 0.05, else the point waits as the pending end (px, py)."""
        mark, tau, ppm, queue = self.ink.mark, self.speed_tau_s, self.px_per_mm, self._queue
        segment2, isfinite, path = self.max_segment_mm**2, math.isfinite, self._path
        (down, lx, ly, lt, speed, first, sx, sy, sw, sa, waiting, px, py, pw, pa, gain_dt,
         gain) = self._pen
        try:
            for force, x, y, t in rows:
                if lifts and not force > 0.0:
                    if down:
                        self._pen = (down, lx, ly, lt, speed, first, sx, sy, sw, sa, waiting, px,
                                     py, pw, pa, gain_dt, gain)
                        self.lift()
                        path = self._path
                        (down, lx, ly, lt, speed, first, sx, sy, sw, sa, waiting, px, py, pw,
                         pa, gain_dt, gain) = self._pen
                    continue
                # (x + y + t + force) * 0 is 0 unless one is not finite (or the sum overflows)
                if (x + y + t + force) * 0.0 != 0.0 and not (
                        isfinite(x) and isfinite(y) and isfinite(t) and isfinite(force)):
                    raise InputError(f"Canvas.touch: non-finite p_mm ({x}, {y}) or t = {t}"
                                     if isfinite(force) else
                                     f"Canvas.touch: force_n must be finite and >= 0, got "
                                     f"{force!r}")
                if not down:  # pen down: wait for the next step to know the speed
                    if path is not None:
                        path.append((x, y, force))
                    down, lx, ly, lt, first, waiting = True, x, y, t, force, False
                    continue
                if t < lt:
                    raise InputError(f"Canvas.touch: time went backwards, t = {t} < previous {lt}")
                if path is not None:
                    path.append((x, y, force))
                dt = t - lt
                if dt > 0.0:
                    dx, dy = x - lx, y - ly  # (not math.hypot: the C pen's arithmetic)
                    raw = math.sqrt(dx * dx + dy * dy) / dt
                    if speed is None:
                        speed = raw
                    else:
                        if dt != gain_dt:  # (the physics step: the same dt at every step)
                            gain_dt, gain = dt, 1.0 - math.exp(-dt / tau)
                        speed += gain * (raw - speed)
                if first is not None:  # the pen-down point, now that the speed is known
                    sw, sa = mark(first, speed or 0.0)
                    sx, sy, first = lx, ly, None
                    queue.extend((sx, sy, sw, sx, sy, sw, sa))
                lx, ly, lt = x, y, t
                width, opacity = mark(force, speed or 0.0)
                if opacity <= 0.0:  # below the ink's threshold: finish what was laid, lay nothing
                    if waiting:
                        queue.extend((sx, sy, sw, px, py, pw, pa))
                        waiting = False
                    sx, sy, sw, sa = x, y, width, 0.0
                elif (
                    (x - sx) * (x - sx) + (y - sy) * (y - sy) >= segment2
                    or abs(width - sw) * ppm >= 0.5
                    or abs(opacity - sa) >= 0.05
                ):
                    queue.extend((sx, sy, sw, x, y, width, opacity))
                    sx, sy, sw, sa, waiting = x, y, width, opacity, False
                    if len(queue) >= _QUEUE_FLOATS:
                        self._rasterise_queue()
                else:
                    px, py, pw, pa, waiting = x, y, width, opacity, True
        finally:
            self._pen = (down, lx, ly, lt, speed, first, sx, sy, sw, sa, waiting, px, py, pw, pa,
                         gain_dt, gain)

    def lift(self) -> None:
        """The pen left the paper: finish the stroke in progress (no-op when none is)."""
        down, lx, ly, _, _, first, sx, sy, sw, _, waiting, px, py, pw, pa, *_ = self._pen
        if not down:
            return
        if first is not None:  # a single touch: a dot, the pen at rest
            width, opacity = self.ink.mark(first, 0.0)
            self._stamp(lx, ly, width, lx, ly, width, opacity)
        elif waiting:
            self._stamp(sx, sy, sw, px, py, pw, pa)
        if self._path:
            self._texture_stroke()
        self._refresh(final=True)
        if self._stroke_box is not None:
            r0, r1, c0, c1 = self._stroke_box
            self._stroke[r0:r1, c0:c1] = 0.0
        self._stroke_box = self._saved_box = None
        self.n_strokes += 1
        self._reset_pen()

    @property
    def in_contact(self) -> bool:
        """Whether a stroke is in progress (touched since the last lift)."""
        return self._pen[0]

    def clear(self, ink: InkModel | None = None) -> None:
        """Blank the page (and forget any stroke in progress); with ``ink``, draw in it from
        now on (a page reused for another drawing gets a fresh ink). Only the inked box is
        written: every capsule, and so every non-zero pixel of the stroke and of the image,
        lies in it."""
        if ink is not None:
            self.ink, self._textured = ink, isinstance(ink, TexturedInk)
        self._queue.clear()
        if self._inked_box is not None:
            r0, r1, c0, c1 = self._inked_box
            for buf in (self._stroke, self._image):
                buf[r0:r1, c0:c1] = 0.0
            self._dirty_box = _union(self._dirty_box, self._inked_box)
        self._stroke_box = self._stale_box = self._saved_box = None
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
    def inked_box(self) -> tuple[int, int, int, int] | None:
        """The pixel box (r0, r1, c0, c1), half-open, that every capsule since the page was
        blank lies in: outside it the page is 0. None on a blank page."""
        self._rasterise_queue()
        return None if self._inked_box is None else tuple(self._inked_box)

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
        # (2-D uint8: mode "L"; zlib's fastest level: half the time of the default, and a page
        # that is mostly blank still packs to tens of kB)
        Image.fromarray(grey).save(path, format="PNG", compress_level=1)
        return path

    def take_dirty_box(self) -> tuple[int, int, int, int] | None:
        """The pixel box (r0, r1, c0, c1), half-open, changed since the previous call, or None
        when nothing changed. For one consumer (the texture uploader) only."""
        self._rasterise_queue()
        box, self._dirty_box = self._dirty_box, None
        return None if box is None else tuple(box)

    # -- rasterisation ----------------------------------------------------------------------

    def _refresh(self, final: bool = False) -> None:
        """Bring the composite image up to date with the stroke in progress, 1 - (1 - base)
        (1 - stroke) on the stale box; ``final`` (at a lift): the stroke may be overwritten.

        Until the first composite of a stroke the image is the ink before it (the base) and the
        final one runs in place on the image; a composite during a stroke first keeps the base
        of the box it overwrites in ``_base`` (:meth:`_save_base`)."""
        self._rasterise_queue()
        if self._stale_box is None:
            return
        r0, r1, c0, c1 = self._stale_box
        image, stroke = self._image[r0:r1, c0:c1], self._stroke[r0:r1, c0:c1]
        if final and self._saved_box is None:  # the same arithmetic, no temporaries
            np.subtract(1.0, stroke, out=stroke)
            np.subtract(1.0, image, out=image)
            image *= stroke
            np.subtract(1.0, image, out=image)
        else:
            base = self._save_base(self._stale_box)[r0:r1, c0:c1]
            image[...] = 1.0 - (1.0 - base) * (1.0 - stroke)
        self._stale_box = None

    def _save_base(self, box: list[int]) -> np.ndarray:
        """Grow ``_saved_box`` to cover ``box``, copying the image into ``_base`` where it was
        not saved yet (there the image has not been composited in this stroke: it is the base);
        the new part is the grown box less the old one, at most four bands. Returns _base."""
        if self._base is None:
            self._base = np.zeros(self.shape, np.float32)
        saved = self._saved_box
        grown = _union(saved, box)
        if saved == grown:
            return self._base
        g0, g1, gc0, gc1 = grown
        s0, s1, sc0, sc1 = saved if saved is not None else (g0, g0, gc0, gc0)
        for r0, r1, c0, c1 in ((g0, s0, gc0, gc1), (s1, g1, gc0, gc1), (s0, s1, gc0, sc0),
                               (s0, s1, sc1, gc1)):
            self._base[r0:r1, c0:c1] = self._image[r0:r1, c0:c1]
        self._saved_box = grown
        return self._base

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
        self._pen = _PEN_UP

    def _stamp(
        self, x0: float, y0: float, w0: float, x1: float, y1: float, w1: float, opacity: float
    ) -> None:
        """Max-composite into the stroke the capsule from (x0, y0) of width w0 to (x1, y1) of
        width w1 (all in [mm]) with anti-aliased coverage times ``opacity``.

        The capsule is queued and its pixels computed with the rest of the queue
        (:meth:`_rasterise_queue`) when the raster is next read, at a lift, or once
        ``_QUEUE_LENGTH`` capsules wait: numpy's cost per call, not per pixel, dominates a
        capsule of a few hundred pixels, and the maximum does not depend on the order."""
        self._queue.extend((x0, y0, w0, x1, y1, w1, opacity))
        if len(self._queue) >= _QUEUE_FLOATS:
            self._rasterise_queue()

    def _rasterise_queue(self) -> None:
        """Max-composite the queued capsules into the stroke (:func:`inkarm.ink.capsules.
        rasterise`: ``_BATCH`` alike boxes, at most ``_QUEUE_PIXELS`` padded pixels at a time),
        and account for those on the page in the boxes and the revision."""
        if not self._queue:
            return
        caps = np.array(self._queue).reshape(-1, CAPSULE_FIELDS)
        self._queue.clear()
        box, count = rasterise(self._stroke, caps, self.px_per_mm, _BATCH, _QUEUE_PIXELS)
        if box is None:
            return
        for name in ("_stroke_box", "_stale_box", "_dirty_box", "_inked_box"):
            setattr(self, name, _union(getattr(self, name), box))
        self._revision += count


def pixel_centres_mm(rows, cols, n_rows: int, px_per_mm: float) -> np.ndarray:
    """Page coordinates in [mm], shape (M, 2), of raster pixels (rows, cols) of a raster with
    ``n_rows`` rows at ``px_per_mm``, row 0 at the top (the convention of :class:`Canvas`)."""
    rows = np.asarray(rows, dtype=float)
    cols = np.asarray(cols, dtype=float)
    return np.column_stack(((cols + 0.5) / px_per_mm, (n_rows - rows - 0.5) / px_per_mm))


def _union(box: list[int] | None, other: list[int]) -> list[int]:
    """The least box [r0, r1, c0, c1) holding ``box`` (None: nothing) and ``other``."""
    if box is None:
        return list(other)
    return [
        min(box[0], other[0]),
        max(box[1], other[1]),
        min(box[2], other[2]),
        max(box[3], other[3]),
    ]
