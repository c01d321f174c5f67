"""Pen recordings stored as SVG with the time of every point (issue 25, part 1): a drawing in
[mm] and [s], refused where the file holds no times (a recording without times gives no speed,
so no human statistic; inkarm never invents them for human measures).

There is no standard for time in SVG. Pen data with time is InkML's (W3C, 2011: a ``<trace>``
whose channels include ``T``); SVG exports of drawing apps and tablets keep the path only, and
the web apps that keep time store it in custom ``data-*`` attributes beside the points. SMIL
(``<animate begin dur>``, as handwriting animations use) times a whole element, not its
points: a constant speed along the path, which is refused like no time at all. inkarm reads:

* a **stroke** is a ``<polyline>`` (its ``points``) or a ``<path>`` of straight segments (``M``,
  ``L``, ``H``, ``V``; each ``M`` starts a stroke): its vertices are the samples. Curves,
  ``Z`` (no time for the closing point) and other shapes with times are refused;
* **times**: the attribute ``data-t`` (also spelt ``data-time``, ``data-times``,
  ``data-timestamps``): one number per vertex, separated by spaces or commas, strictly
  increasing within the element;
* **unit**: ``data-time-unit="s"`` or ``"ms"`` on the element or an ancestor (the root
  ``<svg>`` for the whole file); where the file says nothing, the caller's ``time_unit``;
* **pressure** (optional): ``data-pressure``, one number in [0, 1] per vertex; the pen is up
  where it is 0, and a stroke ends there (as a tablet CSV);
* **placement**: the points go through every transform, viewport and unit as
  :mod:`inkarm.io.trace` maps a path (the page frame in [mm], y up).

Drawn shapes without times (a border, a background) are left out and counted in
``meta["svg_skipped"]`` ("without time stamps"), which the commands print as a note. ``meta``:
``source`` ("svg"), ``file``, ``svg_skipped``.
"""

from __future__ import annotations

import io
import re
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

import numpy as np
import svgelements as se

from inkarm.core.trajectory import MAX_COORD_MM, Drawing, Trajectory
from inkarm.errors import InkarmError, InputError
from inkarm.io.svgdraw import svgelements_call
from inkarm.io.svgtree import page, prepare, read_xml

TIME_ATTRIBUTES = ("data-t", "data-time", "data-times", "data-timestamps")
"""Attributes holding the times of an element's vertices (module docstring)."""
UNIT_ATTRIBUTE = "data-time-unit"
"""Attribute naming the unit of the times, on the element or an ancestor."""
PRESSURE_ATTRIBUTE = "data-pressure"
"""Attribute holding the pen pressure in [0, 1] of an element's vertices."""
TIME_UNITS = {"s": 1.0, "ms": 1e-3}
"""Time units and their length in [s]."""
SMIL_TAGS = ("animate", "animateMotion", "animateTransform", "set")
"""SMIL elements: they time whole elements, not points."""
UNTIMED = "without time stamps"
"""The ``svg_skipped`` reason of drawn shapes that carry no times."""
SINGLE = "a single timed point"
"""The ``svg_skipped`` reason of a stroke of one sample (a dot: no movement to time)."""
NO_TIMES = ("no time stamps: a recording needs the time of every point for speed statistics; "
            "store them as data-t=\"t0 t1 ...\" (one per vertex) on each <polyline> or <path> "
            "with data-time-unit=\"ms\" or \"s\", or give a CSV t,x,y[,pressure]")
"""The message for an SVG without times, where times are needed."""
_SEPARATORS = re.compile(r"[\s,]+")


def _local(tag) -> str:
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else ""


def svg_has_times(path: str | Path) -> bool:
    """Whether any element of the SVG file carries one of :data:`TIME_ATTRIBUTES`; False for a
    file that cannot be read as XML (its reader says why)."""
    try:
        for _, elem in ET.iterparse(path):
            if any(name in elem.attrib for name in TIME_ATTRIBUTES):
                return True
    except (ET.ParseError, OSError, UnicodeError, ValueError):
        return False
    return False


def no_times_error(path: str | Path) -> InputError:
    """The error for an SVG recording without times (:data:`NO_TIMES`), saying where the file
    times whole elements with SMIL instead."""
    message = NO_TIMES
    try:
        smil = sum(1 for _, e in ET.iterparse(path) if _local(e.tag) in SMIL_TAGS)
    except (ET.ParseError, OSError, UnicodeError, ValueError):
        smil = 0
    if smil:
        message = (f"{smil} SMIL animation element{'s' if smil > 1 else ''} (<animate> ...) "
                   "time whole strokes, not their points (a constant speed); " + message)
    return InputError(message, file=str(path))


