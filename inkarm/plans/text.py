"""Text to motor plans: Hershey glyphs -> Gaussian targets -> ligatured strokes (seed 000 sec. 4.1).

The glyph outlines come from the Hershey vector fonts (``hershey-fonts`` package); the
single-line script font ``scripts`` (the default) joins its lower-case letters like connected
handwriting (``scriptc`` is its doubled-line cut, drawn with several passes per letter). A
glyph stroke is a sparse polyline already, so its vertices are the target loci (seed 000
sec. 4: targets near curvature extrema), optionally thinned by turning angle. Letters whose
pen-up gap is small are joined into one stroke (a ligature).

Angle convention: the *turning angle* at vertex p_i is the angle between the incoming
direction p_i - p_{i-1} and the outgoing one p_{i+1} - p_i, in [0, 180] deg: 0 = straight on,
180 = full reversal (a cusp). Seed 000 says a ligature removes a target "if the angle formed
with the previous target and the next is larger than a user-defined threshold" (100 deg in
its Fig. 10); read as the interior angle (180 = straight) that rule would delete the harmless
straight-through targets and keep the hooks, the opposite of a smooth ligature, so we read it
as the turning angle, computed by :func:`inkarm.analysis.density.turning_angles` (in radians,
converted here).

Ligatures keep the letters. Dropping targets until no junction is sharp (seed 000's rule,
still used for asemic tags) cuts off what they outlined: Hershey's script a, c, d, g, o, q
and w start on the far side of their bowl and turn back over it, so the rule ate the top of
the bowl (font -> drawing 3 mm on "inkarm"). Here no junction target turns by more than the
threshold either, but the *connector* gives way: it swings back over the bowl and loops into
the letter's first target (a cursive retrace written as an eyelet), or leaves the exit's last
point, which lies on the next letter, for that letter to draw, or bends
(:func:`join_ligatures`). How far the written text is from the font, both ways, is measured
by :mod:`inkarm.plans.fidelity`.

Control characters other than newline and tab are refused by name (:func:`check_characters`).

Coordinates: page frame in [mm], x right, y up, origin at the page's lower-left corner.
"""

from __future__ import annotations

import math
import unicodedata
from dataclasses import dataclass
from functools import lru_cache
from itertools import pairwise
from typing import NamedTuple

import numpy as np

from inkarm.core.plan import MotorPlan
from inkarm.core.trajectory import A4_MM, Drawing
from inkarm.errors import InputError
from inkarm.plans.fidelity import (  # noqa: F401 - the fidelity measures, re-exported
    TextFidelity,
    font_deviation,
    outline_deviation,
    sample_letters,
    text_fidelity,
)
from inkarm.plans.handstyles import Handstyle, get_handstyle

DEFAULT_FONT = "scripts"
DEFAULT_HEIGHT = 10.0
_SAME_POINT = 1e-6  # [mm]: endpoints closer than this are one point


# -- fonts --------------------------------------------------------------------------------


@dataclass(frozen=True)
class Glyph:
    """One character of a font, scaled to [mm].

    Attributes:
        char: The character.
        strokes: Pen-down polylines, each (n, 2) in [mm], origin at the glyph's left side on
            the base line, y up.
        advance: Horizontal distance to the next glyph's origin in [mm].
    """

    char: str
    strokes: tuple[np.ndarray, ...]
    advance: float


@lru_cache(maxsize=8)
def _hershey(name: str):
    from HersheyFonts import HersheyFonts

    font = HersheyFonts()
    if name not in font.default_font_names:
        raise InputError(
            f"unknown font {name!r}; available: {', '.join(sorted(font.default_font_names))}"
        )
    font.load_default_font(name)
    return font


class HersheyFont:
    """A Hershey font whose cap height (base line to cap line) is ``height`` [mm].

    Hershey units: y grows downwards, cap line at -12, base line at 9 (so 21 units are
    ``height``); the package stores each glyph's left and right side bearings.
    """

    def __init__(self, name: str = DEFAULT_FONT, height: float = DEFAULT_HEIGHT) -> None:
        if not (np.isfinite(height) and height > 0):
            raise InputError(f"letter height must be a positive number of mm, got {height}")
        self.name = name
        self.height = float(height)
        font = _hershey(name)
        opts = font.render_options
        self._base = float(opts["base_line"])
        self._scale = self.height / (self._base - float(opts["cap_line"]))  # [mm per unit]
        self._glyphs = font.all_glyphs

    def glyph(self, char: str) -> Glyph:
        """The glyph for ``char``; InputError naming the character if the font lacks it."""
        g = self._glyphs.get(char)
        if g is None:
            raise InputError(f"font {self.name!r} has no glyph for {char!r} (U+{ord(char):04X})")
        return _scaled_glyph(self._scale, self._base, char, g)

    def has(self, char: str) -> bool:
        return char in self._glyphs


