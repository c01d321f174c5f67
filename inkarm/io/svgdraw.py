"""What of an SVG document is drawn: the shapes svgelements builds, which of them a pen draws,
their layers, and what was skipped and why.

Shapes: ``<path>``, ``<line>``, ``<polyline>``, ``<polygon>``, ``<rect>`` (rounded corners
too), ``<circle>``, ``<ellipse>``, and all of them inside groups, nested ``<svg>`` viewports and
``<use>`` of elements, groups and symbols (``x``/``y`` a translation after the ``<use>``'s
transform), every transform composed. Each sub-path is a polyline; curves (Beziers, arcs and
the arcs of circles, ellipses and rounded corners) become :data:`CURVE_POINTS` points each.

Visibility (a pen draws the outline of what is seen on white paper):

* hidden, drawn nothing: ``display:none`` on the element or an ancestor (a descendant cannot
  undo it); ``visibility:hidden`` or ``collapse`` (inherited, a descendant may set
  ``visible``); an ``opacity`` of 0 (the product of the element's and its ancestors');
* "no stroke or fill": neither paint is seen: a paint is seen when it is not ``none``, its
  alpha (colour alpha x ``stroke-opacity``/``fill-opacity``) is above 0, and for the stroke its
  width is above 0. SVG's default fill is black, so a shape with no paint attribute is drawn;
* "white on white": every paint seen is white (each channel at least :data:`WHITE_LEVEL` of
  255), as the background rectangle matplotlib writes (``fill:#ffffff``, no stroke): white ink
  on white paper is not drawn;
* otherwise the shape's outline is drawn, one stroke per sub-path, whether it is stroked or
  only filled (a glyph of text converted to paths is filled, not stroked; its outline is what
  a pen can draw).

Layers follow vpype (``vpype.io.read_multilayer_svg``, vpype 1.15): each top-level group
(``<g>``, or a nested ``<svg>``) is a layer whose id is the first run of digits of its
``inkscape:label``, else of its ``id``, else its order among the top-level groups (1, 2, ...);
an id of 0 becomes 1; every other top-level element is in layer 1.

Skipped (counted by reason, one per element): "hidden", "no stroke or fill",
"white on white", "zero length" (every sub-path shorter than :data:`MIN_LENGTH_MM`), "text",
"image", "foreignObject", plus what :func:`inkarm.io.svgtree.prepare` drops.
"""

from __future__ import annotations

import io
import math
import re
import xml.etree.ElementTree as ET
from collections import Counter
from dataclasses import dataclass

import numpy as np
import svgelements as se

from inkarm.core.trajectory import MAX_COORD_MM
from inkarm.errors import InkarmError, InputError
from inkarm.io.svgtree import SKIPPED_REASON, SKIPPED_TAG

MAX_SAMPLES = 2_000_000
"""Most points (after flattening curves) read from one SVG file."""
CURVE_POINTS = 32
"""Points per curve piece (Bezier, arc) when flattening, before the arc-length resampling."""
MIN_LENGTH_MM = 1e-9
"""Sub-paths shorter than this [mm] are not drawn (a point, not a stroke)."""
WHITE_LEVEL = 250
"""Each of red, green and blue at least this (of 255): a paint a pen cannot show on white
paper."""
MAX_LAYER = 2**63 - 1
"""Largest layer id (vpype's ids are Python integers; inkarm stores int64)."""

_LABEL = "{http://www.inkscape.org/namespaces/inkscape}label"
_DIGITS = re.compile(r"\d+")


@dataclass(frozen=True)
class Piece:
    """One drawn sub-path: the element it came from, its layer, its points in page [mm] and
    its length [mm] (> :data:`MIN_LENGTH_MM`)."""

    where: str
    layer: int
    points: np.ndarray
    length: float


@dataclass
class Document:
    """The drawn sub-paths of a file, whether it has layers (top-level groups), what was
    skipped."""

    pieces: list[Piece]
    has_layers: bool
    skipped: Counter


