"""Text to motor plans: Hershey glyphs -> Gaussian targets -> ligatured strokes (seed 000 sec. 4.1).

The glyph outlines come from the Hershey vector fonts (``hershey-fonts`` package); the
single-line script font ``scripts`` (the default) joins its lower-case letters like connected
handwriting (``scriptc`` is its doubled-line cut, drawn with several passes per letter). A glyph stroke is a
sparse polyline already, so its vertices are the target loci (seed 000 sec. 4: targets near
curvature extrema), optionally thinned by turning angle. Letters whose pen-up gap is small
are joined into one stroke (a ligature).

Angle convention: the *turning angle* at vertex p_i is the angle between the incoming
direction p_i - p_{i-1} and the outgoing one p_{i+1} - p_i, in [0, 180] deg: 0 = straight on,
180 = full reversal (a cusp). Seed 000 says a ligature removes a target "if the angle formed
with the previous target and the next is larger than a user-defined threshold" (100 deg in
its Fig. 10); read as the interior angle (180 = straight) that rule would delete the harmless
straight-through targets and keep the hooks, the opposite of a smooth ligature, so we read it
as the turning angle. It is computed by :func:`inkarm.analysis.density.turning_angles` (in
radians, converted here), and the rule is applied until no junction exceeds the threshold.
How far the written text is from the font is measured by :mod:`inkarm.plans.fidelity`.

Coordinates: page frame in [mm], x right, y up, origin at the page's lower-left corner.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from itertools import pairwise
from typing import NamedTuple

import numpy as np

from inkarm.analysis.density import turning_angles
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
    line is broken between letters. Raises InputError for empty text, a character the font
    lacks, or text that runs past the bottom margin.
    """
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
    pts = _dedupe(np.asarray(points, dtype=float))
    if min_turn <= 0 or len(pts) <= 2:
        return pts
    kept = [0]
    for i in range(1, len(pts) - 1):
        chord = pts[i] - pts[kept[-1]]
        edge = pts[i + 1] - pts[i]
        turn = np.degrees(np.abs(np.arctan2(chord[0] * edge[1] - chord[1] * edge[0], chord @ edge)))
        if turn >= min_turn:
            kept.append(i)
    kept.append(len(pts) - 1)
    return pts[kept]


def subdivide(points: np.ndarray, max_spacing: float | None) -> np.ndarray:
    """Insert evenly spaced vertices so no edge is longer than ``max_spacing`` [mm].

    Under local isochrony every target gets the same time, so a long edge would be crossed
    at a dash and overshoot its end; extra targets on it keep the speed even.
    """
    if max_spacing is None or len(points) < 2:
        return points
    out = [points[:1]]
    for a, b in pairwise(points):
        k = max(1, int(np.ceil(np.linalg.norm(b - a) / max_spacing)))
        out.append(a + np.outer(np.arange(1, k + 1) / k, b - a))
    return np.vstack(out)


def _dedupe(points: np.ndarray) -> np.ndarray:
    keep = np.ones(len(points), bool)
    keep[1:] = np.linalg.norm(np.diff(points, axis=0), axis=1) > _SAME_POINT
    return points[keep]


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
    pieces: list[TargetSequence], max_gap: float, max_turn: float
) -> list[TargetSequence]:
    """Join consecutive target sequences into ligatures (seed 000 sec. 4.1).

    Two sequences are joined when both are joinable, the pen-up gap between them is at most
    ``max_gap`` [mm], and they belong to the same letter or to neighbouring letters of the
    text (so never across a space). Pieces of the same letter are joined as they are (a
    Hershey letter breaks its strokes at retraced cusps, which belong to the letter's form).
    Where two *letters* meet, the last target of the first and then the first of the second
    are dropped if their turning angle exceeds ``max_turn`` [deg], so the ligature is smooth;
    an end point shared by both (zero gap) counts once.
    """
    if not pieces:
        return []
    out = [_copy(pieces[0])]
    for piece in pieces[1:]:
        prev = out[-1]
        gap = float(np.linalg.norm(piece.means[0] - prev.means[-1]))
        same_letter = prev.letters[-1] == piece.letters[0]
        neighbours = prev.letters[-1] + 1 == piece.letters[0]
        if not (
            prev.joinable and piece.joinable and gap <= max_gap and (same_letter or neighbours)
        ):
            out.append(_copy(piece))
            continue
        start = 1 if gap <= _SAME_POINT else 0
        connectors = piece.connectors[start:].copy()
        if start == 0:
            connectors[0] = True
        joint = len(prev)
        merged = TargetSequence(
            np.vstack([prev.means, piece.means[start:]]),
            np.concatenate([prev.letters, piece.letters[start:]]),
            np.concatenate([prev.connectors, connectors]),
        )
        if not same_letter:
            merged = _drop_sharp(merged, [joint - 1, joint], max_turn)
        out[-1] = merged
    return out


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
        turn = _turn_at(seq.means, keep, i)
        if turn is not None and turn > max_turn:
            keep[i] = False
            a = np.flatnonzero(keep[:i])[-1]
            b = i + 1 + np.flatnonzero(keep[i + 1 :])[0]
            connectors[b] = True
            todo += [a, b]
    return TargetSequence(seq.means[keep], seq.letters[keep], connectors[keep], seq.joinable)


def _turn_at(means: np.ndarray, keep: np.ndarray, i: int) -> float | None:
    """Turning angle in [deg] at kept target ``i``, between the nearest kept targets before and
    after it at another point (a target repeated in place turns where the path turns); None at
    an end of the path."""
    def distinct(indices) -> int | None:
        return next(
            (j for j in indices if np.linalg.norm(means[j] - means[i]) > _SAME_POINT), None
        )

    a = distinct(np.flatnonzero(keep[:i])[::-1])
    b = distinct(i + 1 + np.flatnonzero(keep[i + 1 :]))
    if a is None or b is None:
        return None
    return float(np.degrees(turning_angles(means[[a, i, b]])[1]))


def _copy(seq: TargetSequence) -> TargetSequence:
    return TargetSequence(seq.means.copy(), seq.letters.copy(), seq.connectors.copy(), seq.joinable)


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
    for k, pg in enumerate(placed):
        for stroke in pg.strokes:
            pts = subdivide(thin_polyline(stroke, thin_angle), max_spacing)
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
        text: What to write (newlines allowed).
        style: The :class:`inkarm.plans.handstyles.Handstyle` (covariances, thinning,
            ligature angle, time per target), or a preset's name.
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
    pieces = join_ligatures(pieces, gap, style.ligature_angle)
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