@lru_cache(maxsize=1024)
def _scaled_glyph(scale: float, base: float, char: str, g) -> Glyph:
    strokes = []
    for stroke in g.strokes:
        s = np.asarray(stroke, dtype=float)
        mm = np.column_stack([(s[:, 0] - g.left_offset) * scale, (base - s[:, 1]) * scale])
        mm.flags.writeable = False  # shared by the cache
        strokes.append(mm)
    return Glyph(char, tuple(strokes), g.char_width * scale)


# -- page layout --------------------------------------------------------------------------


@dataclass(frozen=True)
class PageLayout:
    """Where text goes on the page, all in [mm].

    Attributes:
        page_size: (width, height) of the page.
        margins: (left, right, top, bottom) margins.
        line_height: Distance between base lines; None = 2 x the letter height.
    """

    page_size: tuple[float, float] = A4_MM
    margins: tuple[float, float, float, float] = (20.0, 20.0, 20.0, 20.0)
    line_height: float | None = None

    def __post_init__(self) -> None:
        w, h = self.page_size
        left, right, top, bottom = self.margins
        if not (w > 0 and h > 0):
            raise InputError(
                f"page size must be positive (width, height) in mm, got {self.page_size}"
            )
        if min(self.margins) < 0 or left + right >= w or top + bottom >= h:
            raise InputError(
                f"margins (left, right, top, bottom) = {self.margins} mm leave no room on a "
                f"{w} x {h} mm page"
            )
        if self.line_height is not None and not self.line_height > 0:
            raise InputError(f"line height must be positive, got {self.line_height} mm")


@dataclass(frozen=True)
class PlacedGlyph:
    """A glyph on the page: ``index`` is its position in the text, ``origin`` its left side on
    the base line and ``strokes`` its polylines, in page [mm]."""

    char: str
    index: int
    strokes: tuple[np.ndarray, ...]
    origin: tuple[float, float]


def layout_text(
    text: str, font: HersheyFont, layout: PageLayout = PageLayout()
) -> list[PlacedGlyph]:
    """Place ``text`` on the page, line by line, wrapping words at the right margin.

    Newlines start a new line; runs of spaces and tabs separate words. A word wider than the
    line is broken between letters. Raises InputError for any other control character (a
    carriage return included: new lines are ``\\n``), empty text, a character the font lacks,
    or text that runs past the bottom margin.
    """
    check_characters(text)
    if not text.strip():
        raise InputError("text is empty: nothing to write")
    for ch in text:
        if ch not in "\n\t " and not font.has(ch):
            font.glyph(ch)  # raises, naming the character
    w, h = layout.page_size
    left, right, top, bottom = layout.margins
    line_height = layout.line_height or 2.0 * font.height
    space = font.glyph(" ").advance
    x, y = left, h - top - font.height
    placed: list[PlacedGlyph] = []
    index = 0

    def new_line() -> None:
        nonlocal x, y
        x, y = left, y - line_height

    for p, paragraph in enumerate(text.split("\n")):
        if p > 0:
            index += 1  # the newline
            new_line()
        at_line_start = True
        for word, start in _words(paragraph):
            glyphs = [font.glyph(c) for c in word]
            width = sum(g.advance for g in glyphs)
            gap = 0.0 if at_line_start else space
            if not at_line_start and x + gap + width > w - right:
                new_line()
                gap = 0.0
            x += gap
            for k, g in enumerate(glyphs):
                if x + g.advance > w - right and x > left:
                    new_line()  # a word longer than the line: break it
                placed.append(
                    PlacedGlyph(
                        g.char, index + start + k, tuple(s + (x, y) for s in g.strokes), (x, y)
                    )
                )
                x += g.advance
            at_line_start = False
        index += len(paragraph)
    lowest = min((s[:, 1].min() for pg in placed for s in pg.strokes), default=y)
    if lowest < bottom:
        raise InputError(
            f"text does not fit on the page: it reaches {lowest:.1f} mm above the page's lower "
            f"edge but the bottom margin is {bottom} mm; shorten it or lower the letter height"
        )
    return placed


_C0_NAMES = (
    "null", "start of heading", "start of text", "end of text", "end of transmission",
    "enquiry", "acknowledge", "bell", "backspace", "character tabulation", "line feed",
    "line tabulation", "form feed", "carriage return", "shift out", "shift in",
    "data link escape", "device control one", "device control two", "device control three",
    "device control four", "negative acknowledge", "synchronous idle",
    "end of transmission block", "cancel", "end of medium", "substitute", "escape",
    "information separator four", "information separator three",
    "information separator two", "information separator one",
)
"""The Unicode names (aliases) of the C0 control characters U+0000 to U+001F."""


def control_character_name(ch: str) -> str:
    """The name of a control character (Unicode category Cc), e.g. "carriage return"."""
    code = ord(ch)
    if code < len(_C0_NAMES):
        return _C0_NAMES[code]
    return {0x7F: "delete", 0x85: "next line"}.get(code, "C1 control")


