"""Traces to analyse or restyle: a CSV of time-stamped samples, or the paths of an SVG file.

CSV files are read with :meth:`Drawing.from_csv` (``t,x,y[,z][,stroke]``). SVG files are read
with the ``svgelements`` library (as vpype does): the ``d`` attribute of every ``<path>``
(commands M, L, H, V, C, S, Q, T, A, Z, absolute and relative) and the ``points`` of every
``<polyline>`` and ``<polygon>`` are flattened, mapped to the page frame in [mm] (y up, origin
at the page's lower-left corner, ``transform`` attributes, nested ``<svg>`` viewports and
``display="none"`` applied) and sampled uniformly in arc length, each sub-path a stroke traced
at a constant ``speed``; consecutive samples are at most ``speed / rate`` apart. Other shapes
(``<line>``, ``<rect>``, ``<circle>``, text) and anything inside ``<defs>``, ``<use>``,
``<symbol>``, ``<clipPath>``, ``<mask>``, ``<pattern>`` or ``<marker>`` are not drawn; an SVG
with nothing drawable is refused.

Units: a root ``width``/``height`` with a unit (mm, cm, in, pt, pc, px) fixes the page size;
a bare number is CSS pixels (1/96 in); a ``viewBox`` is fitted into that page as SVG says
(``preserveAspectRatio``, by default centred and uniformly scaled). With neither width nor
height, one user unit is one millimetre (as :meth:`Drawing.to_svg` writes) and the page is
the viewBox, or A4 without one.

Before svgelements sees the file, the XML is parsed and checked here: every ``d``,
``points`` and ``transform`` that is drawn must follow the SVG grammar (svgelements would
silently drop what follows a typo), nesting is at most :data:`MAX_DEPTH` elements deep, and
the flattened drawing at most :data:`MAX_SAMPLES` points, every point within
:data:`~inkarm.core.trajectory.MAX_COORD_MM` of the page origin, and the page no larger. The
sampled trace is estimated (length / speed x rate samples) before it is sampled and refused
beyond ``INKARM_MAX_STEPS`` (:mod:`inkarm.core.budget`); ``speed`` and ``rate`` must lie in
:data:`SPEED_RANGE` and :data:`RATE_RANGE`. Every problem is an
:class:`~inkarm.errors.InputError` naming the file and the element (or the setting).
"""

from __future__ import annotations

import io
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import svgelements as se

from inkarm.core.budget import STEPS, require
from inkarm.core.trajectory import A4_MM, MAX_COORD_MM, Drawing, Trajectory
from inkarm.errors import InkarmError, InputError

DEFAULT_SPEED = 50.0
"""Pen speed along an SVG path in [mm/s]."""
DEFAULT_RATE = 200.0
"""Sampling rate of an SVG path in [Hz]."""
MAX_DEPTH = 200
"""Deepest element nesting read from an SVG file (svgelements recurses per level)."""
MAX_SAMPLES = 2_000_000
"""Most points (after flattening curves) read from one SVG file; the samples after resampling
are bounded by ``INKARM_MAX_STEPS``."""
SPEED_RANGE = (1e-3, 1e5)
"""Accepted pen speeds along an SVG path in [mm/s]."""
RATE_RANGE = (1e-3, 1e7)
"""Accepted sampling rates of an SVG path in [Hz]."""
MIN_LENGTH_MM = 1e-9
"""Sub-paths shorter than this [mm] are not drawn (a point, not a stroke)."""

