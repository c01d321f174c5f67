"""The ink models by name, and the interface the canvas uses.

An ink model turns the contact force [N] and the pen speed [mm/s] into a line width [mm] and an
opacity (:class:`InkModel`): :class:`~inkarm.ink.marker.MarkerInk` (no ink below a threshold
force, then a force-saturating width), :class:`~inkarm.ink.brush.BrushInk` (width an inverse
power of speed, seed 000 sec. 4 and GI sec. 5) and :class:`~inkarm.ink.pencil.PencilInk`
(force-dependent darkness, and the texture of a pencil grade, seed 002 ch. 4). A model may also
texture a finished stroke (:class:`TexturedInk`), which the canvas calls at each lift. Their
parameters are refused outside generous physical ranges, naming the field.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from inkarm.errors import InputError
from inkarm.ink.brush import BrushInk
from inkarm.ink.marker import MarkerInk
from inkarm.ink.pencil import PencilInk


class InkModel(Protocol):
    """Maps contact force and pen speed to the mark the pen leaves."""

    def mark(self, force_n: float, speed_mm_s: float) -> tuple[float, float]:
        """Line width in [mm] and opacity in [0, 1] for a contact force in [N] and a pen
        speed in [mm/s]."""
        ...


@runtime_checkable
class TexturedInk(Protocol):
    """An ink model that redraws each finished stroke (see
    :meth:`inkarm.ink.pencil.PencilInk.texture_stroke` for the arguments)."""

    def texture_stroke(self, points_px: np.ndarray, forces_n: np.ndarray,
                       coverage: np.ndarray, origin: tuple[int, int], px_per_mm: float,
                       stroke_index: int) -> np.ndarray:
        ...


INK_MODELS: dict[str, type] = {"marker": MarkerInk, "brush": BrushInk, "pencil": PencilInk}


def make_ink(name: str, **params) -> InkModel:
    """The ink model called ``name`` ("marker", "brush" or "pencil") with the given parameters."""
    if name not in INK_MODELS:
        raise InputError(f"ink model {name!r}: expected one of {sorted(INK_MODELS)}")
    try:
        return INK_MODELS[name](**params)
    except TypeError as err:
        raise InputError(f"ink model {name!r}: {err}") from None
