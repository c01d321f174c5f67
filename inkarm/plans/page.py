"""A drawing laid out on a page as vpype's ``layout``, ``pagesize``, ``scale`` and ``rotate``
commands lay it out, and kept inside the page after restyling.

Facts taken from vpype 1.15 (``vpype/utils.py`` ``PAGE_SIZES``, ``UNITS``;
``vpype_cli/operations.py`` ``layout``, ``_normalize_page_size``; ``vpype_cli/transforms.py``
``rotate``, ``scale``):

* page sizes [mm]: a6 105 x 148, a5 148 x 210, a4 210 x 297, a3 297 x 420, a2 420 x 594,
  a1 594 x 841, a0 841 x 1189, letter 215.9 x 279.4, legal 215.9 x 355.6, executive
  185.15 x 266.7, tabloid 279.4 x 431.8; a custom size is ``WxH`` with units (``210x297mm``,
  ``8.5x11in``; a unit given on one side only applies to both). vpype reads a bare number as
  CSS pixels; inkarm reads it as millimetres (its unit everywhere), ``px`` being 1/96 in.
* orientation is enforced: portrait (width <= height) unless ``--landscape``, even for a
  custom size given the other way round.
* ``layout --fit-to-margins M``: the bounding box scaled (aspect kept) to the page less ``M``
  on every side; then placed by ``--align left|center|right`` and ``--valign
  top|center|bottom`` within the page less the margin (less nothing without
  ``--fit-to-margins``), centred by default.
* ``scale`` and ``rotate`` act about the bounding box's centre; vpype's ``rotate`` is
  clockwise-positive on the page (its y points down).

Coordinates: inkarm's page frame [mm], origin at the page's lower-left corner, x right, y up:
``--valign top`` puts the drawing against the page's top edge (largest y), and
:attr:`Layout.rotation_deg` is counter-clockwise as seen on the page (the CLI's ``--rotate``,
clockwise as vpype's, is its negative). Times [s] are never changed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

import numpy as np

from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError, closest
from inkarm.io.toml import TomlReader

PAGE_SIZES_MM: dict[str, tuple[float, float]] = {
    "a6": (105.0, 148.0), "a5": (148.0, 210.0), "a4": (210.0, 297.0), "a3": (297.0, 420.0),
    "a2": (420.0, 594.0), "a1": (594.0, 841.0), "a0": (841.0, 1189.0),
    "letter": (215.9, 279.4), "legal": (215.9, 355.6), "executive": (185.15, 266.7),
    "tabloid": (279.4, 431.8),
}
UNITS_MM: dict[str, float] = {"mm": 1.0, "cm": 10.0, "in": 25.4, "inch": 25.4,
                              "px": 25.4 / 96.0, "pt": 25.4 / 72.0}
ALIGNS = ("left", "center", "right")
VALIGNS = ("top", "center", "bottom")
OVERSHOOTS = ("refit", "clip")
MAX_PAGE_MM = 10000.0  # the longest page side [mm]: a 10 m roll
MAX_SCALE = 1000.0
TOLERANCE_MM = 1e-9

_NUMBER = r"(\d+(?:\.\d*)?|\.\d+)"
_UNIT = "|".join(sorted(UNITS_MM, key=len, reverse=True))
_LENGTH_RE = re.compile(rf"^{_NUMBER}\s*({_UNIT})?$")
_SIZE_RE = re.compile(rf"^{_NUMBER}\s*({_UNIT})?\s*x\s*{_NUMBER}\s*({_UNIT})?$")


def _unknown(value, names, key: str, what: str = "value", tail: str = "",
             near=None) -> InputError:
    """The error for ``value`` (a ``what``) not one of ``names`` (``tail`` ends the list), the
    name closest to ``near`` (default ``value``) offered."""
    close = closest(value if near is None else near, names)
    hint = f" (did you mean '{close}'?)" if close else ""
    return InputError(f"unknown {what} {value!r}{hint}; expected one of {', '.join(names)}"
                      f"{tail}", key=key, value=value, choices=tuple(names))


def check_overshoot(how, key: str = "overshoot") -> str:
    """``how``, when one of :data:`OVERSHOOTS`; else an :class:`InputError` naming ``key``."""
    if how not in OVERSHOOTS:
        raise _unknown(how, OVERSHOOTS, key)
    return how


def parse_length(text, key: str) -> float:
    """A length [mm] from ``10``, ``10mm``, ``1cm``, ``0.5in`` (a number alone is in mm)."""
    if isinstance(text, bool):
        text = repr(text)
    if isinstance(text, (int, float)):
        value = float(text)
    else:
        match = _LENGTH_RE.match(str(text).strip().lower())
        if match is None:
            raise InputError(f"expected a length such as 10mm, 1cm or 0.5in (units: "
                             f"{', '.join(UNITS_MM)}; a number alone is mm), got {text!r}",
                             key=key, value=text)
        value = float(match.group(1)) * UNITS_MM[match.group(2) or "mm"]
    if not (np.isfinite(value) and 0 <= value <= MAX_PAGE_MM):
        raise InputError(f"expected a length in [0, {MAX_PAGE_MM:g}] mm, got {text!r}",
                         key=key, value=text)
    return value


def parse_page_size(text, key: str = "page_size") -> tuple[float, float]:
    """(width, height) [mm] of a page named as vpype names it (module docstring), as given
    (orientation is :func:`oriented`'s)."""
    name = str(text).strip().lower()
    if name in PAGE_SIZES_MM:
        return PAGE_SIZES_MM[name]
    match = _SIZE_RE.match(name)
    if match is None:
        raise _unknown(text, PAGE_SIZES_MM, key, "page size", f" or WxH with a unit "
                       f"({', '.join(UNITS_MM)}), e.g. 210x297mm or 8.5x11in", near=name)
    w, w_unit, h, h_unit = match.groups()
    w_unit = w_unit or h_unit or "mm"
    h_unit = h_unit or w_unit
    size = (float(w) * UNITS_MM[w_unit], float(h) * UNITS_MM[h_unit])
    if not all(0 < v <= MAX_PAGE_MM for v in size):
        raise InputError(f"expected each side in (0, {MAX_PAGE_MM:g}] mm, got {text!r} "
                         f"({size[0]:g} x {size[1]:g} mm)", key=key, value=text)
    return size


def oriented(size: tuple[float, float], landscape: bool) -> tuple[float, float]:
    """The page turned as vpype's ``_normalize_page_size`` turns it: width <= height
    (portrait) unless ``landscape``, then width >= height."""
    w, h = float(size[0]), float(size[1])
    return (h, w) if (landscape and w < h) or (not landscape and w > h) else (w, h)


@dataclass(frozen=True)
class Layout:
    """How a drawing goes on its page. Lengths [mm], angles [deg] (module docstring).

    Attributes:
        page_size: The page (width, height) before orientation; None: the drawing's own.
        landscape: Landscape orientation (else portrait), as vpype's ``--landscape``.
        fit_to_margins_mm: Scale the bounding box (aspect kept) to the page less this margin
            on every side, as vpype's ``--fit-to-margins``; None: keep the drawing's size.
        scale: Scale factor about the bounding box's centre (vpype's ``scale``); not with
            ``fit_to_margins_mm``.
        align, valign: Where the bounding box goes within the page (less the margin); None
            (not asked): "center".
        rotation_deg: Counter-clockwise rotation about the bounding box's centre, first.
    """

    page_size: tuple[float, float] | None = None
    landscape: bool = False
    fit_to_margins_mm: float | None = None
    scale: float | None = None
    align: str | None = None
    valign: str | None = None
    rotation_deg: float = 0.0

    def __post_init__(self) -> None:
        if self.page_size is not None:
            w, h = (float(v) for v in self.page_size)
            if not all(np.isfinite(v) and 0 < v <= MAX_PAGE_MM for v in (w, h)):
                raise InputError(f"expected a page of (0, {MAX_PAGE_MM:g}] mm a side, got "
                                 f"{self.page_size}", key="page_size", value=self.page_size)
            object.__setattr__(self, "page_size", (w, h))
        margin = self.fit_to_margins_mm
        if margin is not None and not (np.isfinite(margin) and 0 <= margin <= MAX_PAGE_MM / 2):
            raise InputError(f"expected a margin in [0, {MAX_PAGE_MM / 2:g}] mm, got {margin}",
                             key="fit_to_margins", value=margin)
        if self.scale is not None:
            if not (np.isfinite(self.scale) and 0 < self.scale <= MAX_SCALE):
                raise InputError(f"expected a scale factor in (0, {MAX_SCALE:g}], got "
                                 f"{self.scale}", key="scale", value=self.scale)
            if margin is not None:
                raise InputError("give a scale or fit to margins, not both (fitting sets the "
                                 "scale)", key="scale", value=self.scale)
        for key, value, names in (("align", self.align, ALIGNS), ("valign", self.valign, VALIGNS)):
            if value is not None and value not in names:
                raise _unknown(value, names, key)
        if not (np.isfinite(self.rotation_deg) and abs(self.rotation_deg) <= 3600):
            raise InputError(f"expected an angle in [-3600, 3600] deg, got {self.rotation_deg}",
                             key="rotation_deg", value=self.rotation_deg)

    @property
    def places(self) -> bool:
        """Whether the drawing is placed on a page (vpype's ``layout``), not only scaled or
        rotated where it stands."""
        return (self.page_size is not None or self.landscape or self.fit_to_margins_mm is not None
                or self.align is not None or self.valign is not None)

    def page(self, own: tuple[float, float]) -> tuple[float, float]:
        """The page [mm], oriented; ``own``: the drawing's page, when none is given."""
        size = self.page_size if self.page_size is not None else own
        return oriented(size, self.landscape) if self.places else (float(own[0]), float(own[1]))

    def area(self, own: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """The lowest and highest corners [mm] of the page less the margin."""
        w, h = self.page(own)
        m = self.fit_to_margins_mm or 0.0
        return np.array([m, m]), np.array([w - m, h - m])


def _moved(drawing: Drawing, linear: np.ndarray, offset: np.ndarray,
           page: tuple[float, float]) -> Drawing:
    """Every x, y mapped to ``linear @ xy + offset`` (velocities by ``linear``), times, z,
    pressures and meta kept."""
    strokes = []
    for s in drawing.strokes:
        pos = np.array(s.pos, dtype=float)
        pos[:, :2] = pos[:, :2] @ linear.T + offset
        vel = None
        if s.vel is not None:
            vel = np.array(s.vel, dtype=float)
            vel[:, :2] = vel[:, :2] @ linear.T
        strokes.append(replace(s, pos=pos, vel=vel))
    return Drawing(strokes, page_size=page, meta=dict(drawing.meta))


def _xy_bounds(drawing: Drawing) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = drawing.bounds()
    return np.asarray(lo[:2], dtype=float), np.asarray(hi[:2], dtype=float)


def lay_out(drawing: Drawing, layout: Layout) -> Drawing:
    """``drawing`` rotated and scaled about its bounding box's centre, then (when the layout
    :attr:`~Layout.places` it) fitted to the margins and aligned on the page, whose size it
    takes; times, strokes and meta (``meta["layers"]`` included) unchanged."""
    if drawing.dim < 2:
        raise InputError(f"drawing: expected x, y positions, got {drawing.dim} column",
                         key="drawing")
    page = layout.page(drawing.page_size)
    lo, hi = _xy_bounds(drawing)
    centre = 0.5 * (lo + hi)
    a = np.deg2rad(layout.rotation_deg)
    linear = (layout.scale or 1.0) * np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    out = _moved(drawing, linear, centre - linear @ centre, page)
    if not layout.places:
        return out
    lo, hi = _xy_bounds(out)
    size = hi - lo
    area_lo, area_hi = layout.area(page)
    room = area_hi - area_lo
    if np.any(room <= 0):
        raise InputError(f"a margin of {layout.fit_to_margins_mm:g} mm leaves nothing of the "
                         f"{page[0]:g} x {page[1]:g} mm page", key="fit_to_margins",
                         value=layout.fit_to_margins_mm)
    k = 1.0
    if layout.fit_to_margins_mm is not None:
        sized = size > TOLERANCE_MM
        if not np.any(sized):
            raise InputError("the drawing is a single point: there is nothing to fit to the "
                             "margins", key="fit_to_margins", value=layout.fit_to_margins_mm)
        k = float(np.min(room[sized] / size[sized]))
    size = k * size
    x = {"left": area_lo[0], "right": area_hi[0] - size[0]}.get(
        layout.align or "center", area_lo[0] + 0.5 * (room[0] - size[0]))
    y = {"bottom": area_lo[1], "top": area_hi[1] - size[1]}.get(
        layout.valign or "center", area_lo[1] + 0.5 * (room[1] - size[1]))
    return out.transformed(k, np.array([x, y]) - k * lo)


def outside(drawing: Drawing, lo, hi) -> tuple[int, int] | None:
    """The first (stroke, sample) index, 0-based, whose x, y lies outside ``lo``..``hi``
    [mm]; None when every point lies inside."""
    return _first_outside((np.asarray(s.pos, dtype=float)[:, :2] for s in drawing.strokes),
                          lo, hi)


def _first_outside(xys, lo, hi) -> tuple[int, int] | None:
    """:func:`outside` over the (n, 2) x, y arrays ``xys``, one a stroke."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    for s, xy in enumerate(xys):
        bad = np.flatnonzero(np.any((xy < lo - 1e-6) | (xy > hi + 1e-6), axis=1))
        if bad.size:
            return s, int(bad[0])
    return None


def refit(drawing: Drawing, lo, hi) -> tuple[Drawing, float]:
    """``drawing`` kept inside ``lo``..``hi`` [mm]: unchanged when it lies inside; else
    scaled down about its bounding box's centre just enough to fit (aspect kept), then
    moved the least that puts it inside. Returns it and the scale factor (1: not scaled)."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    b_lo, b_hi = _xy_bounds(drawing)
    if np.all(b_lo >= lo - TOLERANCE_MM) and np.all(b_hi <= hi + TOLERANCE_MM):
        return drawing, 1.0
    size = b_hi - b_lo
    sized = size > TOLERANCE_MM
    k = float(min(1.0, *((hi - lo)[sized] / size[sized]))) if np.any(sized) else 1.0
    centre = 0.5 * (b_lo + b_hi)
    new_lo, new_hi = centre - 0.5 * k * size, centre + 0.5 * k * size
    shift = np.maximum(lo - new_lo, 0.0) - np.maximum(new_hi - hi, 0.0)
    return drawing.transformed(k, centre - k * centre + shift), k


def _clip_segments(p: np.ndarray, lo: np.ndarray, hi: np.ndarray):
    """Liang-Barsky: for each segment p[i] -> p[i+1], the parameters (u0, u1) of its part
    inside ``lo``..``hi``, and whether it has one."""
    a, d = p[:-1], np.diff(p, axis=0)
    u0, u1 = np.zeros(len(d)), np.ones(len(d))
    visible = np.ones(len(d), dtype=bool)
    for axis in range(2):
        for q, sign in ((a[:, axis] - lo[axis], -1.0), (hi[axis] - a[:, axis], 1.0)):
            pp = sign * d[:, axis]
            parallel = np.abs(pp) < 1e-15
            visible &= ~(parallel & (q < -TOLERANCE_MM))
            with np.errstate(divide="ignore", invalid="ignore"):
                r = np.where(parallel, 0.0, q / np.where(parallel, 1.0, pp))
            entering, leaving = ~parallel & (pp < 0), ~parallel & (pp > 0)
            u0 = np.where(entering, np.maximum(u0, r), u0)
            u1 = np.where(leaving, np.minimum(u1, r), u1)
    return u0, u1, visible & (u0 <= u1)


def _clip_stroke(s: Trajectory, lo: np.ndarray, hi: np.ndarray) -> list[Trajectory]:
    """The pieces of ``s`` inside ``lo``..``hi`` [mm]: every column (time, z, velocity,
    pressure) interpolated where a segment crosses the edge."""
    xy = np.asarray(s.pos, dtype=float)[:, :2]
    if len(xy) == 1:
        return [s] if np.all((xy[0] >= lo) & (xy[0] <= hi)) else []
    u0, u1, visible = _clip_segments(xy, lo, hi)
    columns = [np.asarray(s.t, dtype=float)[:, None], np.asarray(s.pos, dtype=float)]
    columns += [np.asarray(c, dtype=float).reshape(len(xy), -1) for c in (s.vel, s.pressure)
                if c is not None]
    data = np.hstack(columns)
    starts = data[:-1] + u0[:, None] * np.diff(data, axis=0)
    ends = data[:-1] + u1[:, None] * np.diff(data, axis=0)
    joined = visible[:-1] & visible[1:] & (u1[:-1] >= 1.0) & (u0[1:] <= 0.0)
    pieces = []
    i, n = 0, len(visible)
    while i < n:
        if not visible[i]:
            i += 1
            continue
        j = i
        while j < n - 1 and joined[j]:
            j += 1
        rows = np.vstack([starts[i:i + 1], ends[i:j + 1]])
        rows = rows[np.concatenate(([True], np.diff(rows[:, 0]) > 0))]
        if len(rows) > 1:
            dim = s.pos.shape[1]
            col = 1 + dim
            vel = rows[:, col:col + dim] if s.vel is not None else None
            col += dim if s.vel is not None else 0
            pressure = rows[:, col] if s.pressure is not None else None
            pieces.append(Trajectory(rows[:, 0], rows[:, 1:1 + dim], vel, pressure))
        i = j + 1
    return pieces


def clip(drawing: Drawing, lo, hi) -> tuple[Drawing, int]:
    """``drawing`` cut at the edges of ``lo``..``hi`` [mm]: what lies outside is not drawn
    (the pen lifts there), a stroke that leaves and comes back becomes two; ``meta["layers"]``
    follows the pieces. Returns it and the number of strokes cut."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    layers = None if drawing.meta.get("layers") is None else drawing.layer_ids()
    strokes, kept_layers, cut = [], [], 0
    for k, s in enumerate(drawing.strokes):
        if _first_outside([np.asarray(s.pos, dtype=float)[:, :2]], lo, hi) is None:
            pieces = [s]
        else:
            pieces, cut = _clip_stroke(s, lo, hi), cut + 1
        strokes += pieces
        if layers is not None:
            kept_layers += [int(layers[k])] * len(pieces)
    if not strokes:
        raise InputError(f"nothing of the drawing lies inside ({lo[0]:g}, {lo[1]:g}) to "
                         f"({hi[0]:g}, {hi[1]:g}) mm", key="overshoot", value="clip")
    meta = dict(drawing.meta)
    if layers is not None:
        meta["layers"] = np.asarray(kept_layers, dtype=np.int64)
    return Drawing(strokes, page_size=drawing.page_size, meta=meta), cut


def keep_inside(drawing: Drawing, lo, hi, how: str) -> tuple[Drawing, str]:
    """``drawing`` kept inside ``lo``..``hi`` [mm] by ``how`` ("refit": :func:`refit`;
    "clip": :func:`clip`), and a sentence saying what was done."""
    check_overshoot(how)
    where = f"({lo[0]:g}, {lo[1]:g}) to ({hi[0]:g}, {hi[1]:g}) mm"
    if how == "refit":
        kept, k = refit(drawing, lo, hi)
        return kept, (f"overshoot refit: scaled by {k:.6f} to stay within {where}" if k < 1
                      else f"overshoot refit: moved to stay within {where}"
                      if kept is not drawing else f"no overshoot: inside {where}")
    kept, cut = clip(drawing, lo, hi)
    return kept, (f"overshoot clip: {cut} strokes cut at the edges of {where}" if cut
                  else f"no overshoot: inside {where}")


LAYOUT_KEYS = ("page_size", "landscape", "fit_to_margins_mm", "align", "valign")
"""A TOML table's layout keys (a scenario's ``[placement]``)."""


def read_layout_keys(rd: TomlReader, table: dict, where: str) -> dict:
    """The layout keys (:data:`LAYOUT_KEYS`) of the TOML ``table`` at ``where``, checked
    (errors name the reader's file and ``where.key``): ``page_size`` as a name, ``"WxH"`` or
    ``[w, h]`` [mm], ``landscape``, ``fit_to_margins_mm``, ``align``, ``valign``; refused
    beside ``centre_mm`` (the layout places the drawing) or a fit beside ``height_mm`` or
    ``scale``."""
    given = [k for k in LAYOUT_KEYS if k in table]
    if given and "centre_mm" in table:
        raise rd.error(where, f"give centre_mm or the page layout ({', '.join(given)}), not "
                       "both: the layout places the drawing on the page")
    if "fit_to_margins_mm" in table and ({"height_mm", "scale"} & set(table)):
        raise rd.error(where, "give fit_to_margins_mm or height_mm/scale, not both: fitting "
                       "sets the scale")
    kw: dict = {}
    raw = table.get("page_size")
    if isinstance(raw, list):
        c = rd.array(raw, f"{where}.page_size", 1)
        if c.shape != (2,) or not np.all((c > 0) & (c <= MAX_PAGE_MM)):
            raise rd.error(f"{where}.page_size", f"expected [width, height] in (0, "
                           f"{MAX_PAGE_MM:g}] mm, got {raw}", value=raw)
        kw["page_size"] = (float(c[0]), float(c[1]))
    elif raw is not None:
        try:
            kw["page_size"] = parse_page_size(rd.text(raw, f"{where}.page_size"))
        except InputError as e:
            if e.file is not None:  # (the reader's own: not a string)
                raise
            raise rd.error(f"{where}.page_size", e.message, value=raw,
                           choices=e.choices) from None
    if "landscape" in table:
        kw["landscape"] = rd.boolean(table["landscape"], f"{where}.landscape")
    if "fit_to_margins_mm" in table:
        kw["fit_to_margins_mm"] = rd.number(table["fit_to_margins_mm"],
                                            f"{where}.fit_to_margins_mm", 0.0,
                                            maximum=MAX_PAGE_MM / 2)
    for key, names in (("align", ALIGNS), ("valign", VALIGNS)):
        if key in table:
            kw[key] = rd.choice(table[key], f"{where}.{key}", names)
    return kw


__all__ = ["ALIGNS", "LAYOUT_KEYS", "OVERSHOOTS", "PAGE_SIZES_MM", "VALIGNS", "Layout",
           "check_overshoot", "clip", "keep_inside", "lay_out", "oriented", "outside",
           "parse_length", "parse_page_size", "read_layout_keys", "refit"]
