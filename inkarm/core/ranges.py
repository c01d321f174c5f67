"""Plausible ranges of physical inputs, checked where the input enters.

A range is generous (a user of the model would never need more) but finite, so that no
arithmetic downstream can overflow or divide by zero on a value that passed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from inkarm.errors import InputError


@dataclass(frozen=True)
class Range:
    """Values in [low, high] (``open_low``: (low, high]), in ``unit``."""

    low: float
    high: float
    unit: str = ""
    open_low: bool = False

    def __str__(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        return f"{'(' if self.open_low else '['}{self.low:g}, {self.high:g}]{unit}"

    def contains(self, value: float) -> bool:
        above = value > self.low if self.open_low else value >= self.low
        return math.isfinite(value) and above and value <= self.high


def check_ranges(obj, ranges: dict[str, Range]) -> None:
    """Raise InputError (key = field name) for the first field of ``obj`` outside its range;
    a field may hold a number, a tuple of numbers or None (not checked)."""
    for name, bounds in ranges.items():
        value = getattr(obj, name)
        if value is None:
            continue
        for v in (value if isinstance(value, tuple | list) else (value,)):
            if isinstance(v, bool) or not bounds.contains(float(v)):
                what = "numbers" if isinstance(value, tuple | list) else "a number"
                raise InputError(f"expected {what} in {bounds}, got {v}", key=name, value=value)


def outside(values, low: float, high: float) -> float | None:
    """The first of ``values`` outside [low, high] (NaN counts as outside), else None."""
    arr = np.asarray(values, dtype=float).ravel()
    bad = ~((arr >= low) & (arr <= high))
    return float(arr[np.argmax(bad)]) if bad.any() else None


def expected_in(low: float, high: float, unit: str, what: str = "numbers") -> str:
    """``expected numbers in [1e-06, 1e+06] mm`` (the start of a range message)."""
    return f"expected {what} in [{low:g}, {high:g}]{' ' + unit if unit else ''}"
