"""Checked reading of TOML files (plans, scenarios, handstyles).

Every error is a :class:`inkarm.errors.ScenarioError` whose message starts with the file and the
key path, says what was expected and, for a mistyped key or value, the closest valid one.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np

from inkarm.errors import ScenarioError, closest

MAX_TOML_BYTES = 16 * 1024 * 1024  # far above any plan, scenario or profile a person writes


def load_toml(path: str | Path, what: str = "file") -> dict:
    """Parse a TOML file, naming the file in every error."""
    path = Path(path)
    if not path.is_file():
        raise ScenarioError(f"no such {what}", file=str(path))
    if path.stat().st_size > MAX_TOML_BYTES:
        raise ScenarioError(f"{path.stat().st_size} bytes, more than the {MAX_TOML_BYTES} a "
                            f"{what} may have", file=str(path))
    try:
        # utf-8-sig: a byte-order mark (as some editors write) is accepted, as in CSV files.
        return tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except RecursionError:
        raise ScenarioError("nested too deeply (arrays or tables inside each other)",
                            file=str(path)) from None
    except tomllib.TOMLDecodeError as e:
        raise ScenarioError(f"not valid TOML: {e}", file=str(path)) from None
    except UnicodeDecodeError as e:
        raise ScenarioError(f"not UTF-8 text: {e}", file=str(path)) from None


class TomlReader:
    """Reads values out of parsed TOML, raising ScenarioError that names the file and key.

    Keys are written as paths, ``strokes[1].targets[2].cov``; typos get a difflib suggestion.
    """

    def __init__(self, source: str):
        self.source = source

    def error(self, key: str, message: str, value=ScenarioError.NO_VALUE,
              choices=()) -> ScenarioError:
        return ScenarioError(message, file=self.source, key=key or None, value=value,
                             choices=choices)

    def table(self, value, key: str) -> dict:
        if not isinstance(value, dict):
            raise self.error(key, f"expected a table, got {describe(value)}")
        return value

    def keys(self, table: dict, allowed, key: str) -> None:
        for name in table:
            if name not in allowed:
                where = f"{key}.{name}" if key else name
                close = closest(name, allowed)
                hint = f" (did you mean '{close}'?)" if close else ""
                raise self.error(
                    where, f"unknown key{hint}; valid keys here: {', '.join(allowed)}",
                    value=name, choices=allowed,
                )

    def number(self, value, key: str, minimum: float | None = None, strict: bool = False,
               maximum: float | None = None) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(key, f"expected a number, got {describe(value)}")
        v = float(value)
        if not math.isfinite(v):
            raise self.error(key, f"expected a finite number, got {value}")
        if minimum is not None and (v < minimum or (strict and v == minimum)):
            relation = ">" if strict else ">="
            raise self.error(key, f"expected a number {relation} {minimum:g}, got {value}",
                             value=value)
        if maximum is not None and v > maximum:
            raise self.error(key, f"expected a number <= {maximum:g}, got {value}", value=value)
        return v

    def pair(self, value, key: str, low: float, high: float, what: str) -> tuple[float, float]:
        """Two numbers, each in [low, high]; ``what`` describes them in the message."""
        if not (isinstance(value, list) and len(value) == 2
                and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                        and low <= v <= high for v in value)):
            raise self.error(key, f"expected two numbers {what}, got {value!r}", value=value)
        return float(value[0]), float(value[1])

    def integer(self, value, key: str, low: int, high: int | None = None) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(key, f"expected an integer, got {describe(value)}")
        if value < low or (high is not None and value > high):
            span = f"in {low}..{high}" if high is not None else f">= {low}"
            raise self.error(key, f"expected an integer {span}, got {value}")
        return value

    def boolean(self, value, key: str) -> bool:
        if not isinstance(value, bool):
            raise self.error(key, f"expected true or false, got {describe(value)}")
        return value

    def choice(self, value, key: str, options) -> str:
        if not isinstance(value, str):
            raise self.error(key, f"expected one of {', '.join(map(repr, options))}, got {describe(value)}")
        if value not in options:
            close = closest(value, options)
            hint = f" (did you mean '{close}'?)" if close else ""
            raise self.error(key, f"unknown value {value!r}{hint}; expected one of "
                             f"{', '.join(map(repr, options))}", value=value, choices=options)
        return value

    def text(self, value, key: str) -> str:
        if not isinstance(value, str):
            raise self.error(key, f"expected a string, got {describe(value)}")
        return value

    def array(self, value, key: str, depth: int) -> np.ndarray:
        """A nested list of numbers of the given depth (1: vector, 2: matrix) as floats."""
        def walk(v, level: int, where: str):
            if level == 0:
                return self.number(v, where)
            if not isinstance(v, list):
                raise self.error(where, f"expected an array, got {describe(v)}")
            return [walk(x, level - 1, f"{where}[{i}]") for i, x in enumerate(v)]

        rows = walk(value, depth, key)
        if depth == 2 and len({len(r) for r in rows}) > 1:
            raise self.error(key, "rows have different lengths")
        return np.array(rows, dtype=float)


def describe(value) -> str:
    if isinstance(value, bool):
        return f"{str(value).lower()} (boolean)"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "an array"
    return f"{value!r} ({type(value).__name__})"