_MM_PER_UNIT = {
    "mm": 1.0,
    "cm": 10.0,
    "in": 25.4,
    "pt": 25.4 / 72,
    "pc": 25.4 / 6,
    "px": 25.4 / 96,
    "": 25.4 / 96,
}
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_LENGTH = re.compile(rf"\s*({_NUMBER.pattern})\s*(mm|cm|in|pt|pc|px|)\s*")
_SEPARATORS = re.compile(r"[\s,]*")
_COMMANDS = "MmLlHhVvCcSsQqTtAaZz"
_ARGS = {"M": 2, "L": 2, "H": 1, "V": 1, "C": 6, "S": 4, "Q": 4, "T": 2, "A": 7, "Z": 0}
_TRANSFORM_ARGS = {
    "matrix": (6,),
    "translate": (1, 2),
    "scale": (1, 2),
    "rotate": (1, 3),
    "skewX": (1,),
    "skewY": (1,),
}
_NOT_DRAWN = frozenset(
    {"defs", "symbol", "clipPath", "mask", "pattern", "marker", "use", "metadata",
     "foreignObject", "text", "image", "script"}
)
_DRAWN = (se.Path, se.Polyline, se.Polygon)
_CURVE_POINTS = 32
_MAX_TRANSFORM_ARG = 1e9
"""Largest |argument| of an SVG transform (an angle, scale or offset beyond it is an error)."""
"""Points per curve piece when flattening, before the arc-length resampling."""


def load_trace(
    path: str | Path, speed: float = DEFAULT_SPEED, rate: float = DEFAULT_RATE
) -> Drawing:
    """Read a trace from ``.csv`` (time-stamped samples) or ``.svg`` (paths traced at ``speed``
    [mm/s], sampled at ``rate`` [Hz])."""
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
    """The sub-paths of an SVG file as strokes sampled uniformly in arc length (module docstring).

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
    root = _read_xml(path)
    try:
        page = _page(root)
        _check_and_prune(root)
        polylines = _flatten_document(root, page)
    except InkarmError as e:
        raise e.within(file=str(path)) from None
    strokes = _strokes(polylines, speed, rate, path)
    if not strokes:
        raise InputError(
            "no drawable <path>, <polyline> or <polygon> (of non-zero length) found",
            file=str(path),
        )
    return Drawing(strokes, page_size=page[:2])


def resample_arc_length(points: np.ndarray, spacing: float) -> np.ndarray | None:
    """Points equally spaced in arc length, at most ``spacing`` apart, both ends kept; None for
    a polyline of zero length."""
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(steps)])
    if s[-1] <= 0:
        return None
    keep = np.concatenate([[True], steps > 0])
    s, points = s[keep], points[keep]
    targets = np.linspace(0.0, s[-1], math.ceil(s[-1] / spacing) + 1)
    return np.column_stack([np.interp(targets, s, c) for c in points.T])


def parse_path_data(d: str, where: str = "path") -> list[np.ndarray]:
    """Flatten SVG path data into polylines in user units, one (n, 2) array per sub-path.

    The data is checked against the SVG path grammar first (InputError naming ``where``
    and the character at fault), then read by svgelements; curves (quadratic and cubic
    Beziers, elliptical arcs) become ``_CURVE_POINTS`` points each, ending exactly on their
    end points.
    """
    check_path_data(d, where)
    return _path_polylines(_svgelements(lambda: se.Path(d), where), where)


# -- the XML document ----------------------------------------------------------------------


def _local(tag) -> str:
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else ""


def _read_xml(path: Path) -> ET.Element:
    """The root <svg> element; expat refuses malformed XML and entity-expansion bombs."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as e:
        raise InputError(f"not well-formed XML ({e})", file=str(path)) from None
    except (OSError, UnicodeError, ValueError) as e:
        raise InputError(f"cannot read it as XML ({e})", file=str(path)) from None
    if _local(root.tag) != "svg":
        raise InputError(
            f"root element is <{_local(root.tag)}>, expected <svg>", file=str(path),
            value=_local(root.tag),
        )
    return root


def _length_mm(value: str | None, name: str) -> float | None:
    """A root width or height in [mm]; None when absent."""
    if value is None:
        return None
    m = _LENGTH.fullmatch(value)
    length = float(m.group(1)) * _MM_PER_UNIT[m.group(2)] if m else math.nan
    if not 0 < length <= MAX_COORD_MM:
        raise InputError(
            f"<svg {name}={value!r}>: expected a positive length up to {MAX_COORD_MM:g} mm, "
            "in mm, cm, in, pt, pc or px",
            value=value,
        )
    return length


