"""G-code for a GRBL pen plotter from a :class:`inkarm.core.trajectory.Drawing`.

Three steps, each a small function:

1. **Travel order** (:func:`order_strokes`): strokes whose ends meet (within ``merge_mm``) are
   joined (vpype's ``linemerge``), then ordered greedily: from the pen's position, the nearest
   stroke end next, reversing a stroke when its far end is nearer (vpype's ``linesort``), the
   ends found with a KD-tree (scipy's ``cKDTree``): O(n log n) per query on n strokes, which a
   writing job of thousands of strokes needs, without vpype's dependency stack.
   Optional: writing order and direction are part of a human-like drawing, so
   ``inkarm draw`` keeps them and ``inkarm gcode --optimise`` changes them.
2. **Resampling** (:func:`resample_stroke`): GRBL executes at most ``max_line_rate_hz``
   (about 400) lines a second, so a line shorter than ``v / rate`` caps the speed below v.
   Each stroke is resampled by arc length at ``h = max(v_max / rate, 0.05 mm)``, v_max the
   fastest feed asked for on it; a chord of length h on a curve of radius R departs from it by
   the sagitta h^2 / (8 R) (below 0.01 mm for h = 0.4 mm and R >= 2 mm).
3. **Lines** (:func:`drawing_to_gcode`): units, the profile's header, then per stroke ``G0`` to
   its start, the profile's pen-down lines and dwell, ``G1`` along it with the drawing's own
   speed (F only where it changes by more than 2%, clipped to the profile's pen-down range),
   pen-up lines and dwell; the footer.

The time estimate (:func:`inkarm.hardware.plotter.timing.estimate_seconds`) runs the lines on
the emulator's own planner.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from inkarm.core.trajectory import Drawing
from inkarm.errors import InputError
from inkarm.hardware.plotter.profiles import PenProfile

MIN_SEGMENT_MM = 0.05


@dataclass(frozen=True, eq=False)
class PlotterStroke:
    """A stroke as the plotter will draw it: points (K, 2) in page [mm] and the feed [mm/s]
    of the move into each point (K,; the first is unused)."""

    points: np.ndarray
    speed: np.ndarray


@dataclass(frozen=True, eq=False)
class GcodeJob:
    """G-code lines."""

    lines: list[str]

    def text(self) -> str:
        return "\n".join(self.lines) + "\n"


def plotter_strokes(drawing: Drawing, profile: PenProfile,
                    speed_mm_s: float | None = None) -> list[PlotterStroke]:
    """The drawing's strokes with a feed per point: the drawing's own speed (its timing), or
    ``speed_mm_s`` when given, clipped to the profile's pen-down range."""
    if drawing.dim != 2:
        raise InputError(f"drawing: a plotter draws 2-D (x, y) strokes, got {drawing.dim}-D")
    if not drawing.strokes:
        raise InputError("drawing: no strokes to plot")
    lo, hi = profile.min_draw_speed_mm_s, profile.max_draw_speed_mm_s
    out = []
    for s in drawing.strokes:
        pts = np.asarray(s.pos[:, :2], dtype=float)
        if speed_mm_s is not None:
            v = np.full(len(pts), float(speed_mm_s))
        elif s.n >= 2 and s.duration > 0:
            step = np.linalg.norm(np.diff(pts, axis=0), axis=1)
            dt = np.diff(s.t)
            v = np.concatenate(([0.0], np.divide(step, dt, out=np.zeros_like(step),
                                                 where=dt > 0)))
            v[0] = v[1] if len(v) > 1 else profile.draw_speed_mm_s
        else:
            v = np.full(len(pts), profile.draw_speed_mm_s)
        out.append(PlotterStroke(pts, np.clip(v, lo, hi)))
    return out


