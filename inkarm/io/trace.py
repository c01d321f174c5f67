"""Traces to analyse or restyle: a CSV of time-stamped samples, or the shapes of an SVG file.

CSV files are read with :meth:`Drawing.from_csv` (``t,x,y[,z][,stroke]``). SVG files are read
as vpype reads them, with the ``svgelements`` library: every shape (``<path>``, ``<line>``,
``<polyline>``, ``<polygon>``, ``<rect>``, ``<circle>``, ``<ellipse>``, and ``<use>`` of
elements, groups and symbols) that is seen on white paper is flattened, mapped to the page
frame in [mm] (y up, origin at the page's lower-left corner; transforms, nested ``<svg>``
viewports and ``<use>`` offsets applied) and sampled uniformly in arc length, each sub-path a
stroke traced at a constant ``speed``; consecutive samples are at most ``speed / rate`` apart.
What is drawn, what is not (hidden, unpainted, white, text, images) and the layers (vpype's
convention, top-level groups) are set out in :mod:`inkarm.io.svgdraw`; the tree's preparation
and its bounds (``<use>`` expansion) in :mod:`inkarm.io.svgtree`. An SVG with nothing to draw
is refused, saying what was skipped.

The drawing's ``meta`` holds ``"svg_skipped"``, {reason: count} of the elements not drawn
(:func:`skipped_summary` says it in one line), and, when the file has top-level groups,
``"layers"``, the vpype layer id of each stroke (int64, in stroke order).

Units: a root ``width``/``height`` with a unit (mm, cm, in, pt, pc, px) fixes the page size;
a bare number is CSS pixels (1/96 in); a ``viewBox`` is fitted into that page as SVG says
(``preserveAspectRatio``, by default centred and uniformly scaled). With neither width nor
height, one user unit is one millimetre (as :meth:`Drawing.to_svg` writes) and the page is
the viewBox, or A4 without one.

Before svgelements sees the file, the XML is parsed and checked here: every ``d``,
``points``, ``transform`` and shape length that is drawn must follow the SVG grammar
(svgelements would silently drop what follows a typo), nesting is at most :data:`MAX_DEPTH`
elements deep and the document at most :data:`~inkarm.io.svgtree.MAX_ELEMENTS` elements,
``<use>`` expanded; the flattened drawing at most :data:`MAX_SAMPLES` points, every point
within :data:`~inkarm.core.trajectory.MAX_COORD_MM` of the page origin, and the page no
larger. The sampled trace is estimated (length / speed x rate samples) before it is sampled
and refused beyond ``INKARM_MAX_STEPS`` (:mod:`inkarm.core.budget`); ``speed`` and ``rate``
must lie in :data:`SPEED_RANGE` and :data:`RATE_RANGE`. Every problem is an
:class:`~inkarm.errors.InputError` naming the file and the element (or the setting).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import svgelements as se

from inkarm.core.budget import STEPS, require
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InkarmError, InputError
from inkarm.io.svgdraw import (
    CURVE_POINTS,
    MAX_SAMPLES,
    MIN_LENGTH_MM,
    Piece,
    drawn,
    path_polylines,
    svgelements_call,
)
from inkarm.io.svggrammar import check_path_data, check_transform
from inkarm.io.svgtree import MAX_DEPTH, page, prepare, read_xml

__all__ = [
    "CURVE_POINTS", "DEFAULT_RATE", "DEFAULT_SPEED", "MAX_DEPTH", "MAX_SAMPLES",
    "MIN_LENGTH_MM", "RATE_RANGE", "SPEED_RANGE", "check_path_data", "check_transform",
    "load_trace", "parse_path_data", "read_svg", "resample_arc_length", "skipped_summary",
    "timed_by_length",
]

DEFAULT_SPEED = 50.0
"""Pen speed along an SVG path in [mm/s]."""
DEFAULT_RATE = 200.0
"""Sampling rate of an SVG path in [Hz]."""
SPEED_RANGE = (1e-3, 1e5)
"""Accepted pen speeds along an SVG path in [mm/s]."""
RATE_RANGE = (1e-3, 1e7)
"""Accepted sampling rates of an SVG path in [Hz]."""

SKIPPED_WORDS = {
    "hidden": "hidden",
    "no stroke or fill": "with no stroke or fill",
    "white on white": "white on white paper",
    "zero length": "of zero length",
    "text": "<text> (convert text to paths)",
    "image": "<image> (bitmaps are not drawn)",
    "foreignObject": "<foreignObject>",
    "unresolved <use>": "<use> of a missing element",
    "circular <use>": "<use> inside what it names",
}
"""How :func:`skipped_summary` says each reason of ``meta["svg_skipped"]``."""


def load_trace(
    path: str | Path, speed: float = DEFAULT_SPEED, rate: float = DEFAULT_RATE
) -> Drawing:
    """Read a trace from ``.csv`` (time-stamped samples) or ``.svg`` (shapes traced at
    ``speed`` [mm/s], sampled at ``rate`` [Hz])."""
    path = Path(path)
    if not path.is_file():
        raise InputError("no such file", file=str(path))
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return Drawing.from_csv(path)
    if suffix == ".svg":
        return read_svg(path, speed, rate)
    raise InputError(
        f"unknown trace format {suffix!r}; expected .csv or .svg", file=str(path), value=suffix
    )


def read_svg(path: str | Path, speed: float = DEFAULT_SPEED, rate: float = DEFAULT_RATE) -> Drawing:
    """The visible shapes of an SVG file as strokes sampled uniformly in arc length, one per
    sub-path (module docstring).

    Args:
        path: The SVG file.
        speed: Pen speed along every sub-path in [mm/s].
        rate: Sampling rate in [Hz]; samples are at most ``speed / rate`` [mm] apart.
    """
    path = Path(path)
    for name, value, (low, high), unit in (("speed", speed, SPEED_RANGE, "mm/s"),
                                           ("rate", rate, RATE_RANGE, "Hz")):
        if not (isinstance(value, (int, float)) and low <= value <= high):
            got = f"{value:g}" if isinstance(value, (int, float)) else repr(value)
            raise InputError(
                f"SVG trace {name} must lie in [{low:g}, {high:g}] {unit}, got {got}",
                file=str(path), key=name, value=value,
            )
    if not path.is_file():
        raise InputError("no such file", file=str(path))
    root = read_xml(path)
    try:
        size = page(root)
        dropped = prepare(root)
        doc = drawn(root, size)
    except InkarmError as e:
        raise e.within(file=str(path)) from None
    skipped = dict(dropped + doc.skipped)
    strokes = _strokes(doc.pieces, speed, rate, path)
    if not strokes:
        said = _summary(skipped)
        raise InputError(
            "no drawable shape (visible, of non-zero length) found"
            + (f"; {said}" if said else ""), file=str(path),
        )
    meta: dict = {"svg_skipped": skipped}
    if doc.has_layers:
        meta["layers"] = np.array([p.layer for p in doc.pieces], dtype=np.int64)
    return Drawing(strokes, page_size=size[:2], meta=meta)


def skipped_summary(drawing: Drawing) -> str | None:
    """One line saying what an SVG reading skipped (``meta["svg_skipped"]``), e.g. "skipped 3
    elements: 2 hidden, 1 <text> (convert text to paths)"; None when nothing was."""
    return _summary(drawing.meta.get("svg_skipped") or {})