def read_timed_svg(path: str | Path, time_unit: str = "s") -> Drawing:
    """The timed strokes of an SVG pen recording (module docstring) as a drawing in [mm], [s].

    Args:
        path: The SVG file.
        time_unit: "s" or "ms": the unit of times where the file names none.

    Raises:
        InputError: naming the file and the element: no times in the file, a count of times
            (or pressures) unlike the vertices', times not increasing, not a number, an
            unknown unit, times on a curve, a ``Z`` or another shape, or no stroke of two
            timed points.
    """
    if time_unit not in TIME_UNITS:
        raise InputError(f"expected a time unit of {', '.join(TIME_UNITS)}, got {time_unit!r}",
                         key="time_unit", value=time_unit, choices=TIME_UNITS)
    path = Path(path)
    if not path.is_file():
        raise InputError("no such file", file=str(path))
    if not svg_has_times(path):
        raise no_times_error(path)
    try:
        root = read_xml(path)
        size = page(root)
        prepare(root)
        data = ET.tostring(root)
        svg = svgelements_call(lambda: se.SVG.parse(io.BytesIO(data), reify=True, ppi=96.0,
                                                    on_error="raise"), "<svg>")
        strokes, skipped = _strokes(svg, size, time_unit)
    except InkarmError as e:
        raise e.within(file=str(path)) from None
    if not strokes:
        untimed = skipped.get(UNTIMED, 0)
        raise InputError("no stroke of two or more timed points with the pen down"
                         + (f"; {untimed} shape{'s' if untimed > 1 else ''} without times of "
                            "their own (times on a group time no vertex)" if untimed else ""),
                         file=str(path))
    return Drawing(strokes, page_size=size[:2],
                   meta={"source": "svg", "file": str(path), "svg_skipped": dict(skipped)})


def _strokes(svg, size: tuple[float, float, float], time_unit: str
             ) -> tuple[list[Trajectory], Counter]:
    strokes: list[Trajectory] = []
    skipped: Counter = Counter()
    for elem in svg.elements():
        if not isinstance(elem, se.Shape):
            continue
        where = _where(elem)
        names = [n for n in TIME_ATTRIBUTES if elem.values.get(n) is not None
                 and n in _own_attributes(elem)]
        if not names:
            skipped[UNTIMED] += 1
            continue
        if len(names) > 1:
            raise InputError(f"{where}: times given twice ({', '.join(names)}); keep one",
                             key=names[1])
        pieces = _vertices(elem, where)
        n = sum(len(p) for p in pieces)
        t = _numbers(elem.values[names[0]], where, names[0], n) * _unit(elem, where, time_unit)
        bad = np.flatnonzero(np.diff(t) <= 0)
        if bad.size:
            i = int(bad[0])
            raise InputError(f"{where}: time {i + 1} ({t[i + 1]:g} s) does not come after time "
                             f"{i} ({t[i]:g} s); times must increase", key=names[0])
        pressure = None
        if elem.values.get(PRESSURE_ATTRIBUTE) is not None:
            pressure = _numbers(elem.values[PRESSURE_ATTRIBUTE], where, PRESSURE_ATTRIBUTE, n)
            if not np.all((pressure >= 0) & (pressure <= 1)):
                value = float(pressure[~((pressure >= 0) & (pressure <= 1))][0])
                raise InputError(f"{where}: pressure {value:g} outside [0, 1]",
                                 key=PRESSURE_ATTRIBUTE, value=value)
        start = 0
        for piece in pieces:
            stop = start + len(piece)
            pos = _on_page(piece, size, where)
            p = None if pressure is None else pressure[start:stop]
            for a, b in _down_runs(p, len(piece)):
                if b - a < 2:
                    skipped[SINGLE] += 1
                    continue
                strokes.append(Trajectory(t=t[start + a:start + b], pos=pos[a:b],
                                          pressure=None if p is None else p[a:b]))
            start = stop
    return strokes, skipped


