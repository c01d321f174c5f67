"""Glyph strokes to target sequences: the vertices of each stroke, thinned and subdivided.

A glyph stroke is a sparse polyline already, so its vertices are the target loci (seed 000
sec. 4: targets near curvature extrema), optionally thinned by turning angle
(:func:`thin_polyline`) and with long edges subdivided (:func:`subdivide`), one
:class:`TargetSequence` per stroke (:func:`glyph_targets`); :mod:`inkarm.plans.ligatures`
joins them.

Coordinates: page frame in [mm], as in :mod:`inkarm.plans.layout`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from inkarm.plans.layout import PlacedGlyph

SAME_POINT = 1e-6  # [mm]: endpoints closer than this are one point


def thin_polyline(points: np.ndarray, min_turn: float) -> np.ndarray:
    """Keep the end points and every vertex where the path has turned by >= ``min_turn`` [deg]
    since the last kept vertex; consecutive duplicates are dropped.

    The heading change is measured from the chord (last kept vertex -> vertex) to the next
    edge, so a gentle arc keeps one target every ``min_turn`` degrees of turning.
    """
    return _thin(_dedupe(np.asarray(points, dtype=float)), min_turn)


def _thin(pts: np.ndarray, min_turn: float) -> np.ndarray:
    """:func:`thin_polyline` of a polyline without consecutive duplicates."""
    if min_turn <= 0 or len(pts) <= 2:
        return pts
    xy = pts.tolist()  # Python floats: the same IEEE operations, without array overhead
    kept = [0]
    kx, ky = xy[0]
    for i in range(1, len(xy) - 1):
        (x, y), (nx, ny) = xy[i], xy[i + 1]
        cx, cy = x - kx, y - ky  # the chord from the last kept vertex
        ex, ey = nx - x, ny - y  # the next edge
        if math.degrees(abs(math.atan2(cx * ey - cy * ex, cx * ex + cy * ey))) >= min_turn:
            kept.append(i)
            kx, ky = x, y
    kept.append(len(xy) - 1)
    return pts[kept]


def subdivide(points: np.ndarray, max_spacing: float | None) -> np.ndarray:
    """Insert evenly spaced vertices so no edge is longer than ``max_spacing`` [mm].

    Under local isochrony every target gets the same time, so a long edge would be crossed
    at a dash and overshoot its end; extra targets on it keep the speed even.
    """
    if max_spacing is None or len(points) < 2:
        return points
    return _subdivide_all([points], max_spacing)[0]


def _subdivide_all(polylines: list[np.ndarray], max_spacing: float | None) -> list[np.ndarray]:
    """:func:`subdivide` of every polyline (n_j, 2), in a few array operations for all: the
    first vertex, then for each edge from a to b of length l, k = max(1, ceil(l /
    max_spacing)) vertices a + (j / k) (b - a), j = 1 .. k."""
    if max_spacing is None:
        return polylines
    n = np.array([len(p) for p in polylines], dtype=np.int64)
    if not len(n) or not n.sum():
        return polylines
    points = np.vstack(polylines)
    starts = (np.cumsum(n) - n)[n > 0]  # each polyline's first vertex
    # vertex i brings the edge into it, from i - 1 (a first vertex brings itself)
    step = np.zeros_like(points)
    step[1:] = np.diff(points, axis=0)
    step[starts] = 0.0
    k = np.maximum(1, np.ceil(np.linalg.norm(step, axis=1) / max_spacing)).astype(np.int64)
    k[starts] = 1
    src = np.arange(len(points)) - 1
    src[starts] += 1
    block = np.repeat(np.arange(len(points)), k)
    j = np.arange(len(block)) - np.repeat(np.cumsum(k) - k, k) + 1
    out = points[src[block]] + (j / k[block])[:, None] * step[block]
    at = np.cumsum(k) - k  # where each vertex's block starts
    out[at[starts]] = points[starts]  # first vertices exactly as they are
    total = np.concatenate([[0], np.cumsum(k)])
    ends = np.cumsum(n)
    return [
        p if len(p) < 2 else out[total[e - len(p)]:total[e]]
        for p, e in zip(polylines, ends.tolist())
    ]


def _dedupe(points: np.ndarray) -> np.ndarray:
    keep = np.ones(len(points), bool)
    keep[1:] = np.linalg.norm(np.diff(points, axis=0), axis=1) > SAME_POINT
    return points[keep]


def _dedupe_all(polylines: list[np.ndarray]) -> list[np.ndarray]:
    """:func:`_dedupe` of every polyline (n_j, 2), in a few array operations for all."""
    n = np.array([len(p) for p in polylines], dtype=np.int64)
    if not len(n) or not n.sum():
        return [p[:0] for p in polylines]
    points = np.vstack(polylines)
    keep = np.ones(len(points), bool)
    keep[1:] = np.linalg.norm(np.diff(points, axis=0), axis=1) > SAME_POINT
    keep[(np.cumsum(n) - n)[n > 0]] = True  # each polyline's first point
    total = np.concatenate([[0], np.cumsum(keep)])  # points kept before each point
    kept = total[np.cumsum(n)] - total[np.cumsum(n) - n]  # per polyline
    return [p.copy() for p in np.split(points[keep], np.cumsum(kept)[:-1])]


@dataclass
class TargetSequence:
    """Target means along one pen-down path, with where each target came from.

    Attributes:
        means: (m, 2) target means in [mm].
        letters: (m,) index in the text of the letter each target came from.
        connectors: (m,) True where the path *into* the target is not part of the letter's
            font outline (a bridged pen-up gap, or a junction target was dropped).
        joinable: False for a delayed mark (an i dot), which is never joined to another path.
    """

    means: np.ndarray
    letters: np.ndarray
    connectors: np.ndarray
    joinable: bool = True

    def __len__(self) -> int:
        return len(self.means)


def glyph_targets(
    placed: list[PlacedGlyph],
    thin_angle: float,
    max_spacing: float | None = None,
    mark_size: float = 0.0,
) -> list[TargetSequence]:
    """One target sequence per glyph stroke, in writing order: the stroke's vertices thinned
    by ``thin_angle`` [deg], then long edges subdivided to at most ``max_spacing`` [mm].

    Strokes no larger than ``mark_size`` [mm] (i and j dots) are delayed to the end of their
    word, as a writer dots the i's after the word, and are not joined by ligatures.
    """
    out: list[TargetSequence] = []
    marks: list[TargetSequence] = []
    deduped = _dedupe_all([np.asarray(s, dtype=float) for pg in placed for s in pg.strokes])
    targets = iter(_subdivide_all([_thin(p, thin_angle) for p in deduped], max_spacing))
    for k, pg in enumerate(placed):
        for _ in pg.strokes:
            pts = next(targets)
            is_mark = float(np.max(np.ptp(pts, axis=0))) <= mark_size
            seq = TargetSequence(
                pts, np.full(len(pts), pg.index), np.zeros(len(pts), bool), not is_mark
            )
            (marks if is_mark else out).append(seq)
        word_ends = k + 1 == len(placed) or placed[k + 1].index != pg.index + 1
        if word_ends:
            out += marks
            marks = []
    return out
