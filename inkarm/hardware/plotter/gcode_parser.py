"""GRBL 1.1h's line filter and G-code word parser (its ``protocol.c`` main loop and step 2 of
``gcode.c`` ``gc_execute_line``), as inkarm's own code.

The line filter (:func:`normalise`, :func:`filter_line`) drops what GRBL drops before a line is
parsed: control characters and spaces, ``/``, ``(...)`` comments and everything after ``;``;
letters are upper-cased. What is left may be :data:`MAX_LINE` = 79 characters (GRBL's 80-byte
line buffer less its terminator); one more sets the overflow flag and the line is answered
``error:11`` whatever it holds.

:func:`parse_block` reads the words of a filtered line into a :class:`Block` with GRBL's
word-level checks, in GRBL's order (the first failing check gives the code):

====  ===============================================================
code  why (GRBL 1.1 ``error:N``)
====  ===============================================================
1     a word does not start with a letter A-Z
2     a letter without a number after it
4     a negative F, N, P, T or S
20    an unknown G or M command or letter (G38.x other than .2-.5, G43 other than .1)
21    two commands of one modal group
23    a non-integer G or M number (G28.1, G30.1, G92.1, G91.1, G43.1 and G38.x aside)
24    two axis commands in one line (G0-G3/G38 with G10/G28/G30/G92, or G43.1/G49)
25    a value word repeated
38    a tool number T above 255
====  ===============================================================

The checks that need the machine's state (feed undefined, axis words missing, arcs, G10's
P and L, unused words) are in :mod:`inkarm.hardware.plotter.interpreter`.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

MAX_LINE = 79  # GRBL 1.1h LINE_BUFFER_SIZE (80) less the terminating zero
MAX_INT_DIGITS = 8  # GRBL nuts_bolts.h: digits read_float keeps
MAX_TOOL_NUMBER = 255
AXIS_NONE, AXIS_NON_MODAL, AXIS_MOTION, AXIS_TOOL_LENGTH = 0, 1, 2, 3
VALUE_LETTERS = "FIJKLNPRSTXYZ"
NEGATIVE_REFUSED = "FNPTS"


class GcodeError(Exception):
    """A line GRBL refuses, with its ``error:N`` code."""

    def __init__(self, code: int, why: str):
        super().__init__(f"error:{code} ({why})")
        self.code = code


@dataclass
class Block:
    """What one line asks for (GRBL's parser block before the state checks).

    Attributes:
        groups: The modal groups given a command ("motion", "non-modal", "plane", "distance",
            "arc distance", "feed mode", "units", "cutter", "tool length", "coord", "path",
            "flow", "spindle", "coolant"), each with its command (G28.1 as 28.1, G38.2 as 38.2).
        coolant: The coolant M codes given (8 or 9).
        values: The value words by letter (F, I, J, K, L, N, P, R, S, T, X, Y, Z).
        axis_command: None, a non-modal axis command (G10/G28/G30/G92), a motion command or a
            tool length offset (AXIS_* constants).
    """

    groups: dict[str, float] = field(default_factory=dict)
    coolant: list[int] = field(default_factory=list)
    values: dict[str, float] = field(default_factory=dict)
    axis_command: int = AXIS_NONE

    def axis_words(self) -> list[int]:
        """Indices (0 X, 1 Y, 2 Z) of the axis words given."""
        return [i for i, a in enumerate("XYZ") if a in self.values]


def _kept(raw: str) -> Iterator[str]:
    """The characters GRBL keeps of a line, upper-cased: whitespace, control characters, ``/``
    (block delete), ``(...)`` comments and everything after ``;`` are dropped."""
    paren = semicolon = False
    for ch in raw:
        if paren or semicolon:
            paren = paren and ch != ")"
            continue
        if ch <= " " or ch == "/":
            continue
        if ch == "(":
            paren = True
        elif ch == ";":
            semicolon = True
        else:
            yield ch.upper() if "a" <= ch <= "z" else ch


def filter_line(raw: str) -> tuple[str, bool]:
    """GRBL's character filter over one received line: the characters kept (upper-cased), at
    most :data:`MAX_LINE` of them, and whether the line overflowed the line buffer."""
    kept = list(itertools.islice(_kept(raw), MAX_LINE + 1))
    return "".join(kept[:MAX_LINE]), len(kept) > MAX_LINE


def normalise(line: str) -> str:
    """The characters of ``line`` GRBL keeps (see :func:`filter_line`), overflow ignored."""
    return "".join(_kept(line))


def read_float(text: str, pos: int) -> tuple[float, int] | None:
    """GRBL's ``read_float``: an optional sign, digits with at most one point (no exponent),
    the value in single precision and the index after it; None without a digit."""
    i, negative = pos, False
    if i < len(text) and text[i] in "+-":
        negative = text[i] == "-"
        i += 1
    whole, exp, ndigit, decimal = 0, 0, 0, False
    while i < len(text):
        ch = text[i]
        if "0" <= ch <= "9":
            ndigit += 1
            if ndigit <= MAX_INT_DIGITS:
                exp -= decimal
                whole = whole * 10 + ord(ch) - 48
            elif not decimal:
                exp += 1
        elif ch == "." and not decimal:
            decimal = True
        else:
            break
        i += 1
    if not ndigit:
        return None
    value = np.float32(whole)
    if value != 0:
        while exp <= -2:
            value = np.float32(value * np.float32(0.01))
            exp += 2
        if exp < 0:
            value = np.float32(value * np.float32(0.1))
        while exp > 0:
            value = np.float32(value * np.float32(10.0))
            exp -= 1
    return (-float(value) if negative else float(value)), i


def _g_group(block: Block, code: int, mantissa: int) -> tuple[str, float]:
    """The modal group and command of ``G<code>.<mantissa/10>`` (GRBL's step 2 switch)."""
    if code in (10, 28, 30, 92) and mantissa == 0:
        if block.axis_command:
            raise GcodeError(24, f"G{code} with another axis command")
        block.axis_command = AXIS_NON_MODAL
    if code in (4, 10, 28, 30, 53, 92):
        if code in (28, 30, 92) and mantissa not in (0, 10):
            raise GcodeError(20, f"G{code}.{mantissa // 10} is not a GRBL command")
        return "non-modal", code + (0.1 if mantissa == 10 and code in (28, 30, 92) else 0)
    if code in (0, 1, 2, 3, 38, 80):
        if code != 80:
            if block.axis_command:
                raise GcodeError(24, f"G{code} with another axis command")
            block.axis_command = AXIS_MOTION
        if code == 38:
            if mantissa not in (20, 30, 40, 50):
                raise GcodeError(20, "G38 needs .2, .3, .4 or .5")
            return "motion", 38 + mantissa / 100
        return "motion", code
    if code in (17, 18, 19):
        return "plane", code
    if code in (90, 91):
        if mantissa == 0:
            return "distance", code
        if mantissa != 10 or code == 90:
            raise GcodeError(20, "G90.1 is not supported")
        return "arc distance", 91.1
    simple = {93: "feed mode", 94: "feed mode", 20: "units", 21: "units", 40: "cutter",
              54: "coord", 55: "coord", 56: "coord", 57: "coord", 58: "coord", 59: "coord"}
    if code in simple:
        return simple[code], code
    if code in (43, 49):
        if block.axis_command:
            raise GcodeError(24, f"G{code} with another axis command")
        block.axis_command = AXIS_TOOL_LENGTH
        if code == 43 and mantissa != 10:
            raise GcodeError(20, "only G43.1 of the G43 family is supported")
        return "tool length", 43.1 if code == 43 else 49
    if code == 61:
        if mantissa:
            raise GcodeError(20, "G61.1 is not supported")
        return "path", 61
    raise GcodeError(20, f"unsupported command G{code}")


_M_GROUPS = {0: "flow", 1: "flow", 2: "flow", 30: "flow", 3: "spindle", 4: "spindle",
             5: "spindle", 8: "coolant", 9: "coolant"}
_INT_EXEMPT = (28.1, 30.1, 92.1, 91.1, 43.1)


def parse_block(line: str, start: int = 0) -> Block:
    """Read the words of a filtered line (from ``start``: 3 after ``$J=``) into a
    :class:`Block`; raises :class:`GcodeError` with GRBL's code (see the module docstring)."""
    block, pos = Block(), start
    while pos < len(line):
        letter = line[pos]
        if not "A" <= letter <= "Z":
            raise GcodeError(1, f"expected a command letter at {line[pos:]!r}")
        read = read_float(line, pos + 1)
        if read is None:
            raise GcodeError(2, f"bad number format after {letter} in {line!r}")
        value, pos = read
        int_value = int(np.float32(value))  # (trunc)
        mantissa = round(100 * (value - int_value))
        if letter == "G":
            group, command = _g_group(block, int_value, mantissa)
            if mantissa > 0 and command not in _INT_EXEMPT and not 38 < command < 39:
                raise GcodeError(23, f"G{value:g} is not an integer command")
            if group in block.groups:
                raise GcodeError(21, f"G{command:g} and G{block.groups[group]:g} are in one "
                                 "modal group")
            block.groups[group] = command
        elif letter == "M":
            if mantissa > 0:
                raise GcodeError(23, f"M{value:g} is not an integer command")
            if int_value not in _M_GROUPS:
                raise GcodeError(20, f"unsupported command M{int_value}")
            group = _M_GROUPS[int_value]
            if group in block.groups:
                raise GcodeError(21, f"M{int_value} and M{block.groups[group]:g} are in one "
                                 "modal group")
            block.groups[group] = int_value
            if group == "coolant":
                block.coolant.append(int_value)
        elif letter in VALUE_LETTERS:
            if letter == "T" and value > MAX_TOOL_NUMBER:
                raise GcodeError(38, f"tool T{value:g} above {MAX_TOOL_NUMBER}")
            if letter in block.values:
                raise GcodeError(25, f"{letter} given twice")
            if letter in NEGATIVE_REFUSED and value < 0:
                raise GcodeError(4, f"{letter}{value:g} is negative")
            if letter in "LT":
                value = float(int_value)
            elif letter == "N":
                value = float(int(value))
            block.values[letter] = value
        else:
            raise GcodeError(20, f"unsupported word {letter}")
    if block.axis_words() and not block.axis_command:
        block.axis_command = AXIS_MOTION
    return block


__all__ = ["AXIS_MOTION", "AXIS_NONE", "AXIS_NON_MODAL", "AXIS_TOOL_LENGTH", "MAX_LINE",
           "Block", "GcodeError", "filter_line", "normalise", "parse_block", "read_float"]