def check_characters(text: str) -> None:
    """Refuse control characters other than newline and tab, naming the first one, its code
    point and its index in ``text``: InputError, e.g. ``text: control character U+000D
    (carriage return) at index 5``."""
    for i, ch in enumerate(text):
        if ch not in "\n\t" and unicodedata.category(ch) == "Cc":
            hint = "; new lines are \\n" if ch in "\r\x0b\x0c\x85" else ""
            raise InputError(
                f"text: control character U+{ord(ch):04X} ({control_character_name(ch)}) "
                f"at index {i}{hint}"
            )


def _words(line: str) -> list[tuple[str, int]]:
    """(word, offset) for each run of non-blank characters in ``line``."""
    words, start = [], None
    for i, ch in enumerate(line + " "):
        if ch in " \t":
            if start is not None:
                words.append((line[start:i], start))
                start = None
        elif start is None:
            start = i
    return words


# -- targets and ligatures ----------------------------------------------------------------


def thin_polyline(points: np.ndarray, min_turn: float) -> np.ndarray:
    """Keep the end points and every vertex where the path has turned by >= ``min_turn`` [deg]
    since the last kept vertex; consecutive duplicates are dropped.

    The heading change is measured from the chord (last kept vertex -> vertex) to the next
    edge, so a gentle arc keeps one target every ``min_turn`` degrees of turning.
    """
    return _thin(_dedupe(np.asarray(points, dtype=float)), min_turn)


def _thin(pts: np.ndarray, min_turn: float) -> np.ndarray:
    """:func:`thin_polyline` of a polyline without consecutive duplicates."""
    if min_turn <= 0 or len(pts) <= 2:
        return pts
    xy = pts.tolist()  # Python floats: the same IEEE operations, without array overhead
    kept = [0]
    kx, ky = xy[0]
    for i in range(1, len(xy) - 1):
        (x, y), (nx, ny) = xy[i], xy[i + 1]
        cx, cy = x - kx, y - ky  # the chord from the last kept vertex
        ex, ey = nx - x, ny - y  # the next edge
        if math.degrees(abs(math.atan2(cx * ey - cy * ex, cx * ex + cy * ey))) >= min_turn:
            kept.append(i)
            kx, ky = x, y
    kept.append(len(xy) - 1)
    return pts[kept]


def subdivide(points: np.ndarray, max_spacing: float | None) -> np.ndarray:
    """Insert evenly spaced vertices so no edge is longer than ``max_spacing`` [mm].

    Under local isochrony every target gets the same time, so a long edge would be crossed
    at a dash and overshoot its end; extra targets on it keep the speed even.
    """
    if max_spacing is None or len(points) < 2:
        return points
    return _subdivide_all([points], max_spacing)[0]


def _subdivide_all(polylines: list[np.ndarray], max_spacing: float | None) -> list[np.ndarray]:
    """:func:`subdivide` of every polyline (n_j, 2), in a few array operations for all: the
    first vertex, then for each edge from a to b of length l, k = max(1, ceil(l /
    max_spacing)) vertices a + (j / k) (b - a), j = 1 .. k."""
    if max_spacing is None:
        return polylines
    n = np.array([len(p) for p in polylines], dtype=np.int64)
    if not len(n) or not n.sum():
        return polylines
    points = np.vstack(polylines)
    starts = (np.cumsum(n) - n)[n > 0]  # each polyline's first vertex
    # vertex i brings the edge into it, from i - 1 (a first vertex brings itself)
    step = np.zeros_like(points)
    step[1:] = np.diff(points, axis=0)
    step[starts] = 0.0
    k = np.maximum(1, np.ceil(np.linalg.norm(step, axis=1) / max_spacing)).astype(np.int64)
    k[starts] = 1
    src = np.arange(len(points)) - 1
    src[starts] += 1
    block = np.repeat(np.arange(len(points)), k)
    j = np.arange(len(block)) - np.repeat(np.cumsum(k) - k, k) + 1
    out = points[src[block]] + (j / k[block])[:, None] * step[block]
    at = np.cumsum(k) - k  # where each vertex's block starts
    out[at[starts]] = points[starts]  # first vertices exactly as they are
    total = np.concatenate([[0], np.cumsum(k)])
    ends = np.cumsum(n)
    return [
        p if len(p) < 2 else out[total[e - len(p)]:total[e]]
        for p, e in zip(polylines, ends.tolist())
    ]


def _dedupe(points: np.ndarray) -> np.ndarray:
    keep = np.ones(len(points), bool)
    keep[1:] = np.linalg.norm(np.diff(points, axis=0), axis=1) > _SAME_POINT
    return points[keep]