def order_strokes(strokes: list[PlotterStroke], start_mm=(0.0, 0.0),
                  merge_mm: float = 0.05, reverse: bool = True) -> list[PlotterStroke]:
    """Join strokes that continue one another, then visit them nearest-end first (see the
    module docstring)."""
    strokes = _merge(strokes, merge_mm)
    n = len(strokes)
    if n <= 1:
        return strokes
    ends = np.array([[s.points[0], s.points[-1]] for s in strokes]).reshape(2 * n, 2)
    tree = cKDTree(ends)
    left = np.ones(n, dtype=bool)
    here = np.asarray(start_mm, dtype=float)
    out = []
    for _ in range(n):
        k = 2
        while True:  # widen the query until an unvisited end turns up
            _, idx = tree.query(here, k=min(k, 2 * n))
            idx = np.atleast_1d(idx)
            found = [i for i in idx if left[i // 2] and (reverse or i % 2 == 0)]
            if found or k >= 2 * n:
                break
            k *= 4
        if not found:  # (only without reversal, when every start is taken)
            found = [2 * int(np.flatnonzero(left)[0])]
        i = found[0]
        s = strokes[i // 2]
        left[i // 2] = False
        if i % 2 == 1:
            s = PlotterStroke(s.points[::-1].copy(), np.concatenate(([s.speed[-1]],
                                                                     s.speed[:0:-1])))
        out.append(s)
        here = s.points[-1]
    # Greedy nearest-end is a heuristic: keep the given order where it travels less.
    start = np.asarray(start_mm, dtype=float)
    return out if _travel(out, start) <= _travel(strokes, start) else strokes


def _travel(strokes: list[PlotterStroke], start: np.ndarray) -> float:
    """Pen-up travel [mm] from ``start`` through ``strokes`` in their order."""
    here, total = start, 0.0
    for s in strokes:
        total += float(np.hypot(*(s.points[0] - here)))
        here = s.points[-1]
    return total


def _merge(strokes: list[PlotterStroke], merge_mm: float) -> list[PlotterStroke]:
    """Join each stroke to the one before when it starts where that one ends."""
    out: list[PlotterStroke] = []
    for s in strokes:
        if out and np.linalg.norm(out[-1].points[-1] - s.points[0]) <= merge_mm:
            last = out[-1]
            out[-1] = PlotterStroke(np.vstack([last.points, s.points[1:]]),
                                    np.concatenate([last.speed, s.speed[1:]]))
        else:
            out.append(s)
    return out


def resample_stroke(stroke: PlotterStroke, max_line_rate_hz: float) -> PlotterStroke:
    """The stroke by arc length at about ``h = max(max speed / rate, MIN_SEGMENT_MM)`` [mm]
    (the whole number of equal chords no shorter than h), each new
    point's speed interpolated along the arc (see the module docstring)."""
    pts = stroke.points
    step = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    arc = np.concatenate(([0.0], np.cumsum(step)))
    total = float(arc[-1])
    if total <= 0:
        return PlotterStroke(pts[:1].copy(), stroke.speed[:1].copy())
    h = max(float(stroke.speed.max()) / max_line_rate_hz, MIN_SEGMENT_MM)
    n = max(1, math.floor(total / h + 1e-9))  # spacing >= h: no line shorter than 1/rate
    s = np.linspace(0.0, total, n + 1)
    keep = np.concatenate(([True], step > 0))  # drop repeated points before interpolating
    arc_k, pts_k, v_k = arc[keep], pts[keep], stroke.speed[keep]
    new = np.column_stack([np.interp(s, arc_k, pts_k[:, c]) for c in range(2)])
    return PlotterStroke(new, np.interp(s, arc_k, v_k))


def drawing_to_gcode(drawing: Drawing, profile: PenProfile, *, optimise: bool = False,
                     speed_mm_s: float | None = None) -> GcodeJob:
    """The G-code job drawing ``drawing`` with pen ``profile`` (module docstring, step 3)."""
    strokes = plotter_strokes(drawing, profile, speed_mm_s)
    if optimise:
        strokes = order_strokes(strokes)
    strokes = [resample_stroke(s, profile.max_line_rate_hz) for s in strokes]
    lines = profile.start_lines()
    for s in strokes:
        lines += [f"G0 {profile.xy(*s.points[0])}", *profile.pen_lines(True)]
        feed = None
        for p, v in zip(s.points[1:], s.speed[1:], strict=True):
            line = f"G1 {profile.xy(*p)}"
            if feed is None or abs(v - feed) > 0.02 * feed:
                feed = float(v)
                line += f" {profile.feed(feed)}"
            lines.append(line)
        lines += profile.pen_lines(False)
    lines += list(profile.footer)
    return GcodeJob(lines)


def check_travel(drawing: Drawing, travel_mm: tuple[float, float],
                 key: str = "--travel") -> None:
    """Refuse a drawing with a point outside the machine's travel, page frame
    [0, ``travel_mm``] per axis [mm] (``$130``, ``$131``: the job's G-code is in page
    coordinates, the page's lower-left corner at the travel's): the first such point (x, y
    [mm], 1-based stroke and point), the travel and what to do. GRBL itself raises ALARM:2
    there with soft limits on (system.c ``system_check_travel_limits``), or drives the pen
    into the frame without."""
    travel = f"X 0 to {travel_mm[0]:g} mm ($130), Y 0 to {travel_mm[1]:g} mm ($131)"
    for s, stroke in enumerate(drawing.strokes):
        xy = np.asarray(stroke.pos, dtype=float)[:, :2]
        for axis, name in enumerate("XY"):
            limit = float(travel_mm[axis])
            out = np.flatnonzero((xy[:, axis] < -1e-6) | (xy[:, axis] > limit + 1e-6))
            if out.size:
                i = int(out[0])
                raise InputError(
                    f"stroke {s + 1} point {i + 1} at ({xy[i, 0]:.2f}, {xy[i, 1]:.2f}) mm lies "
                    f"outside the machine's travel in {name} (${130 + axis}, {name} max "
                    f"travel): {travel}, from the page origin; lay the drawing out on the "
                    f"page (--page-size a4 --fit-to-margins 10mm), or give the machine's "
                    f"travel with --travel X,Y",
                    key=key, value=(float(xy[i, 0]), float(xy[i, 1])))
