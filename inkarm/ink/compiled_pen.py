"""The felt-tip marker's pen between physics steps in C (``inkarm/ink/_pen.c``): whether this
process may use it, and the canvas's loop around it.

:meth:`inkarm.ink.canvas.Canvas.touch_many` hands its rows to :func:`touch_rows` when the ink is
a :class:`~inkarm.ink.marker.MarkerInk` (not a subclass: its law is the C one) and the module
is usable, else it runs its Python loop (``Canvas._touch_rows``), which is the reference and
gives the same bits (tests/ink/test_compiled_pen.py). The C walks the rows and returns to
Python where the canvas must act: a lift, a full capsule queue, or a row it refuses (the
Python loop then raises its own message on that row, from the same pen). It is used only when
the extension is built by pip (``setup.py``; optional), is of this source (``API``), and the
environment variable ``INKARM_COMPILED`` is not ``0`` (the switch of every compiled part).
"""

from __future__ import annotations

import logging

import numpy as np

from inkarm.core.compiled import loader, switched_on

_LOG = logging.getLogger(__name__)
API = 2  # (inkarm/ink/_pen.c's INKARM_PEN_API)


# the module, or None (why logged once)
_load = loader("inkarm.ink._pen", API, "compiled pen", _LOG)


def pen_module():
    """The extension module (``advance``), or None: switched off with ``INKARM_COMPILED=0``, or
    not usable here (logged once, debug)."""
    return _load() if switched_on() else None


def touch_rows(canvas, pen, steps, queue_floats: int) -> None:
    """``canvas.touch_many(steps)`` for a marker through the C pen ``pen`` (:func:`pen_module`):
    rows (force [N], x [mm], y [mm], t [s]), ``queue_floats`` the length at which the canvas
    rasterises its capsule queue."""
    rows = np.ascontiguousarray(steps, dtype=np.float64)
    if rows.ndim != 2 or rows.shape[1] != 4:  # (the Python loop names what is wrong)
        canvas._touch_rows(steps, True)
        return
    ink = canvas.ink
    law = (ink.w0_mm, ink.k_mm, ink.f0_n, ink.opacity, ink.threshold_n)
    motion = (canvas.speed_tau_s, canvas.px_per_mm, canvas.max_segment_mm**2)
    i, n = 0, len(rows)
    while i < n:
        canvas._pen, i, why = pen.advance(canvas._pen, rows, i, law, motion,
                                          canvas._queue, queue_floats)
        if why == pen.LIFT:
            canvas.lift()
        elif why == pen.FLUSH:
            canvas._rasterise_queue()
        elif why != pen.DONE:  # a row refused: the reference raises its message on it
            canvas._touch_rows(rows[i : i + 1].tolist(), True)
            raise AssertionError(f"the C pen refused row {i} ({why}), the Python loop did not")


__all__ = ["API", "pen_module", "touch_rows"]
