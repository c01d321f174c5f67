"""The XML of an SVG file, read and made safe for svgelements: the page size, the grammar of
what is drawn, and bounds on what ``<use>`` expands.

svgelements reads the document in two steps (svgelements 1.9 ``SVG._use_structure_parse``):
every element with an ``id`` is stored, then the tree is walked and each ``<use>`` is replaced
by a copy of the element its ``href`` (or ``xlink:href``; ``href`` wins) names, recursively and
without a guard: a ``<use>`` inside the element it names recurses for ever, and ``<use>``
elements naming groups of ``<use>`` elements expand exponentially (a "<use> bomb"). Before the
file reaches it, :func:`prepare` therefore

* removes what is never drawn (comments, ``<clipPath>``, ``<mask>``, ``<pattern>``,
  ``<marker>``, gradients, filters, scripts, metadata) and the parts of ``<defs>`` that no drawn
  ``<use>`` names (its ``<style>`` sheets stay); puts a ``<symbol>`` outside ``<defs>`` into one (a symbol is drawn only
  through a ``<use>``); replaces ``<text>``, ``<image>`` and ``<foreignObject>`` by an empty
  placeholder that keeps their visibility, so that what is skipped can be counted;
* drops (and counts) a ``<use>`` naming no element of the file, or one that would contain
  itself (a cycle);
* counts the elements svgelements will create, ``<use>`` expansions included, and refuses more
  than :data:`MAX_ELEMENTS`, or nesting (through ``<use>`` too) deeper than :data:`MAX_DEPTH`;
* checks the grammar of every ``d``, ``points``, ``transform`` and geometry length left
  (:mod:`inkarm.io.svggrammar`).

All walks are iterative (no recursion on the file's depth).
"""

from __future__ import annotations

import itertools
import math
import re
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

from inkarm.core.trajectory import A4_MM, MAX_COORD_MM
from inkarm.errors import InputError
from inkarm.io.svggrammar import check_length, check_path_data, check_points, check_transform

MAX_DEPTH = 200
"""Deepest element nesting read from an SVG file, counting what ``<use>`` expands
(svgelements recurses per level)."""
MAX_ELEMENTS = 200_000
"""Most elements svgelements may create from one file, every ``<use>`` expanded."""
SKIPPED_TAG = "inkarm-skipped"
"""Tag of the placeholder that stands for a ``<text>``, ``<image>`` or ``<foreignObject>``."""
SKIPPED_REASON = "data-inkarm-skipped"
"""Attribute of the placeholder naming what it stands for (a key of the skipped counts)."""

XLINK_HREF = "{http://www.w3.org/1999/xlink}href"
_MM_PER_UNIT = {
    "mm": 1.0,
    "cm": 10.0,
    "in": 25.4,
    "pt": 25.4 / 72,
    "pc": 25.4 / 6,
    "px": 25.4 / 96,
    "": 25.4 / 96,
}
_LENGTH = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(mm|cm|in|pt|pc|px|)\s*")
_NOT_DRAWN = frozenset({
    "clipPath", "mask", "pattern", "marker", "metadata", "script", "linearGradient",
    "radialGradient", "filter", "cursor", "view",
})
_PLACEHOLDERS = {"text": "text", "image": "image", "foreignObject": "foreignObject"}
_KEPT_BY_PLACEHOLDER = ("id", "class", "style", "display", "visibility", "opacity")
_GEOMETRY = {
    "rect": ("x", "y", "width", "height", "rx", "ry"),
    "circle": ("cx", "cy", "r"),
    "ellipse": ("cx", "cy", "rx", "ry"),
    "line": ("x1", "y1", "x2", "y2"),
    "use": ("x", "y", "width", "height"),
    "svg": ("x", "y", "width", "height"),
}


def local(tag) -> str:
    """The tag without its namespace ('' for comments and processing instructions)."""
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else ""


def describe(elem: ET.Element) -> str:
    """``<tag> id='...'``, the element as error messages name it."""
    return f"<{local(elem.tag)}>" + (f" id={elem.get('id')!r}" if elem.get("id") else "")