def _dedupe_all(polylines: list[np.ndarray]) -> list[np.ndarray]:
    """:func:`_dedupe` of every polyline (n_j, 2), in a few array operations for all."""
    n = np.array([len(p) for p in polylines], dtype=np.int64)
    if not len(n) or not n.sum():
        return [p[:0] for p in polylines]
    points = np.vstack(polylines)
    keep = np.ones(len(points), bool)
    keep[1:] = np.linalg.norm(np.diff(points, axis=0), axis=1) > _SAME_POINT
    keep[(np.cumsum(n) - n)[n > 0]] = True  # each polyline's first point
    total = np.concatenate([[0], np.cumsum(keep)])  # points kept before each point
    kept = total[np.cumsum(n)] - total[np.cumsum(n) - n]  # per polyline
    return [p.copy() for p in np.split(points[keep], np.cumsum(kept)[:-1])]


@dataclass
class TargetSequence:
    """Target means along one pen-down path, with where each target came from.

    Attributes:
        means: (m, 2) target means in [mm].
        letters: (m,) index in the text of the letter each target came from.
        connectors: (m,) True where the path *into* the target is not part of the letter's
            font outline (a bridged pen-up gap, or a junction target was dropped).
        joinable: False for a delayed mark (an i dot), which is never joined to another path.
    """

    means: np.ndarray
    letters: np.ndarray
    connectors: np.ndarray
    joinable: bool = True

    def __len__(self) -> int:
        return len(self.means)


def join_ligatures(
    pieces: list[TargetSequence], max_gap: float, max_turn: float, eyelet: float | None = None
) -> list[TargetSequence]:
    """Join consecutive target sequences into ligatures (seed 000 sec. 4.1).

    Two sequences are joined when both are joinable, the pen-up gap between them is at most
    ``max_gap`` [mm], and they belong to the same letter or to neighbouring letters of the
    text (so never across a space). Pieces of the same letter are joined as they are (a
    Hershey letter breaks its strokes at retraced cusps, which belong to the letter's form);
    an end point shared by two pieces (zero gap) counts once.

    Where two *letters* meet, no *junction target* (the last target of the first letter, the
    connector targets, the first target of the second) may turn by more than ``max_turn``
    [deg]. How that is reached depends on ``eyelet``:

    * None: seed 000's rule, for asemic tags. Junction targets that turn more than
      ``max_turn`` are dropped, repeatedly, until none does (:func:`_drop_sharp`); the last
      target a letter has left is never dropped.
    * A size in [mm]: letters keep their targets and the connector bends instead
      (:func:`_join_letters`), seed 000's rule being only the last resort.

    Each junction sees only the two letters it joins, so the time is linear in the number of
    targets.
    """
    out: list[TargetSequence] = []
    ligature: _Ligature | None = None
    for piece in pieces:
        if not len(piece):
            continue
        if ligature is not None and ligature.takes(piece, max_gap):
            ligature.add(piece, max_turn, eyelet)
        else:
            if ligature is not None:
                out.append(ligature.sequence())
            ligature = _Ligature(piece)
    if ligature is not None:
        out.append(ligature.sequence())
    return out


class _Ligature:
    """A ligature being built: the letters already joined (never changed again), the last
    targets before the current letter (the context its turning angles need), and the current
    letter's targets, the only ones the next junction may change."""

    CONTEXT = 2

    def __init__(self, piece: TargetSequence) -> None:
        self.done: list[TargetSequence] = []
        self.context = _slice(piece, 0, 0)
        self.tail = _slice(piece, 0, len(piece))

    def takes(self, piece: TargetSequence, max_gap: float) -> bool:
        last = int(self.tail.letters[-1])
        return bool(
            self.tail.joinable
            and piece.joinable
            and np.linalg.norm(piece.means[0] - self.tail.means[-1]) <= max_gap
            and int(piece.letters[0]) in (last, last + 1)
        )

    def add(self, piece: TargetSequence, max_turn: float, eyelet: float | None) -> None:
        shared = _same(piece.means[0], self.tail.means[-1])
        following = _slice(piece, 1 if shared else 0, len(piece))
        if not len(following):
            return  # a single target on the end of the path: nothing to add
        if not shared:
            following.connectors[0] = True
        if piece.letters[0] == self.tail.letters[-1]:
            self.tail = _concat([self.tail, following])
            return
        first, second = _join_letters(
            self.context, self.tail, following, piece.means, shared, max_turn, eyelet
        )
        self.done.append(first)
        context = _concat([self.context, first])
        self.context = _slice(context, max(0, len(context) - self.CONTEXT), len(context))
        self.tail = second

    def sequence(self) -> TargetSequence:
        return _concat([*self.done, self.tail])


_SWING = 1.6
"""The longest connector that swings back along the next letter's outline, as a multiple of
the gap it bridges (pi / 2: half round a bowl, from one side to the other)."""


