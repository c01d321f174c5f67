"""Users' pen recordings for learning motor primitives: CSV ``t,x,y[,pressure]``.

One file is one recorded sample (a character, a word, a scribble), as a digitising tablet
exports it: a header row naming the columns ``t`` [s], ``x``, ``y`` [mm] and optionally
``pressure`` (in [0, 1]; 0 = pen in the air), in any order, then one row per sample with times
strictly increasing. A folder is read as every ``*.csv`` in it, sorted by name. Every problem
is an :class:`~inkarm.errors.InputError` naming the file, the line and the column.

Rows are bounded while read (``INKARM_MAX_STEPS``, :mod:`inkarm.core.budget`), lines at
:data:`~inkarm.core.trajectory.CSV_MAX_LINE` characters, coordinates at
:data:`~inkarm.core.trajectory.MAX_COORD_MM`.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inkarm.core.budget import STEPS, require
from inkarm.core.trajectory import CSV_MAX_LINE, MAX_COORD_MM, MAX_TIME_S
from inkarm.errors import InputError

REQUIRED = ("t", "x", "y")
OPTIONAL = ("pressure",)


@dataclass(frozen=True, eq=False)
class PenRecording:
    """One recording: times [s], positions (N, 2) [mm], pressure (N,) in [0, 1] or None."""

    file: Path
    t: np.ndarray
    pos: np.ndarray
    pressure: np.ndarray | None


def _lines(f, path: Path):
    number = 0
    while True:
        line = f.readline(CSV_MAX_LINE + 1)
        if not line:
            return
        number += 1
        if len(line) > CSV_MAX_LINE and not line.endswith("\n"):
            raise InputError(f"line {number}: longer than {CSV_MAX_LINE} characters",
                             file=str(path))
        yield line


def read_pen_csv(path: str | Path) -> PenRecording:
    """Read one recording (module docstring)."""
    path = Path(path)
    if not path.is_file():
        raise InputError("no such file", file=str(path))
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            return _read(f, path)
    except UnicodeDecodeError:
        raise InputError("not a UTF-8 text file; expected CSV t,x,y[,pressure]",
                         file=str(path)) from None


def _read(f, path: Path) -> PenRecording:
    reader = csv.reader(_lines(f, path))
    header = next(reader, None)
    if header is None:
        raise InputError("empty file; expected a header row t,x,y[,pressure]", file=str(path))
    names = [h.strip().lower() for h in header]
    for name in REQUIRED:
        if name not in names:
            raise InputError(f"line 1: no column {name!r}; expected a header row "
                             f"t,x,y[,pressure], got {','.join(header)}", file=str(path),
                             key=name)
    unknown = [n for n in names if n not in REQUIRED + OPTIONAL]
    if unknown or len(set(names)) != len(names):
        what = f"unknown column {unknown[0]!r}" if unknown else "a column is repeated"
        raise InputError(f"line 1: {what}; expected t,x,y[,pressure]", file=str(path),
                         key=unknown[0] if unknown else None)
    bounds = [(0.0, 1.0) if n == "pressure" else (-MAX_TIME_S, MAX_TIME_S) if n == "t"
              else (-MAX_COORD_MM, MAX_COORD_MM) for n in names]
    rows: list[list[float]] = []
    linenos: list[int] = []
    limit = STEPS.value
    for number, row in enumerate(reader, start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(names):
            raise InputError(f"line {number}: {len(row)} values, expected {len(names)} "
                             f"({','.join(names)})", file=str(path))
        values = []
        for name, (low, bound), cell in zip(names, bounds, row):
            try:
                value = float(cell)
            except ValueError:
                raise InputError(f"line {number}, column {name}: not a number: {cell!r}",
                                 file=str(path), key=name, value=cell) from None
            if not (math.isfinite(value) and low <= value <= bound):
                raise InputError(f"line {number}, column {name}: {value!r} is outside "
                                 f"[{low:g}, {bound:g}]", file=str(path), key=name, value=value)
            values.append(value)
        rows.append(values)
        linenos.append(number)
        if len(rows) > limit:
            require(len(rows), STEPS, "rows of a pen recording", file=str(path))
    if not rows:
        raise InputError("no samples after the header", file=str(path))
    data = np.array(rows)
    t = data[:, names.index("t")]
    steps = np.diff(t)
    if np.any(steps <= 0):
        bad = int(np.argmax(steps <= 0))
        raise InputError(f"line {linenos[bad + 1]}, column t: {float(t[bad + 1])!r} does not come "
                         f"after {float(t[bad])!r}; times must increase", file=str(path))
    pos = data[:, [names.index("x"), names.index("y")]]
    pressure = data[:, names.index("pressure")] if "pressure" in names else None
    return PenRecording(path, t, pos, pressure)


def read_pen_recordings(path: str | Path) -> list[PenRecording]:
    """One CSV file, or every ``*.csv`` of a folder (sorted); at least one."""
    path = Path(path)
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.suffix.lower() == ".csv" and p.is_file())
        if not files:
            raise InputError("no *.csv files in this folder", file=str(path))
        return [read_pen_csv(p) for p in files]
    return [read_pen_csv(path)]