def _page(root: ET.Element) -> tuple[float, float, float]:
    """(width, height, px_per_mm): the page size in [mm] (module docstring) and the size of
    one CSS pixel; the root's width and height are rewritten in those pixels, so that
    svgelements fits the viewBox without its own (6-digit) unit constants."""
    width = _length_mm(root.get("width"), "width")
    height = _length_mm(root.get("height"), "height")
    box = root.get("viewBox")
    vb = None
    if box is not None:
        try:
            vb = [float(v) for v in box.replace(",", " ").split()]
        except ValueError:
            vb = []
        if len(vb) != 4 or not all(map(math.isfinite, vb)):
            raise InputError(f"<svg viewBox={box!r}>: expected four numbers", value=box)
        if vb[2] <= 0 or vb[3] <= 0:
            raise InputError(
                f"<svg viewBox={box!r}>: width and height must be positive", value=box
            )
    if width is None and height is None:  # one user unit is one millimetre
        w, h = (vb[2], vb[3]) if vb else A4_MM
        px_per_mm = 1.0
    else:
        aspect = vb[2] / vb[3] if vb else A4_MM[0] / A4_MM[1]
        w = width if width is not None else height * aspect
        h = height if height is not None else width / aspect
        px_per_mm = 96 / 25.4
    if not (w <= MAX_COORD_MM and h <= MAX_COORD_MM):
        raise InputError(
            f"page of {w:g} x {h:g} mm (from the viewBox and the width or height): expected at "
            f"most {MAX_COORD_MM:g} mm a side", value=box,
        )
    root.set("width", repr(w * px_per_mm))
    root.set("height", repr(h * px_per_mm))
    return w, h, px_per_mm


def _check_and_prune(root: ET.Element) -> None:
    """Remove the elements that are not drawn and check the attributes of those that are,
    walking the tree without recursion (at most :data:`MAX_DEPTH` levels)."""
    stack = [(root, 0)]
    while stack:
        elem, depth = stack.pop()
        if depth >= MAX_DEPTH and len(elem):
            raise InputError(
                f"elements are nested more than {MAX_DEPTH} deep; flatten the groups",
                value=MAX_DEPTH + 1,
            )
        for child in list(elem):
            tag = _local(child.tag)
            if not tag or tag in _NOT_DRAWN:  # comments, processing instructions, not drawn
                elem.remove(child)
                continue
            where = f"<{tag}>" + (f" id={child.get('id')!r}" if child.get("id") else "")
            check_transform(child.get("transform"), where)
            if tag == "path":
                check_path_data(child.get("d", ""), where)
            elif tag in ("polyline", "polygon"):
                _polyline_numbers(child.get("points", ""), where)
            stack.append((child, depth + 1))


def _flatten_document(
    root: ET.Element, page: tuple[float, float, float]
) -> list[tuple[str, np.ndarray]]:
    """(element, polyline in page [mm]) for every drawn sub-path; ``page`` from :func:`_page`."""
    _, page_h, px_per_mm = page
    data = ET.tostring(root)
    svg = _svgelements(
        lambda: se.SVG.parse(io.BytesIO(data), reify=True, ppi=96.0, on_error="raise"), "<svg>"
    )
    mm = 1.0 / px_per_mm
    out, count = [], 0
    for elem in _svgelements(lambda: [e for e in svg.elements() if type(e) in _DRAWN], "<svg>"):
        tag = type(elem).__name__.lower()
        where = f"<{tag}>" + (f" id={elem.id!r}" if getattr(elem, "id", None) else "")
        if isinstance(elem, se.Path):
            pieces = _path_polylines(elem, where)
        else:
            pieces = [_shape_points(elem)]
        for poly in pieces:
            count += len(poly)
            if count > MAX_SAMPLES:
                raise InputError(f"{where}: more than {MAX_SAMPLES} points after flattening")
            with np.errstate(over="ignore", invalid="ignore"):
                on_page = np.column_stack([poly[:, 0] * mm, page_h - poly[:, 1] * mm])
            outside = ~(np.abs(on_page) <= MAX_COORD_MM)  # also NaN
            if outside.any():
                value = on_page[tuple(np.argwhere(outside)[0])]
                raise InputError(
                    f"{where}: coordinates overflow: a point at {value:g} mm in the page "
                    f"frame, expected |x|, |y| <= {MAX_COORD_MM:g} mm", value=float(value),
                )
            out.append((where, on_page))
    return out