def _join_letters(
    context: TargetSequence,
    first: TargetSequence,
    second: TargetSequence,
    outline: np.ndarray,
    shared: bool,
    max_turn: float,
    eyelet: float | None,
) -> tuple[TargetSequence, TargetSequence]:
    """Join the targets of one letter, ``second`` (without a start point it shares with
    ``first``), to those of the letter before, ``first``, which follows the ``context``
    targets (read for turning angles, never changed). ``outline`` (k, 2) [mm] is the second
    letter's first piece, its start point included even when ``shared`` with ``first``.
    Returns the targets of both letters, connector targets included, so that no junction
    target turns by more than ``max_turn`` [deg].

    With an ``eyelet`` size [mm], the first of these junctions whose targets all turn by at
    most ``max_turn`` is taken, so every letter target is kept while one is:

    1. the straight connector;
    2. the *swing*: where the first letter's exit ends on the second letter's outline (the
       Hershey script's exit strokes end on the side of a following a, c, d, g, o, q or w,
       whose pen starts on the far side of the bowl and turns back over it), the connector
       swings back along that outline, up to ``eyelet`` outside it, and turns into the first
       target through a loop of diameter ``eyelet``: a cursive hand's retrace at the top of
       the bowl, written as an eyelet rather than a cusp (:func:`_swing_connector`);
    3. the last target of the first letter left out when it lies on the second letter's
       outline (the exit overshooting into the next letter, whose pen draws that point);
    4. a *bend*: one connector target after the first letter and/or before the second, at
       ``eyelet`` or a third of the gap, that turns the pen part of the way
       (:func:`_bends`), with or without 3.

    Otherwise (and without an ``eyelet``, or where the letters share the junction point)
    seed 000's rule: :func:`_drop_sharp`.
    """
    b_letter = int(second.letters[0])

    def attempt(head: TargetSequence, links: list[tuple[np.ndarray, int]]):
        joined = _with_links(context, head, links, second)
        lo = len(context) + len(head) - 1
        hi = lo + len(links) + (0 if shared else 1)
        pts = joined.means.tolist()
        for i in range(lo, hi + 1):
            turn = _turn_at(pts, i)
            if turn is not None and turn > max_turn:
                return None
        return joined

    joined = attempt(first, [])
    if joined is None and eyelet is not None and eyelet > 0 and not shared:
        joined = _shape_keeping_join(context, first, second, outline, max_turn, eyelet, attempt)
    if joined is None:
        joined = _with_links(context, first, [], second)
        joint = len(context) + len(first)
        joined = _drop_sharp(joined, [joint - 1, joint], max_turn)
    return _split(joined, len(context), b_letter)


def _shape_keeping_join(context, first, second, outline, max_turn, eyelet, attempt):
    """Steps 2 to 4 of :func:`_join_letters`: the first smooth join, or None."""
    a_letter, b_letter = int(first.letters[-1]), int(second.letters[0])
    p = first.means[-1]
    on_next = len(outline) > 1 and _distance_to_path(p, outline) <= 0.5 * eyelet
    if on_next:
        swing = _swing_connector(p, outline, eyelet, max_turn)
        if swing is not None and (joined := attempt(first, [(x, b_letter) for x in swing])):
            return joined
    heads = [first]
    if on_next and len(first) > 1:
        heads.insert(0, _slice(first, 0, len(first) - 1))
        if joined := attempt(heads[0], []):
            return joined
    after = _distinct_after(second.means, 0)
    for head in reversed(heads):  # the whole first letter first
        before = _distinct_before(np.vstack([context.means, head.means]))
        for bend in _bends(before, head.means[-1], second.means[0], after, eyelet, max_turn):
            links = [(x, a_letter if own else b_letter) for x, own in bend]
            if joined := attempt(head, links):
                return joined
    return None


def _swing_connector(
    p: np.ndarray, outline: np.ndarray, eyelet: float, max_turn: float
) -> np.ndarray | None:
    """Connector targets (k, 2) [mm] from ``p``, a point on the polyline ``outline`` (the next
    letter's first piece), back along the outline to its start S and into S through an
    eyelet: a half circle of diameter ``eyelet`` outside the outline, so the pen arrives at S
    heading where the letter goes on. The connector runs outside the outline, its offset
    growing from 0 at ``p`` to ``eyelet`` at S. None when ``p`` is at S or the way back is
    longer than :data:`_SWING` times the gap, or the eyelet would need more than 12 targets
    to turn by at most ``max_turn`` [deg] at each."""
    s = outline[0]
    a, ab = outline[:-1], np.diff(outline, axis=0)
    length2 = np.einsum("ij,ij->i", ab, ab)
    u = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(length2, 1e-300), 0.0, 1.0)
    k = int(np.argmin(np.linalg.norm(a + u[:, None] * ab - p, axis=1)))
    index = np.arange(k if u[k] > 0 else k - 1, 0, -1)  # outline vertices between p and S
    index = index[np.linalg.norm(outline[index] - p, axis=1) > _SAME_POINT]
    path = np.vstack([p, outline[index], s])
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    gap = float(np.linalg.norm(s - p))
    if gap <= _SAME_POINT or steps.sum() > _SWING * gap:
        return None
    n_loop = max(3, int(np.ceil(180.0 / (0.9 * max_turn)))) if max_turn > 0 else 99
    if n_loop > 12:
        return None
    edges = ab / np.maximum(np.sqrt(length2), 1e-300)[:, None]  # the outline's way, from S
    normals = _outward_side(outline) * np.column_stack([edges[:, 1], -edges[:, 0]])
    at_vertex = np.vstack([normals[:1], normals[:-1] + normals[1:], normals[-1:]])
    at_vertex /= np.maximum(np.linalg.norm(at_vertex, axis=1, keepdims=True), 1e-300)
    along = np.cumsum(steps)  # from p to each vertex of the way back, and to S
    lifted = outline[index] + (eyelet * along[:-1] / along[-1])[:, None] * at_vertex[index]
    v, n = edges[0], normals[0]
    phi = np.pi * np.arange(n_loop) / n_loop  # from S + eyelet n round to (not including) S
    loop = s + 0.5 * eyelet * ((1.0 + np.cos(phi))[:, None] * n - np.sin(phi)[:, None] * v)
    return np.vstack([lifted, loop])


