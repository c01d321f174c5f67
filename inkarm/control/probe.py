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

The probe is part of the drawing's own plan (:func:`with_probes`: its dots are the first
strokes), so that a batch of plants, which shares one plan, probes as one plant does; the log of
the drawing starts where the pen leaves the last dot (:func:`without_probes`).
"""

from __future__ import annotations

import numpy as np

from inkarm.core.log import DrawLog
from inkarm.core.trajectory import Drawing, Trajectory

DWELL_S = 0.05  # how long each probe holds the pen at its point once the force has settled [s]


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


def probe_drawing(drawing: Drawing) -> Drawing:
    """A drawing of dots at :func:`probe_points`, each held :data:`DWELL_S`."""
    dots = [Trajectory(t=np.array([0.0, DWELL_S]), pos=np.array([p, p]))
            for p in probe_points(drawing)]
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


__all__ = ["DWELL_S", "first_drawing_row", "probe_drawing", "probe_note", "probe_points",
           "with_probes", "without_probes"]