def _svgelements(call, where: str):
    """Run a svgelements call; whatever it raises becomes an InputError naming ``where``."""
    try:
        return call()
    except InkarmError:
        raise
    except RecursionError:
        raise InputError(f"{where}: nested too deeply for svgelements") from None
    except Exception as e:  # noqa: BLE001 - third-party parser, untrusted input: never crash
        detail = f": {e}" if str(e) else ""
        raise InputError(
            f"{where}: svgelements cannot read it ({type(e).__name__}{detail})"
        ) from None


def _strokes(
    polylines: list[tuple[str, np.ndarray]], speed: float, rate: float, path: Path
) -> list[Trajectory]:
    """Each polyline resampled every ``speed / rate`` [mm] and timed at ``speed`` [mm/s]; the
    number of samples, length / speed x rate, is checked against ``INKARM_MAX_STEPS`` first."""
    lengths = [float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))) for _, p in polylines]
    drawn = [length > MIN_LENGTH_MM for length in lengths]
    total = sum(length for length, keep in zip(lengths, drawn) if keep)
    needed = total / speed * rate + sum(drawn)
    require(needed, STEPS, f"{total:.4g} mm of paths at {speed:g} mm/s sampled at {rate:g} Hz "
            f"(one sample every {speed / rate:.3g} mm); lower the rate or raise the speed",
            key="rate", value=rate, file=str(path))
    spacing = speed / rate
    strokes = []
    for (_, poly), keep in zip(polylines, drawn):
        pos = resample_arc_length(poly, spacing) if keep else None
        if pos is not None:
            step = np.linalg.norm(np.diff(pos, axis=0), axis=1)
            t = np.concatenate([[0.0], np.cumsum(step)]) / speed
            strokes.append(Trajectory(t=t, pos=pos))
    return strokes


# -- flattening svgelements shapes ----------------------------------------------------------


def _xy(point) -> np.ndarray:
    return np.array([[float(point.x), float(point.y)]])


def _path_polylines(path: se.Path, where: str) -> list[np.ndarray]:
    """One (n, 2) polyline per sub-path of a svgelements Path, in its (reified) coordinates."""
    segments = list(path)
    size = sum(1 if isinstance(s, (se.Move, se.Linear)) else _CURVE_POINTS for s in segments)
    if size > MAX_SAMPLES:
        raise InputError(f"{where}: d: more than {MAX_SAMPLES} points after flattening")
    inner = np.linspace(0.0, 1.0, _CURVE_POINTS + 1)[1:-1]
    subpaths: list[list[np.ndarray]] = []
    for seg in segments:
        if isinstance(seg, se.Move):
            subpaths.append([_xy(seg.end)])
            continue
        if not subpaths:
            subpaths.append([_xy(seg.start)])
        straight = isinstance(seg, se.Linear) or (
            isinstance(seg, se.Arc) and (seg.rx == 0 or seg.ry == 0)  # SVG: a zero radius is a line
        )
        if not straight:
            subpaths[-1].append(_svgelements(lambda s=seg: np.asarray(s.npoint(inner)), where))
        subpaths[-1].append(_xy(seg.end))
    return [np.vstack(parts) for parts in subpaths if len(parts) > 1]


def _shape_points(shape) -> np.ndarray:
    """The vertices of a svgelements Polyline or Polygon (closed), (n, 2)."""
    pts = np.array([[float(p.x), float(p.y)] for p in shape.points], dtype=float).reshape(-1, 2)
    if isinstance(shape, se.Polygon) and len(pts):
        pts = np.vstack([pts, pts[:1]])
    return pts


