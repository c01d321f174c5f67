"""The SVG grammar of the attributes inkarm draws from, checked before svgelements reads them.

svgelements is lenient: it silently drops what follows a typo in path data, a ``points`` list
or a ``transform``, so a file with one mistake would be drawn partly and without a word. These
checks follow the grammars of SVG 1.1 (paths: section 8.3.9, "The grammar for path data";
points: section 9.7.1; transforms: section 7.6.1) and raise an
:class:`~inkarm.errors.InputError` at the first character that breaks them, naming the element
(``where``) and the character.
"""

from __future__ import annotations

import re

from inkarm.errors import InputError

NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
"""An SVG number (sign, digits, fraction, exponent)."""
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
MAX_TRANSFORM_ARG = 1e9
"""Largest |argument| of an SVG transform (an angle, scale or offset beyond it is an error)."""


def check_transform(text: str | None, where: str) -> None:
    """Raise InputError unless ``text`` is a list of SVG transforms (matrix, translate, scale,
    rotate, skewX, skewY) with valid argument counts, each argument at most
    :data:`MAX_TRANSFORM_ARG` in magnitude."""
    if not text:
        return
    pos = 0
    for call in re.finditer(r"\s*,?\s*(\w+)\s*\(([^)]*)\)", text):
        if call.start() != pos:
            break
        pos = call.end()
        name, args = call.group(1), [float(v) for v in NUMBER.findall(call.group(2))]
        if not all(abs(v) <= MAX_TRANSFORM_ARG for v in args):
            raise InputError(
                f"{where}: transform {call.group(0).strip()!r}: arguments must be numbers of "
                f"magnitude at most {MAX_TRANSFORM_ARG:g}",
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


def check_points(text: str, where: str) -> None:
    """Raise InputError unless ``points`` (of a polyline or polygon) holds an even count of at
    least 4 numbers."""
    values, pos = 0, 0
    while True:
        pos = _SEPARATORS.match(text, pos).end()
        if pos == len(text):
            break
        m = NUMBER.match(text, pos)
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


def check_length(text: str | None, where: str, name: str) -> None:
    """Raise InputError unless ``text`` (a geometry attribute such as ``r`` or ``x``) is absent
    or one number with an optional unit or percent sign (or ``auto``, for ``rx`` and ``ry``)."""
    if text is None:
        return
    if text.strip() == "auto" and name in ("rx", "ry"):
        return
    if not re.fullmatch(rf"\s*{NUMBER.pattern}\s*(?:mm|cm|in|pt|pc|px|em|ex|%)?\s*", text):
        raise InputError(
            f"{where}: {name}={text[:40]!r}: expected a number with an optional unit "
            "(mm, cm, in, pt, pc, px, em, ex or %)",
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
                m = NUMBER.match(d, pos)
                if not m:
                    expected = "a number" if first or k else "a number or a path command"
                    _grammar_error(d, pos, expected, where)
                pos = m.end()
            pos, first = _SEPARATORS.match(d, pos).end(), False
        pos = _SEPARATORS.match(d, pos).end()


def _grammar_error(d: str, pos: int, expected: str, where: str):
    got = d[pos : pos + 10] or "end of data"
    raise InputError(f"{where}: d: expected {expected} at character {pos}, got {got!r}", value=d)