def _summary(skipped: dict) -> str | None:
    total = sum(skipped.values())
    if not total:
        return None
    parts = [f"{n} {SKIPPED_WORDS.get(reason, reason)}"
             for reason, n in sorted(skipped.items(), key=lambda item: (-item[1], item[0])) if n]
    return f"skipped {total} element{'s' if total != 1 else ''}: " + ", ".join(parts)


def resample_arc_length(points: np.ndarray, spacing: float, min_points: int = 2
                        ) -> np.ndarray | None:
    """Points equally spaced in arc length, at most ``spacing`` apart and at least
    ``min_points`` of them, both ends kept; None for a polyline of zero length."""
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(steps)])
    if s[-1] <= 0:
        return None
    keep = np.concatenate([[True], steps > 0])
    s, points = s[keep], points[keep]
    targets = np.linspace(0.0, s[-1], max(min_points, math.ceil(s[-1] / spacing) + 1))
    return np.column_stack([np.interp(targets, s, c) for c in points.T])


def timed_by_length(pos: np.ndarray, speed: float) -> np.ndarray:
    """Times [s] of the points ``pos`` [mm] traced at a constant ``speed`` [mm/s]: cumulative
    arc length / speed, 0 at the first point."""
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pos, axis=0), axis=1))]) / speed


def parse_path_data(d: str, where: str = "path") -> list[np.ndarray]:
    """Flatten SVG path data into polylines in user units, one (n, 2) array per sub-path.

    The data is checked against the SVG path grammar first (InputError naming ``where``
    and the character at fault), then read by svgelements; curves (quadratic and cubic
    Beziers, elliptical arcs) become ``CURVE_POINTS`` points each, ending exactly on their
    end points.
    """
    check_path_data(d, where)
    return path_polylines(svgelements_call(lambda: se.Path(d), where), where)


def _strokes(pieces: list[Piece], speed: float, rate: float, path: Path) -> list[Trajectory]:
    """Each piece resampled every ``speed / rate`` [mm] and timed at ``speed`` [mm/s]; the
    number of samples, length / speed x rate, is checked against ``INKARM_MAX_STEPS`` first."""
    total = sum(p.length for p in pieces)
    require(total / speed * rate + len(pieces), STEPS,
            f"{total:.4g} mm of paths at {speed:g} mm/s sampled at {rate:g} Hz "
            f"(one sample every {speed / rate:.3g} mm); lower the rate or raise the speed",
            key="rate", value=rate, file=str(path))
    strokes = []
    for piece in pieces:  # every piece is longer than MIN_LENGTH_MM (svgdraw.drawn)
        pos = resample_arc_length(piece.points, speed / rate)
        strokes.append(Trajectory(t=timed_by_length(pos, speed), pos=pos))
    return strokes