def _outward_side(outline: np.ndarray) -> float:
    """+1 if the polyline's outside is to the right of its direction (it turns left, as a
    bowl written anticlockwise), -1 if to the left: from its signed turning over its first
    half turn."""
    d = np.diff(outline, axis=0)
    total = 0.0
    for a, b in pairwise(d):
        total += float(np.arctan2(a[0] * b[1] - a[1] * b[0], a @ b))
        if abs(total) >= np.pi / 2:
            break
    return 1.0 if total >= 0 else -1.0


def _bends(
    before: np.ndarray | None,
    p: np.ndarray,
    s: np.ndarray,
    after: np.ndarray | None,
    eyelet: float,
    max_turn: float,
):
    """Candidate connectors from ``p`` to ``s`` [mm] (lists of (point, belongs to the first
    letter)): a target after ``p`` turning the pen from its way into ``p`` (from ``before``)
    towards ``s``, and/or one before ``s`` from which it reaches ``s`` heading within 0.8 x
    ``max_turn`` of where it goes next (to ``after``), each ``eyelet`` or a third of the gap
    away from its end."""
    chord = s - p
    gap = float(np.linalg.norm(chord))
    if gap <= _SAME_POINT:
        return
    step = np.radians(0.8 * max_turn)
    for length in (eyelet, gap / 3):
        bend = []
        if before is not None:
            heading = _rotate_towards(p - before, chord, step)
            if heading is not None:
                bend.append((p + length * heading, True))
        if after is not None:
            heading = _rotate_towards(after - s, chord, step)
            if heading is not None:
                bend.append((s - length * heading, False))
        if bend:
            yield bend


def _rotate_towards(d: np.ndarray, target: np.ndarray, step: float) -> np.ndarray | None:
    """The unit direction ``d`` turned towards ``target`` by ``step`` [rad]; None when the two
    are within ``step`` already (no bend needed at that end)."""
    angle = float(np.arctan2(d[0] * target[1] - d[1] * target[0], d @ target))
    if abs(angle) <= step:
        return None
    a = np.sign(angle) * step
    c, s = np.cos(a), np.sin(a)
    d = d / np.linalg.norm(d)
    return np.array([c * d[0] - s * d[1], s * d[0] + c * d[1]])


def _drop_sharp(seq: TargetSequence, candidates: list[int], max_turn: float) -> TargetSequence:
    """Drop junction targets whose turning angle exceeds ``max_turn`` [deg], repeatedly: when
    a target goes, its kept neighbours form the new junction and are checked in turn, until
    no junction target of the two joined letters turns by more than ``max_turn``. The ends of
    the sequence, and the last target a letter has left in it, are never dropped."""
    keep = np.ones(len(seq), bool)
    connectors = seq.connectors.copy()
    todo = [i for i in candidates if 0 <= i < len(seq)]
    joined = {int(seq.letters[i]) for i in todo}
    while todo:
        i = todo.pop(0)
        same_letter = keep & (seq.letters == seq.letters[i])
        if not keep[i] or int(seq.letters[i]) not in joined or same_letter.sum() == 1:
            continue
        turn = _turn_at(seq.means, i, keep)
        if turn is not None and turn > max_turn:
            keep[i] = False
            a = np.flatnonzero(keep[:i])[-1]
            b = i + 1 + np.flatnonzero(keep[i + 1 :])[0]
            connectors[b] = True
            todo += [a, b]
    return TargetSequence(seq.means[keep], seq.letters[keep], connectors[keep], seq.joinable)


def _turn_at(means, i: int, keep: np.ndarray | None = None) -> float | None:
    """Turning angle in [deg] at target ``i``, between the nearest (kept) targets before and
    after it at another point (a target repeated in place turns where the path turns); None
    at an end of the path. ``means``: (m, D) array, or its ``tolist()`` (faster when asked
    at several targets)."""
    pts = means.tolist() if isinstance(means, np.ndarray) else means
    a = _distinct_index(pts, i, -1, keep)
    b = _distinct_index(pts, i, +1, keep)
    if a is None or b is None:
        return None
    return _turn_angle(pts[a], pts[i], pts[b])


