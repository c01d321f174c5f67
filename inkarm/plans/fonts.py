"""Hershey vector fonts, glyphs scaled to [mm] (seed 000 sec. 4.1: the letters' outlines).

The glyph outlines come from the Hershey vector fonts (``hershey-fonts`` package); the
single-line script font ``scripts`` (the default) joins its lower-case letters like connected
handwriting (``scriptc`` is its doubled-line cut, drawn with several passes per letter).

Coordinates: a glyph's own frame in [mm], x right, y up, origin at its left side on the base
line.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from inkarm.errors import InputError

DEFAULT_FONT = "scripts"
DEFAULT_HEIGHT = 10.0  # [mm]: cap height


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