def _own_attributes(elem) -> set[str]:
    """The attributes written on the element itself (svgelements copies a parent's ``data-*``
    into its children's ``values``; a group's times would time no vertex)."""
    own = elem.values.get("attributes")
    return set(own) if isinstance(own, dict) else set(elem.values)  # (svgelements 1.9 keeps it)


def _where(elem) -> str:
    tag = elem.values.get("tag") or type(elem).__name__.lower()
    return f"<{tag}>" + (f" id={elem.id!r}" if getattr(elem, "id", None) else "")


def _vertices(elem, where: str) -> list[np.ndarray]:
    """The vertices (n, 2) in pixels of each sub-path of a timed polyline or straight path."""
    if isinstance(elem, se.Polygon):
        raise InputError(f"{where}: a <polygon> closes back to its first point, which has no "
                         "time; write it as a <polyline> repeating that point with its time",
                         key="data-t")
    if isinstance(elem, se.Polyline):
        return [np.array([[float(p.x), float(p.y)] for p in elem.points]).reshape(-1, 2)]
    if not isinstance(elem, se.Path):
        raise InputError(f"{where}: times are read on <polyline> and <path> elements only "
                         f"(each vertex a sample)", key="data-t")
    pieces: list[list[tuple[float, float]]] = []
    for k, seg in enumerate(elem):
        if isinstance(seg, se.Move):
            pieces.append([(float(seg.end.x), float(seg.end.y))])
        elif isinstance(seg, se.Close):
            raise InputError(f"{where}: segment {k} is Z, which has no time for the closing "
                             "point; repeat the first point with its time instead", key="d")
        elif isinstance(seg, se.Line):
            pieces[-1].append((float(seg.end.x), float(seg.end.y)))
        else:
            raise InputError(f"{where}: segment {k} is a {type(seg).__name__.lower()}; times "
                             "are read on straight segments (M, L, H, V) only, one per vertex",
                             key="d")
    return [np.array(p, dtype=float).reshape(-1, 2) for p in pieces]


def _numbers(text: str, where: str, name: str, expected: int) -> np.ndarray:
    cells = [c for c in _SEPARATORS.split(str(text).strip()) if c]
    try:
        values = np.array([float(c) for c in cells], dtype=float)
    except ValueError:
        bad = next(c for c in cells if not _is_number(c))
        raise InputError(f"{where}: not a number: {bad!r}", key=name,
                         value=bad) from None
    if not np.all(np.isfinite(values)):
        raise InputError(f"{where}: not a finite number: "
                         f"{float(values[~np.isfinite(values)][0])!r}", key=name)
    if values.size != expected:
        raise InputError(f"{where}: {values.size} values for {expected} points; "
                         "expected one per vertex", key=name, value=values.size)
    return values


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _unit(elem, where: str, default: str) -> float:
    unit = elem.values.get(UNIT_ATTRIBUTE)
    if unit is None:
        return TIME_UNITS[default]
    if str(unit).strip() not in TIME_UNITS:
        raise InputError(f"{where}: got {unit!r}, expected one of {', '.join(TIME_UNITS)}", key=UNIT_ATTRIBUTE, value=unit,
                         choices=TIME_UNITS)
    return TIME_UNITS[str(unit).strip()]


def _on_page(points: np.ndarray, size: tuple[float, float, float], where: str) -> np.ndarray:
    """Pixels (y down) to the page frame in [mm] (y up), checked against MAX_COORD_MM."""
    _, page_h, px_per_mm = size
    pos = np.column_stack([points[:, 0] / px_per_mm, page_h - points[:, 1] / px_per_mm])
    if not np.all(np.abs(pos) <= MAX_COORD_MM):
        raise InputError(f"{where}: a point lies beyond {MAX_COORD_MM:g} mm of the page origin")
    return pos


def _down_runs(pressure: np.ndarray | None, n: int) -> list[tuple[int, int]]:
    """[start, end) of each run of samples with the pen down (pressure > 0; all without)."""
    if pressure is None:
        return [(0, n)]
    down = np.concatenate([[False], pressure > 0, [False]])
    edges = np.flatnonzero(np.diff(down.astype(np.int8)))
    return list(zip(edges[0::2].tolist(), edges[1::2].tolist()))


__all__ = ["NO_TIMES", "PRESSURE_ATTRIBUTE", "TIME_ATTRIBUTES", "TIME_UNITS", "UNIT_ATTRIBUTE",
           "UNTIMED", "no_times_error", "read_timed_svg", "svg_has_times"]
