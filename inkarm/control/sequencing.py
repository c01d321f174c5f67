"""The pen phases in the page frame: approach, descend, draw, lift, travel (and home).

For each stroke the pen descends from ``hover_mm`` above its first point to the nominal
compression depth F*/k below the paper, tracks the stroke, lifts back to hover height and
travels (minimum jerk) to above the next stroke. The result is one page point per control
period; arms turn it into joint references (:mod:`inkarm.control.reference`), a plotter
follows it directly. Page [mm] and [s] throughout.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.control.config import LoopConfig
from inkarm.core.log import DESCEND, DRAW, LIFT, TRAVEL
from inkarm.core.spline import cubic_spline, hermite_spline
from inkarm.core.trajectory import Drawing
from inkarm.errors import InputError
from inkarm.models.minjerk import PEAK_SPEED_RATIO, minimum_jerk_profile


@dataclass(frozen=True, eq=False)
class PenPath:
    """The pen's planned path on the control grid.

    Attributes:
        page_mm: Pen tip (x, y, z) in page [mm], (K, 3); z < 0 while pressing.
        phase: Index into :data:`inkarm.core.log.PHASES`, (K,).
        stroke: Stroke index of each row (during travel: the stroke travelled to), (K,).
        settle: Rows after which the force must settle before drawing (ends of descents).
    """

    page_mm: np.ndarray
    phase: np.ndarray
    stroke: np.ndarray
    settle: frozenset[int]

    def __len__(self) -> int:
        return self.page_mm.shape[0]


def minimum_jerk(n: int) -> np.ndarray:
    """The minimum-jerk profile s(tau) on n samples of tau in [0, 1] (seed 002, eq. 3.1)."""
    return minimum_jerk_profile(np.linspace(0.0, 1.0, max(n, 2)))


def ticks(duration: float, dt: float) -> int:
    """Control periods of a move of ``duration`` [s], both ends included (at least 2)."""
    return max(2, int(np.ceil(duration / dt)) + 1)


def pen_depth_mm(config: LoopConfig, stiffness_n_per_mm: float, travel_mm: float,
                 preload_n: float = 0.0, paper_stiffness_n_per_mm: float = 0.0) -> float:
    """How far below the paper the pen reference goes [mm] to press with F*: the pen's
    compression (F* - P) / k beyond its preload P, plus the underlay's sink F* / k_paper
    (0 for a rigid table).

    k is ``config.pen_stiffness_n_per_mm``, else ``stiffness_n_per_mm`` (the controller's model);
    the compression must leave 20% of the pen's ``travel_mm``."""
    stiffness = (stiffness_n_per_mm if config.pen_stiffness_n_per_mm is None
                 else config.pen_stiffness_n_per_mm)
    if not stiffness > 0:
        raise InputError(f"expected > 0, got {stiffness}", key="pen_stiffness_n_per_mm",
                         value=stiffness)
    depth = max(config.force_n - preload_n, 0.0) / stiffness
    if depth > 0.8 * travel_mm:
        raise InputError(f"{config.force_n} N compresses the pen by {depth:.1f} mm, more than "
                         f"80% of its {travel_mm:.1f} mm travel", key="force_n",
                         value=config.force_n)
    sink = config.force_n / paper_stiffness_n_per_mm if paper_stiffness_n_per_mm > 0 else 0.0
    return depth + sink


def stroke_points(drawing: Drawing, k: int, dt: float) -> np.ndarray:
    """Stroke k resampled on the control grid, (N, 3) page [mm] with z height (0 if 2-D).

    A cubic spline through the samples (Hermite with the stroke's velocities when it has
    them): the arm draws smooth curves, and a piecewise-linear reference would differ from
    them by the chord sagitta, (v T)^2 / (8 R) for samples T apart on a curve of radius R.
    """
    s = drawing.strokes[k]
    if s.dim == 1:
        raise InputError(f"drawing stroke {k}: 1-D positions cannot be drawn on a page")
    # Whole periods covering the stroke, the last one clamped onto its end point.
    n = max(1, int(np.ceil(s.duration / dt - 1e-9)) + 1)
    t = np.minimum(s.t[0] + dt * np.arange(n), s.t[-1])
    pts = np.zeros((n, 3))
    if s.n >= 4 and s.vel is not None:
        pts[:, : s.dim] = hermite_spline(s.t, s.pos, s.vel)(t)
    elif s.n >= 4:
        pts[:, : s.dim] = cubic_spline(s.t, s.pos)(t)
    else:
        for c in range(s.dim):
            pts[:, c] = np.interp(t, s.t, s.pos[:, c])
    return pts


def sequence_pen(drawing: Drawing, config: LoopConfig, depth_mm: float, dt: float) -> PenPath:
    """The pen phases of ``drawing`` on the control grid of period ``dt`` [s]: descend to
    ``depth_mm`` below the paper, draw, lift to ``config.hover_mm``, travel to the next."""
    if not drawing.strokes:
        raise InputError("drawing: no strokes to draw")
    hover = config.hover_mm
    segments: list[tuple[int, int, np.ndarray]] = []  # (phase, stroke, page points (N, 3))
    previous = None
    for k in range(len(drawing.strokes)):
        pts = stroke_points(drawing, k, dt)
        pts[:, 2] -= depth_mm
        start, end = pts[0], pts[-1]
        above = np.array([start[0], start[1], hover])
        if previous is not None:
            distance = float(np.linalg.norm(above[:2] - previous[:2]))
            # Minimum jerk peaks at 1.875 A / t_f (seed 002, eq. 3.1).
            n = ticks(PEAK_SPEED_RATIO * distance / config.travel_speed_mm_s, dt)
            segments.append((TRAVEL, k, previous + minimum_jerk(n)[:, None] * (above - previous)))
        n = ticks(config.descend_s, dt)
        segments.append((DESCEND, k, above + minimum_jerk(n)[:, None] * (start - above)))
        segments.append((DRAW, k, pts))
        lifted = np.array([end[0], end[1], hover])
        n = ticks(config.lift_s, dt)
        segments.append((LIFT, k, end + minimum_jerk(n)[:, None] * (lifted - end)))
        previous = lifted

    settle, row = set(), 0
    for ph, _, pts in segments:
        row += len(pts)
        if ph == DESCEND:
            settle.add(row - 1)
    return PenPath(
        page_mm=np.vstack([seg[2] for seg in segments]),
        phase=np.concatenate([np.full(len(seg[2]), seg[0], dtype=np.int8) for seg in segments]),
        stroke=np.concatenate([np.full(len(seg[2]), seg[1], dtype=np.int32)
                               for seg in segments]),
        settle=frozenset(settle),
    )
