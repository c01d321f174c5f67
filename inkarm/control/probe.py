"""Probing the paper before drawing (``LoopConfig.probe_paper``).

The force loop learns the sheet's plane while drawing (:mod:`inkarm.control.surface`), so the
first stroke is drawn on the model's belief: on a sheet 5 mm lower and tilted 2 deg, with the
rest of issue 9's imperfections, its force swings to 0.87..1.14 N before the plane is known.
Probing first touches the paper at three points and settles the force there; each settled
period is a sample of the plane, so the drawing starts with it known.

The points lie on the drawing's own path (where the pen lays ink anyway, so a probe leaves no
mark of its own): the path's first point p1, the point farthest from it p2, and the point
farthest from the line p1 p2 p3 (the largest triangle of the three), so the plane's two slopes
are both seen unless the drawing is a straight line (then the surface's ridge prior keeps the
unseen slope at zero).

For a height map (``calibrate paper``; :class:`inkarm.control.heightmap.MapPrior` then feeds it
forward) the sheet is probed more densely, in one of two :data:`PATTERNS`:

- ``"path"``: along the drawing's own path, a dot every ``spacing_mm`` of arc length in each
  stroke (its first point, then every ``spacing_mm``, and its last point), leaving out a dot
  closer than ``spacing_mm / 2`` to one already chosen (where strokes cross or come back);
  where the pen draws, the map is measured, and nowhere else;
- ``"grid"``: a grid over the drawing's bounding box, its corners included, at most
  ``spacing_mm`` apart along x and y (``ceil(width / spacing) + 1`` columns, evenly spaced),
  visited row by row in alternating directions (a serpentine, the shortest travel).

The probe is part of the drawing's own plan (:func:`with_probes`: its dots are the first
strokes), so that a batch of plants, which shares one plan, probes as one plant does; the log of
the drawing starts where the pen leaves the last dot (:func:`without_probes`).
"""

from __future__ import annotations

import math

import numpy as np

from inkarm.core.log import DrawLog
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError, closest

DWELL_S = 0.05  # how long each probe holds the pen at its point once the force has settled [s]
PATTERNS = ("path", "grid")  # the dense patterns of probe_drawing(spacing_mm=...)
MAX_PROBES = 10000  # more dots than this is a mistake in the spacing, not a calibration


def probe_points(drawing: Drawing) -> np.ndarray:
    """The (k, 2) page points [mm] to probe, k <= 3 (fewer when the path has fewer distinct
    points)."""
    path = np.vstack([s.pos[:, :2] for s in drawing.strokes])
    first = path[0]
    far = path[int(np.argmax(np.linalg.norm(path - first, axis=1)))]
    side = far - first
    # twice the triangle's area with each candidate: |side x (p - first)|
    area = np.abs(side[0] * (path[:, 1] - first[1]) - side[1] * (path[:, 0] - first[0]))
    third = path[int(np.argmax(area))]
    points = [first]
    for p in (far, third):
        if min(np.linalg.norm(p - q) for q in points) > 1e-6:
            points.append(p)
    return np.array(points)


def path_points(drawing: Drawing, spacing_mm: float) -> np.ndarray:
    """The (k, 2) page points [mm] along the drawing's path every ``spacing_mm`` of arc length
    (the ``"path"`` pattern of the module docstring), in drawing order."""
    spacing = _check_spacing(spacing_mm)
    chosen: list[np.ndarray] = []
    for stroke in drawing.strokes:
        xy = np.asarray(stroke.pos[:, :2], dtype=float)
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))])
        stops = np.append(np.arange(0.0, arc[-1], spacing), arc[-1])
        points = np.column_stack([np.interp(stops, arc, xy[:, 0]),
                                  np.interp(stops, arc, xy[:, 1])])
        for p in points:
            if not chosen or np.min(np.linalg.norm(np.asarray(chosen) - p, axis=1)) \
                    >= spacing / 2:
                chosen.append(p)
                _check_count(len(chosen), spacing_mm)
    return np.array(chosen).reshape(-1, 2)