def _turn_angle(p: list[float], q: list[float], r: list[float]) -> float:
    """Turning angle in [deg] at q of the path p, q, r (three points apart): the value of
    :func:`inkarm.analysis.density.turning_angles` (Kahan's angle between the steps) at q,
    in the same floating-point operations, on Python floats."""
    u = [b - a for a, b in zip(p, q)]
    v = [b - a for a, b in zip(q, r)]
    nu = math.sqrt(sum(c * c for c in u))
    nv = math.sqrt(sum(c * c for c in v))
    a = [c * nv for c in u]
    b = [c * nu for c in v]
    minus = math.sqrt(sum((x - y) * (x - y) for x, y in zip(a, b)))
    plus = math.sqrt(sum((x + y) * (x + y) for x, y in zip(a, b)))
    return math.degrees(2.0 * math.atan2(minus, plus))


def _distinct_index(means, i: int, step: int, keep=None) -> int | None:
    """The nearest (kept) target from ``i`` in direction ``step`` at another point (more than
    ``_SAME_POINT`` away); ``means`` an (m, D) array or its ``tolist()``."""
    pts = means.tolist() if isinstance(means, np.ndarray) else means
    here = pts[i]
    j = i + step
    while 0 <= j < len(pts):
        if (keep is None or keep[j]) and math.sqrt(
            sum((a - b) * (a - b) for a, b in zip(pts[j], here))
        ) > _SAME_POINT:
            return j
        j += step
    return None


def _distinct_before(means: np.ndarray) -> np.ndarray | None:
    """The last point of ``means`` before its end point at another point, or None."""
    j = _distinct_index(means, len(means) - 1, -1)
    return None if j is None else means[j]


def _distinct_after(means: np.ndarray, i: int) -> np.ndarray | None:
    j = _distinct_index(means, i, +1)
    return None if j is None else means[j]


def _distance_to_path(p: np.ndarray, polyline: np.ndarray) -> float:
    """Distance in [mm] from the point ``p`` to the polyline (k >= 2, 2)."""
    a, ab = polyline[:-1], np.diff(polyline, axis=0)
    length2 = np.einsum("ij,ij->i", ab, ab)
    u = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(length2, 1e-300), 0.0, 1.0)
    return float(np.min(np.linalg.norm(a + u[:, None] * ab - p, axis=1)))


def junction_turns(
    means: np.ndarray, letters, connectors
) -> list[tuple[int, int, float]]:
    """(letter before, letter after, largest turning angle [deg]) of every junction between
    two letters along a target path: the targets from the last one of a letter's outline
    through the connector targets to the first one of the next letter (a start point shared
    by both letters alone)."""
    means = np.asarray(means, dtype=float)
    letters, connectors = np.asarray(letters), np.asarray(connectors, dtype=bool)
    out = []
    for j in np.flatnonzero(letters[1:] != letters[:-1]) + 1:
        lo = j - 1
        while lo > 0 and connectors[lo] and letters[lo - 1] == letters[lo]:
            lo -= 1  # connector targets of the first letter
        hi = j - 1
        while hi + 1 < len(means) and connectors[hi + 1] and letters[hi + 1] == letters[j]:
            hi += 1  # connector targets of the second letter, and its first target
        turns = [t for i in range(lo, hi + 1) if (t := _turn_at(means, i)) is not None]
        out.append((int(letters[j - 1]), int(letters[j]), max(turns, default=0.0)))
    return out


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.linalg.norm(a - b) <= _SAME_POINT)


def _slice(seq: TargetSequence, lo: int, hi: int) -> TargetSequence:
    return TargetSequence(
        seq.means[lo:hi].copy(), seq.letters[lo:hi].copy(), seq.connectors[lo:hi].copy(),
        seq.joinable,
    )


def _concat(seqs: list[TargetSequence]) -> TargetSequence:
    return TargetSequence(
        np.concatenate([s.means for s in seqs]),
        np.concatenate([s.letters for s in seqs]),
        np.concatenate([s.connectors for s in seqs]),
        seqs[-1].joinable,
    )


def _with_links(
    context: TargetSequence,
    head: TargetSequence,
    links: list[tuple[np.ndarray, int]],
    second: TargetSequence,
) -> TargetSequence:
    """``context`` + ``head`` + connector targets (point, letter) + ``second``."""
    middle = TargetSequence(
        np.array([x for x, _ in links], dtype=float).reshape(-1, 2),
        np.array([letter for _, letter in links], dtype=head.letters.dtype),
        np.ones(len(links), bool),
    )
    return _concat([context, head, middle, second])