# -- grammar checks (svgelements is lenient) ------------------------------------------------


def check_transform(text: str | None, where: str) -> None:
    """Raise InputError unless ``text`` is a list of SVG transforms (matrix, translate, scale,
    rotate, skewX, skewY) with valid argument counts."""
    if not text:
        return
    pos = 0
    for call in re.finditer(r"\s*,?\s*(\w+)\s*\(([^)]*)\)", text):
        if call.start() != pos:
            break
        pos = call.end()
        name, args = call.group(1), [float(v) for v in _NUMBER.findall(call.group(2))]
        if not all(abs(v) <= _MAX_TRANSFORM_ARG for v in args):
            raise InputError(
                f"{where}: transform {call.group(0).strip()!r}: arguments must be numbers of "
                f"magnitude at most {_MAX_TRANSFORM_ARG:g}",
                value=text,
            )
        if len(args) not in _TRANSFORM_ARGS.get(name, ()):
            raise InputError(
                f"{where}: transform {name}({', '.join(map(str, args))}) not understood in "
                f"{text!r}; expected matrix(6), translate(1-2), scale(1-2), rotate(1 or 3), "
                "skewX(1) or skewY(1)",
                value=text,
            )
    if text[pos:].strip():
        raise InputError(
            f"{where}: cannot parse transform={text!r} near {text[pos : pos + 20]!r}", value=text
        )


def _polyline_numbers(text: str, where: str) -> None:
    """Raise InputError unless ``points`` holds an even count of at least 4 numbers."""
    values, pos = 0, 0
    while True:
        pos = _SEPARATORS.match(text, pos).end()
        if pos == len(text):
            break
        m = _NUMBER.match(text, pos)
        if not m:
            raise InputError(
                f"{where}: points: unexpected {text[pos : pos + 10]!r} at character {pos}",
                value=text,
            )
        values, pos = values + 1, m.end()
    if values % 2 or values < 4:
        raise InputError(
            f"{where}: points={text[:40]!r}: expected an even count of at least 4 numbers",
            value=text,
        )


def check_path_data(d: str, where: str = "path") -> None:
    """Raise InputError at the first character of ``d`` that breaks the SVG path grammar:
    data starts with M or m, each command takes whole groups of its arguments (numbers, arc
    flags 0 or 1), repeated groups continue the command."""
    pos = _SEPARATORS.match(d).end()
    if pos < len(d) and d[pos] not in "Mm":
        if d[pos] in _COMMANDS:
            raise InputError(f"{where}: d: path data must start with M or m, got {d[pos]!r}",
                             value=d)
        _grammar_error(d, pos, "a path command (M, L, C, ...)", where)
    while pos < len(d):
        if d[pos] not in _COMMANDS:
            _grammar_error(d, pos, "a path command", where)
        command = d[pos].upper()
        pos, first = pos + 1, True
        while _ARGS[command] and (first or (pos < len(d) and d[pos] not in _COMMANDS)):
            for k in range(_ARGS[command]):
                pos = _SEPARATORS.match(d, pos).end()
                if command == "A" and k in (3, 4):
                    if d[pos : pos + 1] not in ("0", "1"):
                        _grammar_error(d, pos, "an arc flag 0 or 1", where)
                    pos += 1
                    continue
                m = _NUMBER.match(d, pos)
                if not m:
                    expected = "a number" if first or k else "a number or a path command"
                    _grammar_error(d, pos, expected, where)
                pos = m.end()
            pos, first = _SEPARATORS.match(d, pos).end(), False
        pos = _SEPARATORS.match(d, pos).end()


def _grammar_error(d: str, pos: int, expected: str, where: str):
    got = d[pos : pos + 10] or "end of data"
    raise InputError(f"{where}: d: expected {expected} at character {pos}, got {got!r}", value=d)