def drawn(root: ET.Element, page: tuple[float, float, float]) -> Document:
    """The pieces a pen draws from a prepared tree (:func:`inkarm.io.svgtree.prepare`);
    ``page`` from :func:`inkarm.io.svgtree.page`."""
    data = ET.tostring(root)
    svg = svgelements_call(
        lambda: se.SVG.parse(io.BytesIO(data), reify=True, ppi=96.0, on_error="raise",
                             parse_display_none=True), "<svg>")
    doc = Document([], False, Counter())
    top, groups = [], 0
    for child in svg:
        layer = 1
        if isinstance(child, se.Group) and _own(child, "display") != "none":
            groups += 1
            layer = layer_id(child, groups)
            doc.has_layers = True
        top.append((child, layer))
    count = 0
    stack = [(child, layer, _hidden(svg), _opacity(svg)) for child, layer in reversed(top)]
    while stack:
        elem, layer, hidden, opacity = stack.pop()
        hidden = hidden or _hidden(elem)
        opacity *= _opacity(elem)
        if isinstance(elem, (se.Group, se.Use)):
            stack.extend((c, layer, hidden, opacity) for c in reversed(elem))
            continue
        if not isinstance(elem, (se.Shape, se.Text, se.Image)) and not _placeholder(elem):
            continue  # <title>, <desc>, the element a <symbol> leaves, unknown elements
        reason = _skip_reason(elem, hidden, opacity)
        if reason is not None:
            doc.skipped[reason] += 1
            continue
        where = _where(elem)
        pieces = [Piece(where, layer, p, _length(p)) for p in _flatten(elem, where, page)]
        pieces = [p for p in pieces if p.length > MIN_LENGTH_MM]
        if not pieces:
            doc.skipped["zero length"] += 1
        for piece in pieces:
            count += len(piece.points)
            if count > MAX_SAMPLES:
                raise InputError(f"{where}: more than {MAX_SAMPLES} points after flattening")
            doc.pieces.append(piece)
    return doc


def layer_id(group: se.Group, order: int) -> int:
    """vpype's layer id of a top-level group (module docstring); ``order`` counts from 1."""
    label = group.values.get(_LABEL) or ""
    match = _DIGITS.search(label) or _DIGITS.search(group.values.get("id") or "")
    digits = (match.group().lstrip("0") or "0") if match else str(order)
    if len(digits) > len(str(MAX_LAYER)) or int(digits) > MAX_LAYER:
        raise InputError(f"{_where(group)}: layer id {digits[:40]} (from its label or id) is "
                         f"larger than {MAX_LAYER}", value=digits[:40])
    return max(int(digits), 1)


def svgelements_call(call, where: str):
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


# -- visibility ---------------------------------------------------------------------------------


def _own(elem, name: str) -> str:
    """The element's own attribute (style properties and CSS included), lower case, or ''."""
    attributes = elem.values.get("attributes") or {}
    return str(attributes.get(name, "")).strip().lower()


def _hidden(elem) -> bool:
    return _own(elem, "display") == "none"


def _opacity(elem) -> float:
    """The element's own ``opacity`` in [0, 1] (a number or a percentage; unreadable is 1)."""
    text = _own(elem, "opacity")
    try:
        value = float(text[:-1]) / 100 if text.endswith("%") else float(text or 1)
    except ValueError:
        return 1.0
    return min(max(value, 0.0), 1.0) if math.isfinite(value) else 1.0


def _seen(paint) -> bool:
    return paint is not None and paint.value is not None and (paint.value & 0xFF) > 0


def _white(paint) -> bool:
    v = paint.value
    return all((v >> shift) & 0xFF >= WHITE_LEVEL for shift in (24, 16, 8))


def _placeholder(elem) -> bool:
    return _own(elem, "tag") == SKIPPED_TAG