def _split(joined: TargetSequence, n_context: int, second: int) -> tuple[TargetSequence, ...]:
    """The joined targets after the context: those before the second letter's, and its own."""
    body = _slice(joined, n_context, len(joined))
    k = int(np.argmax(body.letters == second)) if np.any(body.letters == second) else len(body)
    return _slice(body, 0, k), _slice(body, k, len(body))


def glyph_targets(
    placed: list[PlacedGlyph],
    thin_angle: float,
    max_spacing: float | None = None,
    mark_size: float = 0.0,
) -> list[TargetSequence]:
    """One target sequence per glyph stroke, in writing order: the stroke's vertices thinned
    by ``thin_angle`` [deg], then long edges subdivided to at most ``max_spacing`` [mm].

    Strokes no larger than ``mark_size`` [mm] (i and j dots) are delayed to the end of their
    word, as a writer dots the i's after the word, and are not joined by ligatures.
    """
    out: list[TargetSequence] = []
    marks: list[TargetSequence] = []
    deduped = _dedupe_all([np.asarray(s, dtype=float) for pg in placed for s in pg.strokes])
    targets = iter(_subdivide_all([_thin(p, thin_angle) for p in deduped], max_spacing))
    for k, pg in enumerate(placed):
        for _ in pg.strokes:
            pts = next(targets)
            is_mark = float(np.max(np.ptp(pts, axis=0))) <= mark_size
            seq = TargetSequence(
                pts, np.full(len(pts), pg.index), np.zeros(len(pts), bool), not is_mark
            )
            (marks if is_mark else out).append(seq)
        word_ends = k + 1 == len(placed) or placed[k + 1].index != pg.index + 1
        if word_ends:
            out += marks
            marks = []
    return out


# -- text -> plan -> drawing --------------------------------------------------------------


@dataclass(frozen=True)
class TextPlan:
    """A written text: the motor plan plus what produced it (for figures and checks).

    Attributes:
        text: The text.
        plan: One stroke per pen-down ligature; stroke meta ``letters`` gives, per target,
            the index in ``text`` of the letter the target came from, and ``connectors``
            whether the path into the target is a ligature rather than the letter's outline.
        glyphs: The placed font glyphs (page [mm]).
        font: The font used.
    """

    text: str
    plan: MotorPlan
    glyphs: tuple[PlacedGlyph, ...]
    font: HersheyFont


def plan_text(
    text: str,
    style: Handstyle | str,
    height: float = DEFAULT_HEIGHT,
    font: str = DEFAULT_FONT,
    layout: PageLayout = PageLayout(),
    ligature_gap: float | None = None,
    seed: int | np.random.Generator | None = 0,
) -> TextPlan:
    """Text -> ligatured Gaussian targets with the covariances of ``style`` (a Handstyle).

    Args:
        text: What to write (newlines and tabs allowed, no other control character).
        style: The :class:`inkarm.plans.handstyles.Handstyle` (covariances, thinning,
            ligature angle and eyelet, time per target), or a preset's name.
        height: Cap height of the letters in [mm].
        font: Hershey font name (script fonts: ``scripts``, ``scriptc``).
        layout: Page, margins and line height.
        ligature_gap: Largest pen-up gap in [mm] bridged by a ligature; None = 0.45 x height
            (bridges most joins of the ``scripts`` lower case, never a space).
        seed: Seed or Generator for the covariance perturbation (rho > 0).
    """
    style = get_handstyle(style) if isinstance(style, str) else style
    f = HersheyFont(font, height)
    placed = layout_text(text, f, layout)
    gap = 0.45 * f.height if ligature_gap is None else float(ligature_gap)
    spacing = None if style.max_spacing is None else style.max_spacing * f.height
    pieces = glyph_targets(placed, style.thin_angle, spacing, mark_size=0.2 * f.height)
    eyelet = style.eyelet * f.height if style.eyelet > 0 else None
    pieces = join_ligatures(pieces, gap, style.ligature_angle, eyelet)
    rng = np.random.default_rng(seed)
    return TextPlan(text, style.motor_plan(pieces, rng, "letters"), tuple(placed), f)


class WrittenText(NamedTuple):
    """What :func:`write_text` returns (unpacks as ``tp, drawing``)."""

    text_plan: TextPlan
    drawing: Drawing

    def fidelity(self) -> TextFidelity:
        """How far the drawing is from the font, both ways (:func:`text_fidelity`)."""
        return text_fidelity(self.text_plan, self.drawing)


def write_text(text: str, style: Handstyle | str, dt: float = 0.01, **kwargs) -> WrittenText:
    """Plan and realise ``text`` with ``style`` (a Handstyle or a preset's name): the plan and
    the Drawing, strokes timed one after the other. Keyword arguments go to
    :func:`plan_text`."""
    style = get_handstyle(style) if isinstance(style, str) else style
    tp = plan_text(text, style, **kwargs)
    layout = kwargs.get("layout", PageLayout())
    return WrittenText(tp, style.realise(tp.plan, dt=dt, page_size=layout.page_size))
