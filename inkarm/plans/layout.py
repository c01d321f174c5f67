"""Text on the page: glyphs placed line by line, words wrapped at the right margin.

Control characters other than newline and tab are refused by name (:func:`check_characters`).

Coordinates: page frame in [mm], x right, y up, origin at the page's lower-left corner.
"""

from __future__ import annotations

import unicodedata
from dataclasses import dataclass

import numpy as np

from inkarm.core.trajectory import A4_MM
from inkarm.errors import InputError
from inkarm.plans.fonts import HersheyFont


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