def _skip_reason(elem, hidden: bool, opacity: float) -> str | None:
    """Why a shape, text or image is not drawn (module docstring), or None when it is."""
    if _placeholder(elem):
        kind = (elem.values.get("attributes") or {}).get(SKIPPED_REASON, "text")
        return "hidden" if hidden or opacity <= 0 else kind
    if isinstance(elem, se.Text):
        return "hidden" if hidden or opacity <= 0 else "text"
    if isinstance(elem, se.Image):
        return "hidden" if hidden or opacity <= 0 else "image"
    visibility = str(elem.values.get("visibility", "")).strip().lower()
    if hidden or opacity <= 0 or visibility in ("hidden", "collapse"):
        return "hidden"
    try:
        width = float(elem.stroke_width if elem.stroke_width is not None else 1.0)
    except (TypeError, ValueError):  # a length svgelements could not resolve: drawn
        width = 1.0
    paints = [p for p in (elem.stroke if width > 0 else None, elem.fill) if _seen(p)]
    if not paints:
        return "no stroke or fill"
    if all(_white(p) for p in paints):
        return "white on white"
    return None


def _where(elem) -> str:
    tag = _own(elem, "tag") or type(elem).__name__.lower()
    return f"<{tag}>" + (f" id={elem.id!r}" if getattr(elem, "id", None) else "")


# -- flattening ---------------------------------------------------------------------------------


def _length(points: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))


def _flatten(elem, where: str, page: tuple[float, float, float]) -> list[np.ndarray]:
    """The sub-paths of a shape in page [mm] (y up from the page's lower edge), each point
    checked against MAX_COORD_MM."""
    _, page_h, px_per_mm = page
    if isinstance(elem, (se.Polyline, se.Polygon)):
        pieces = [shape_points(elem)]
    else:
        path = elem
        if not isinstance(elem, se.Path):
            path = svgelements_call(lambda: se.Path(elem), where)
            svgelements_call(path.reify, where)
        pieces = path_polylines(path, where)
    out = []
    mm = 1.0 / px_per_mm
    for poly in pieces:
        with np.errstate(over="ignore", invalid="ignore"):
            on_page = np.column_stack([poly[:, 0] * mm, page_h - poly[:, 1] * mm])
        outside = ~(np.abs(on_page) <= MAX_COORD_MM)  # also NaN
        if outside.any():
            value = on_page[tuple(np.argwhere(outside)[0])]
            raise InputError(
                f"{where}: coordinates overflow: a point at {value:g} mm in the page "
                f"frame, expected |x|, |y| <= {MAX_COORD_MM:g} mm", value=float(value),
            )
        out.append(on_page)
    return out


def _xy(point) -> np.ndarray:
    return np.array([[float(point.x), float(point.y)]])


def path_polylines(path: se.Path, where: str) -> list[np.ndarray]:
    """One (n, 2) polyline per sub-path of a svgelements Path, in its (reified) coordinates;
    a curve piece is CURVE_POINTS points ending exactly on its end point, an arc of zero radius
    a straight line (SVG 1.1 F.6.2)."""
    segments = list(path)
    size = sum(1 if isinstance(s, (se.Move, se.Linear)) else CURVE_POINTS for s in segments)
    if size > MAX_SAMPLES:
        raise InputError(f"{where}: d: more than {MAX_SAMPLES} points after flattening")
    inner = np.linspace(0.0, 1.0, CURVE_POINTS + 1)[1:-1]
    subpaths: list[list[np.ndarray]] = []
    for seg in segments:
        if isinstance(seg, se.Move):
            subpaths.append([_xy(seg.end)])
            continue
        if not subpaths:
            subpaths.append([_xy(seg.start)])
        straight = isinstance(seg, se.Linear) or (
            isinstance(seg, se.Arc) and (seg.rx == 0 or seg.ry == 0)
        )
        if not straight:
            subpaths[-1].append(svgelements_call(lambda s=seg: np.asarray(s.npoint(inner)), where))
        subpaths[-1].append(_xy(seg.end))
    return [np.vstack(parts) for parts in subpaths if len(parts) > 1]


def shape_points(shape) -> np.ndarray:
    """The vertices of a svgelements Polyline or Polygon (closed), (n, 2)."""
    pts = np.array([[float(p.x), float(p.y)] for p in shape.points], dtype=float).reshape(-1, 2)
    if isinstance(shape, se.Polygon) and len(pts):
        pts = np.vstack([pts, pts[:1]])
    return pts
