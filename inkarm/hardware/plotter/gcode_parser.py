"""GRBL 1.1's G-code line parser, for the subset a pen plotter uses.

A line is normalised as GRBL does (spaces and comments dropped, letters upper-cased), split
into words (a letter and a number), checked word by word and modal group by modal group, and
returned as a :class:`Block` of what it asks for, or refused with GRBL's error code:

====  ===============================================================
code  meaning (GRBL 1.1 ``error:N``)
====  ===============================================================
1     expected a command letter
2     bad number format
11    line longer than 80 characters
20    unsupported or invalid G/M command
21    two commands of one modal group
23    a G/M command needs an integer value
25    a word repeated
26    no axis words for a command that needs them
====  ===============================================================

Supported: G0 G1 G2 G3 (I, J offsets) G4 (P seconds) G17 G20 G21 G90 G91 G92 G94 G54, M3 M4
M5 M2 M30, F S N and X Y Z.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

MAX_LINE = 80  # GRBL's LINE_BUFFER_SIZE
_WORD = re.compile(r"([A-Z])([-+]?(?:\d+\.?\d*|\.\d+))")
_MOTION = {0: "G0", 1: "G1", 2: "G2", 3: "G3"}
_G_GROUPS = {0: "motion", 1: "motion", 2: "motion", 3: "motion", 4: "non-modal",
             92: "non-modal", 17: "plane", 20: "units", 21: "units", 90: "distance",
             91: "distance", 94: "feed mode", 54: "coordinate system"}
_M_GROUPS = {3: "spindle", 4: "spindle", 5: "spindle", 2: "stopping", 30: "stopping"}
_VALUE_LETTERS = set("FSNXYZIJP")


class GcodeError(Exception):
    """A line GRBL refuses, with its ``error:N`` code."""

    def __init__(self, code: int, why: str):
        super().__init__(f"error:{code} ({why})")
        self.code = code


@dataclass
class Block:
    """What one line asks for (GRBL's parser block).

    Attributes:
        g: The G commands given, by modal group.
        m: The M commands given, by modal group.
        values: The value words (F, S, X, Y, Z, I, J, P, N).
    """

    g: dict[str, int] = field(default_factory=dict)
    m: dict[str, int] = field(default_factory=dict)
    values: dict[str, float] = field(default_factory=dict)

    @property
    def axes(self) -> dict[str, float]:
        return {k: v for k, v in self.values.items() if k in "XYZ"}


def normalise(line: str) -> str:
    """The line as GRBL's protocol layer passes it on: comments ``(...)`` and ``;...`` and
    whitespace removed, letters upper-cased."""
    out, in_paren = [], False
    for ch in line:
        if in_paren:
            in_paren = ch != ")"
        elif ch == "(":
            in_paren = True
        elif ch == ";":
            break
        elif not ch.isspace():
            out.append(ch.upper())
    return "".join(out)


def parse_block(line: str) -> Block:
    """Parse one normalised G-code line; raises :class:`GcodeError` with GRBL's code."""
    block, pos = Block(), 0
    while pos < len(line):
        m = _WORD.match(line, pos)
        if m is None:
            if not line[pos].isalpha():
                raise GcodeError(1, f"expected a command letter at {line[pos:]!r}")
            raise GcodeError(2, f"bad number format at {line[pos:]!r}")
        letter, number = m.group(1), float(m.group(2))
        pos = m.end()
        if letter in "GM":
            code = int(number)
            if code != number:
                raise GcodeError(23 if letter == "M" else 20,
                                 f"{letter}{m.group(2)} is not supported")
            groups = _G_GROUPS if letter == "G" else _M_GROUPS
            if code not in groups:
                raise GcodeError(20, f"unsupported command {letter}{code}")
            target = block.g if letter == "G" else block.m
            group = groups[code]
            if group in target and not (group == "non-modal" and target[group] == code):
                raise GcodeError(21, f"{letter}{code} and {letter}{target[group]} are in one "
                                 "modal group")
            target[group] = code
        elif letter in _VALUE_LETTERS:
            if letter in block.values:
                raise GcodeError(25, f"{letter} given twice")
            block.values[letter] = number
        else:
            raise GcodeError(20, f"unsupported word {letter}")
    return block
