"""The ink models by name, and the interface the canvas uses.

An ink model turns the contact force [N] and the pen speed [mm/s] into a line width [mm] and an
opacity (:class:`InkModel`): :class:`~inkarm.ink.marker.MarkerInk` (no ink below a threshold
force, then a force-saturating width), :class:`~inkarm.ink.brush.BrushInk` (width an inverse
power of speed, seed 000 sec. 4 and GI sec. 5) and :class:`~inkarm.ink.pencil.PencilInk`
(force-dependent darkness, and the texture of a pencil grade, seed 002 ch. 4). A model may also
texture a finished stroke (:class:`TexturedInk`), which the canvas calls at each lift. Their
parameters are refused outside generous physical ranges, naming the field.

The ink registry (:data:`INKS`, ``inkarm.plugins.registry("ink")``) is the one list of ink
models. A scenario's ``[ink] model`` names one by its registered name, as
``"package.module:Class"``, or by an installed package's entry point ``ink.<name>`` in the group
``inkarm.plugins``; the ``[ink]`` table's other keys are the fields of its class. A new ink is
one module: a dataclass with ``mark(force_n, speed_mm_s) -> (width_mm, opacity)`` (and, if it
textures its strokes, ``texture_stroke``), plus at most one registration
(:meth:`~inkarm.plugins.Registry.register` or the entry point).
"""

from __future__ import annotations

import dataclasses
import inspect
from typing import Protocol, runtime_checkable

import numpy as np

from inkarm.errors import InputError
from inkarm.ink.brush import BrushInk
from inkarm.ink.marker import MarkerInk
from inkarm.ink.pencil import PencilInk
from inkarm.plugins import registry


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


INKS = registry("ink")
INKS.register("marker", MarkerInk)
INKS.register("brush", BrushInk)
INKS.register("pencil", PencilInk)

INK_MODELS = INKS
"""The ink registry under its old name (a mapping: ``INK_MODELS["marker"]``, ``sorted(...)``)."""


def ink_class(name: str, key: str | None = "ink.model") -> type:
    """The ink model class registered as ``name``, imported from ``"package.module:Class"`` or
    installed as the entry point ``ink.<name>``; an :class:`InputError` naming ``key`` when there
    is none or it is not an ink model (a dataclass with ``mark``)."""
    if ":" not in name and name not in INKS.names():
        raise InputError(f"ink model {name!r}: expected one of {sorted(INKS.names())}", key=key,
                         value=name, choices=tuple(sorted(INKS.names())))
    cls = INKS.get(name, key=key)
    if not (inspect.isclass(cls) and dataclasses.is_dataclass(cls)
            and callable(getattr(cls, "mark", None))):
        raise InputError(f"{name!r} is not an ink model: an ink model is a dataclass with "
                         f"mark(force_n, speed_mm_s) -> (width_mm, opacity)", key=key,
                         value=name)
    return cls


def make_ink(name: str, **params) -> InkModel:
    """The ink model called ``name`` (``"marker"``, ``"brush"``, ``"pencil"``, a plug-in's name
    or ``"package.module:Class"``) with the given parameters."""
    cls = ink_class(name, key=None)
    try:
        return cls(**params)
    except TypeError as err:
        raise InputError(f"ink model {name!r}: {err}") from None