def read_xml(path: Path) -> ET.Element:
    """The root <svg> element; expat refuses malformed XML and entity-expansion bombs."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as e:
        raise InputError(f"not well-formed XML ({e})", file=str(path)) from None
    except (OSError, UnicodeError, ValueError) as e:
        raise InputError(f"cannot read it as XML ({e})", file=str(path)) from None
    if local(root.tag) != "svg":
        raise InputError(
            f"root element is <{local(root.tag)}>, expected <svg>", file=str(path),
            value=local(root.tag),
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


def page(root: ET.Element) -> tuple[float, float, float]:
    """(width, height, px_per_mm): the page size in [mm] and the size of one CSS pixel.

    A root ``width``/``height`` with a unit fixes the page; a bare number is CSS pixels
    (1/96 in); with neither, one user unit is one millimetre and the page is the viewBox (A4
    without one). The root's width and height are rewritten in pixels, so that svgelements fits
    the viewBox without its own (6-digit) unit constants.
    """
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


def prepare(root: ET.Element) -> Counter:
    """Make the tree safe for svgelements (module docstring); the counts of what was dropped,
    by reason ("unresolved <use>", "circular <use>")."""
    skipped: Counter = Counter()
    _prune(root)
    ids = _ids(root)
    reached = _reached(root, ids, skipped)
    for defs in [e for e in root.iter() if local(e.tag) == "defs"]:
        for child in list(defs):
            if local(child.tag) != "style" and not any(e in reached for e in child.iter()):
                defs.remove(child)
    _bound_and_check(root, _ids(root), skipped)
    return skipped


def _prune(root: ET.Element) -> None:
    """Remove what is never drawn, replace text/images by placeholders, put stray symbols into
    a <defs>; refuse nesting deeper than MAX_DEPTH."""
    stack = [(root, 0)]
    while stack:
        elem, depth = stack.pop()
        if depth >= MAX_DEPTH and len(elem):
            raise InputError(
                f"elements are nested more than {MAX_DEPTH} deep; flatten the groups",
                value=MAX_DEPTH + 1,
            )
        for i, child in enumerate(list(elem)):
            tag = local(child.tag)
            if not tag or tag in _NOT_DRAWN:
                elem.remove(child)
            elif tag in _PLACEHOLDERS:
                namespace = child.tag[: len(child.tag) - len(tag)]
                kept = {k: v for k, v in child.attrib.items() if k in _KEPT_BY_PLACEHOLDER}
                holder = ET.Element(namespace + SKIPPED_TAG,
                                    {**kept, SKIPPED_REASON: _PLACEHOLDERS[tag]})
                elem.remove(child)
                elem.insert(i, holder)
            elif tag == "symbol" and local(elem.tag) != "defs":
                defs = ET.Element(child.tag[: len(child.tag) - len(tag)] + "defs")
                elem.remove(child)
                defs.append(child)
                elem.insert(i, defs)
                stack.append((child, depth + 2))
            else:
                if tag == "path" and child.get("d") is None:
                    child.set("d", "")  # nothing to draw (svgelements fails on a missing d)
                stack.append((child, depth + 1))


def _ids(root: ET.Element) -> dict[str, ET.Element]:
    """Elements by id, in document order, the last one winning (as svgelements stores them)."""
    return {e.get("id"): e for e in root.iter() if e.get("id") is not None}


def _href(use: ET.Element) -> str | None:
    url = use.get(XLINK_HREF)
    return use.get("href", url)


def _target(use: ET.Element, ids: dict[str, ET.Element]) -> ET.Element | None:
    """The element a <use> names, as svgelements looks it up (``href[1:]``), or None."""
    url = _href(use)
    return ids.get(url[1:]) if url and url.startswith("#") else None


def _reached(root: ET.Element, ids: dict, skipped: Counter) -> set[ET.Element]:
    """The elements drawn from the root: children (not those of <defs>) and what each <use>
    names; a <use> naming nothing is dropped and counted."""
    reached, stack = set(), [root]
    while stack:
        elem = stack.pop()
        if elem in reached:
            continue
        reached.add(elem)
        if local(elem.tag) == "use" and _href(elem) is not None:
            target = _target(elem, ids)
            if target is None:
                skipped["unresolved <use>"] += 1
                elem.attrib.pop("href", None)
                elem.attrib.pop(XLINK_HREF, None)
            else:
                stack.append(target)
        if local(elem.tag) != "defs":
            stack.extend(elem)
    return reached


MAX_CYCLES = 100
"""Most circular ``<use>`` elements dropped from one file before it is refused."""


def _bound_and_check(root: ET.Element, ids: dict, skipped: Counter) -> None:
    """Count (size) and measure (depth) what svgelements creates from each element, every
    <use> expanded; a <use> that closes a cycle is dropped and the count starts again; refuse
    beyond MAX_ELEMENTS or MAX_DEPTH; check the grammar of each element once."""
    checked: set[ET.Element] = set()
    for _ in range(MAX_CYCLES + 1):
        use = _walk(root, ids, checked)
        if use is None:
            return
        skipped["circular <use>"] += 1
        use.attrib.pop("href", None)
        use.attrib.pop(XLINK_HREF, None)
    raise InputError(f"more than {MAX_CYCLES} <use> elements name an element containing them; "
                     "refused", value=MAX_CYCLES)


def _below(elem: ET.Element, ids: dict) -> list[ET.Element]:
    """What svgelements walks under an element: its children, then what a <use> names."""
    target = _target(elem, ids) if local(elem.tag) == "use" else None
    return list(elem) + ([target] if target is not None else [])


def _walk(root: ET.Element, ids: dict, checked: set) -> ET.Element | None:
    """One depth-first walk (module docstring); the <use> closing the first cycle found, or
    None when there is none."""
    size: dict[ET.Element, int] = {}
    depth: dict[ET.Element, int] = {}
    path, pending = [root], [iter(_below(root, ids))]
    on_path = {root}
    while path:
        nxt = next(pending[-1], None)
        if nxt is None:
            elem = path.pop()
            pending.pop()
            on_path.discard(elem)
            below = _below(elem, ids)
            size[elem] = min(1 + sum(size[e] for e in below), MAX_ELEMENTS + 1)
            depth[elem] = 1 + max((depth[e] for e in below), default=-1)
            if size[elem] > MAX_ELEMENTS:
                where = describe(elem) if elem is not root else "<svg>"
                raise InputError(
                    f"{where}: the drawing expands to more than {MAX_ELEMENTS} elements "
                    "(<use> elements naming groups of <use> elements); refused",
                    value=MAX_ELEMENTS)
            if depth[elem] > MAX_DEPTH:
                raise InputError(
                    f"elements are nested more than {MAX_DEPTH} deep (counting what <use> "
                    f"expands, near {describe(elem)}); flatten the groups", value=depth[elem])
            continue
        if nxt in size:
            continue
        if nxt in on_path:  # a cycle: nxt ... path[-1] -> nxt; it goes through a <use>
            cycle = path[path.index(nxt):] + [nxt]
            return next(a for a, b in reversed(list(itertools.pairwise(cycle)))
                        if local(a.tag) == "use" and _target(a, ids) is b)
        if nxt not in checked:
            _check(nxt)
            checked.add(nxt)
        path.append(nxt)
        pending.append(iter(_below(nxt, ids)))
        on_path.add(nxt)
    return None


def _check(elem: ET.Element) -> None:
    """The grammar of what svgelements reads from one element (InputError naming it)."""
    tag, where = local(elem.tag), describe(elem)
    check_transform(elem.get("transform"), where)
    if tag == "path":
        check_path_data(elem.get("d", ""), where)
    elif tag in ("polyline", "polygon"):
        check_points(elem.get("points", ""), where)
    for name in _GEOMETRY.get(tag, ()):
        check_length(elem.get(name), where, name)
