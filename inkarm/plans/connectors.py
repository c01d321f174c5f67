"""Connector shapes between two letters of a ligature (:mod:`inkarm.plans.ligatures`).

Where the straight connector from one letter to the next turns too sharply, the connector
gives way rather than the letters: it swings back over the next letter's bowl and loops into
its first target (a cursive retrace written as an eyelet, :func:`swing_connector`), or bends
(:func:`bends`).

Coordinates: page frame in [mm], as in :mod:`inkarm.plans.layout`; angles in [deg] unless
named in [rad].
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from inkarm.plans.targets import SAME_POINT

_SWING = 1.6
"""The longest connector that swings back along the next letter's outline, as a multiple of
the gap it bridges (pi / 2: half round a bowl, from one side to the other)."""


def swing_connector(
    p: np.ndarray, outline: np.ndarray, eyelet: float, max_turn: float
) -> np.ndarray | None:
    """Connector targets (k, 2) [mm] from ``p``, a point on the polyline ``outline`` (the next
    letter's first piece), back along the outline to its start S and into S through an
    eyelet: a half circle of diameter ``eyelet`` outside the outline, so the pen arrives at S
    heading where the letter goes on. The connector runs outside the outline, its offset
    growing from 0 at ``p`` to ``eyelet`` at S. None when ``p`` is at S or the way back is
    longer than :data:`_SWING` times the gap, or the eyelet would need more than 12 targets
    to turn by at most ``max_turn`` [deg] at each."""
    s = outline[0]
    a, ab = outline[:-1], np.diff(outline, axis=0)
    length2 = np.einsum("ij,ij->i", ab, ab)
    u = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(length2, 1e-300), 0.0, 1.0)
    k = int(np.argmin(np.linalg.norm(a + u[:, None] * ab - p, axis=1)))
    index = np.arange(k if u[k] > 0 else k - 1, 0, -1)  # outline vertices between p and S
    index = index[np.linalg.norm(outline[index] - p, axis=1) > SAME_POINT]
    path = np.vstack([p, outline[index], s])
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    gap = float(np.linalg.norm(s - p))
    if gap <= SAME_POINT or steps.sum() > _SWING * gap:
        return None
    n_loop = max(3, int(np.ceil(180.0 / (0.9 * max_turn)))) if max_turn > 0 else 99
    if n_loop > 12:
        return None
    edges = ab / np.maximum(np.sqrt(length2), 1e-300)[:, None]  # the outline's way, from S
    normals = _outward_side(outline) * np.column_stack([edges[:, 1], -edges[:, 0]])
    at_vertex = np.vstack([normals[:1], normals[:-1] + normals[1:], normals[-1:]])
    at_vertex /= np.maximum(np.linalg.norm(at_vertex, axis=1, keepdims=True), 1e-300)
    along = np.cumsum(steps)  # from p to each vertex of the way back, and to S
    lifted = outline[index] + (eyelet * along[:-1] / along[-1])[:, None] * at_vertex[index]
    v, n = edges[0], normals[0]
    phi = np.pi * np.arange(n_loop) / n_loop  # from S + eyelet n round to (not including) S
    loop = s + 0.5 * eyelet * ((1.0 + np.cos(phi))[:, None] * n - np.sin(phi)[:, None] * v)
    return np.vstack([lifted, loop])


def _outward_side(outline: np.ndarray) -> float:
    """+1 if the polyline's outside is to the right of its direction (it turns left, as a
    bowl written anticlockwise), -1 if to the left: from its signed turning over its first
    half turn."""
    d = np.diff(outline, axis=0)
    total = 0.0
    for a, b in pairwise(d):
        total += float(np.arctan2(a[0] * b[1] - a[1] * b[0], a @ b))
        if abs(total) >= np.pi / 2:
            break
    return 1.0 if total >= 0 else -1.0


def bends(
    before: np.ndarray | None,
    p: np.ndarray,
    s: np.ndarray,
    after: np.ndarray | None,
    eyelet: float,
    max_turn: float,
):
    """Candidate connectors from ``p`` to ``s`` [mm] (lists of (point, belongs to the first
    letter)): a target after ``p`` turning the pen from its way into ``p`` (from ``before``)
    towards ``s``, and/or one before ``s`` from which it reaches ``s`` heading within 0.8 x
    ``max_turn`` of where it goes next (to ``after``), each ``eyelet`` or a third of the gap
    away from its end."""
    chord = s - p
    gap = float(np.linalg.norm(chord))
    if gap <= SAME_POINT:
        return
    step = np.radians(0.8 * max_turn)
    for length in (eyelet, gap / 3):
        bend = []
        if before is not None:
            heading = _rotate_towards(p - before, chord, step)
            if heading is not None:
                bend.append((p + length * heading, True))
        if after is not None:
            heading = _rotate_towards(after - s, chord, step)
            if heading is not None:
                bend.append((s - length * heading, False))
        if bend:
            yield bend


def _rotate_towards(d: np.ndarray, target: np.ndarray, step: float) -> np.ndarray | None:
    """The unit direction ``d`` turned towards ``target`` by ``step`` [rad]; None when the two
    are within ``step`` already (no bend needed at that end)."""
    angle = float(np.arctan2(d[0] * target[1] - d[1] * target[0], d @ target))
    if abs(angle) <= step:
        return None
    a = np.sign(angle) * step
    c, s = np.cos(a), np.sin(a)
    d = d / np.linalg.norm(d)
    return np.array([c * d[0] - s * d[1], s * d[0] + c * d[1]])


def distance_to_path(p: np.ndarray, polyline: np.ndarray) -> float:
    """Distance in [mm] from the point ``p`` to the polyline (k >= 2, 2)."""
    a, ab = polyline[:-1], np.diff(polyline, axis=0)
    length2 = np.einsum("ij,ij->i", ab, ab)
    u = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(length2, 1e-300), 0.0, 1.0)
    return float(np.min(np.linalg.norm(a + u[:, None] * ab - p, axis=1)))