def grid_points(drawing: Drawing, spacing_mm: float) -> np.ndarray:
    """The (k, 2) page points [mm] of a grid over the drawing's bounding box, at most
    ``spacing_mm`` apart, in a serpentine (the ``"grid"`` pattern of the module docstring)."""
    spacing = _check_spacing(spacing_mm)
    path = np.vstack([s.pos[:, :2] for s in drawing.strokes])
    (x0, y0), (x1, y1) = path.min(axis=0), path.max(axis=0)
    nx, ny = (math.ceil((hi - lo) / spacing - 1e-9) + 1 for lo, hi in ((x0, x1), (y0, y1)))
    _check_count(nx * ny, spacing_mm)
    xs, ys = np.linspace(x0, x1, nx), np.linspace(y0, y1, ny)
    rows = [np.column_stack([xs if j % 2 == 0 else xs[::-1], np.full(nx, y)])
            for j, y in enumerate(ys)]
    return np.vstack(rows)


def _check_spacing(spacing_mm: float) -> float:
    if isinstance(spacing_mm, bool) or not isinstance(spacing_mm, int | float | np.number) \
            or not math.isfinite(spacing_mm) or spacing_mm <= 0:
        raise InputError(f"expected a probe spacing > 0 mm, got {spacing_mm!r}",
                         key="spacing_mm", value=spacing_mm)
    return float(spacing_mm)


def _check_count(count: int, spacing_mm: float) -> None:
    if count > MAX_PROBES:
        raise InputError(f"more than {MAX_PROBES} probe points {spacing_mm:g} mm apart; "
                         "expected a larger spacing", key="spacing_mm", value=spacing_mm)


def probe_drawing(drawing: Drawing, spacing_mm: float | None = None,
                  pattern: str = "path") -> Drawing:
    """A drawing of dots, each held :data:`DWELL_S`: at :func:`probe_points` (the sheet's plane)
    without ``spacing_mm``; with it, ``spacing_mm`` [mm] apart along the drawing's path
    (``pattern="path"``, :func:`path_points`) or on a grid over its bounding box (``"grid"``,
    :func:`grid_points`). Raises InputError for a spacing that is not > 0 or gives more than
    :data:`MAX_PROBES` dots, and for an unknown pattern."""
    if pattern not in PATTERNS:
        hint = closest(pattern, PATTERNS)
        raise InputError(f"expected one of {', '.join(PATTERNS)}, got {pattern!r}"
                         + (f" (did you mean {hint!r}?)" if hint else ""),
                         key="pattern", value=pattern, choices=PATTERNS)
    if spacing_mm is None:
        points = probe_points(drawing)
    else:
        points = (path_points if pattern == "path" else grid_points)(drawing, spacing_mm)
    dots = [Trajectory(t=np.array([0.0, DWELL_S]), pos=np.array([p, p])) for p in points]
    return Drawing(dots, page_size=drawing.page_size)


def with_probes(drawing: Drawing) -> tuple[Drawing, int]:
    """``drawing`` with the dots of :func:`probe_drawing` first, and how many strokes they
    are."""
    dots = probe_drawing(drawing).strokes
    return Drawing([*dots, *drawing.strokes], page_size=drawing.page_size), len(dots)


def first_drawing_row(stroke: np.ndarray, probes: int) -> int:
    """The first row of a plan (or log) with strokes ``stroke`` past its ``probes`` dots: the
    travel to the drawing's first stroke (0 without probes)."""
    return int(np.argmax(stroke >= probes)) if probes else 0


def probe_note(probes: int, plane: str) -> str:
    """The run's note on what its probe found (``plane``: the surface estimate in words)."""
    return f"probed the paper at {probes} points of the path: {plane}"


def without_probes(log: DrawLog, probes: int) -> DrawLog:
    """The drawing's part of the ``log`` of a drawing :func:`with_probes`: from the first row
    past the ``probes`` dots (the travel to the first stroke) on, its strokes numbered from 0
    again; the whole ``log`` when the run never got past the dots (it failed probing)."""
    if not probes or not (log.stroke >= probes).any():
        return log
    part = log.rows(first_drawing_row(log.stroke, probes), len(log))
    part.stroke = np.where(part.stroke >= probes, part.stroke - probes, part.stroke)
    return part


__all__ = ["DWELL_S", "MAX_PROBES", "PATTERNS", "first_drawing_row", "grid_points", "path_points",
           "probe_drawing", "probe_note", "probe_points", "with_probes", "without_probes"]
