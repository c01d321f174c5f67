"""Acceleration-limited motion for the EBB: a polyline (machine [mm]) with a speed cap per
segment becomes timed samples, then ``SM`` moves in whole steps and milliseconds.

The planning follows the AxiDraw software's (evil-mad/axidraw ``motion.py``): a speed limit
and a constant acceleration (pen down and pen up have their own), corners taken at the speed
the cornering rule allows (GRBL's junction deviation, which the AxiDraw software also models:
``v^2 = a d sin(t/2) / (1 - sin(t/2))``, t the angle between the directions, d =
``cornering_mm``), a backward and a forward pass so that every vertex speed can be reached and
left within the acceleration, and a trapezoid (or triangle) on every segment. The profile is
then cut in time, at whole milliseconds (so a move's duration is exact and its speed the
profile's mean over it): moves of at most ``time_slice_ms`` (the AxiDraw software's 25 ms while the
speed changes), and along a drawn curve vertices closer than ``min_move_ms`` are joined into
one straight move unless the path turns more than :data:`SHARP_DEG` there (the EBB sustains
moves down to 3-4 ms; fewer, longer moves are its advice).

Whole steps and milliseconds (:class:`StepCursor`): each move goes to the *absolute* target
rounded to the nearest step (``steps1 = round(k (x + y))``, ``steps2 = round(k (x - y))``,
:mod:`.geometry`) and ends at the absolute time rounded to the millisecond, so the rounding of
one move is carried into the next: the steps of a path sum exactly to its end and the position
never drifts. A move whose rounding asks a motor for more than 25 kHz is lengthened by whole
milliseconds (the EBB refuses faster moves); the slip is kept in the later moves' times.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from inkarm.hardware.axidraw.ebb import MAX_STEP_RATE, MIN_STEP_RATE
from inkarm.hardware.axidraw.geometry import carriage_mm, motor_steps

SHARP_DEG = 20.0  # a vertex turning more than this is always a move boundary
RATE_MARGIN = 0.9998  # a move's fastest axis stays below 25 kHz by this factor (axidraw:
# max_step_rate 24.995 steps/ms)


@dataclass(frozen=True)
class Limits:
    """Speed [mm/s], acceleration [mm/s^2], junction deviation [mm], longest move and
    shortest joined move [s]."""

    speed_mm_s: float
    accel_mm_s2: float
    junction_mm: float
    slice_s: float = 0.025
    min_move_s: float = 0.02


def profile_limits(profile, pen_down: bool) -> Limits:
    """The limits of an :class:`~inkarm.hardware.axidraw.profiles.AxiDrawProfile`."""
    speed = profile.speed_pendown_mm_s if pen_down else profile.speed_penup_mm_s
    accel = profile.accel_pendown_mm_s2 if pen_down else profile.accel_penup_mm_s2
    return Limits(min(speed, profile.max_speed_mm_s()), accel, profile.cornering_mm,
                  profile.time_slice_ms / 1000.0, profile.min_move_ms / 1000.0)


@dataclass(frozen=True)
class Timed:
    """A planned path: sample times ``t`` (K,) [s] from its start, positions ``xy`` (K, 2)
    [mm]; ``vertex_sample`` (N,): for each vertex of the polyline, the first sample at or
    after which the carriage has passed it."""

    t: np.ndarray
    xy: np.ndarray
    vertex_sample: np.ndarray

    @property
    def duration_s(self) -> float:
        return float(self.t[-1])


@dataclass(frozen=True)
class Move:
    """One ``SM``: ``duration_ms``, ``steps1``, ``steps2``."""

    duration_ms: int
    steps1: int
    steps2: int


def junction_speed(u_in: np.ndarray, u_out: np.ndarray, lim: Limits) -> float:
    """The fastest speed [mm/s] through a corner from direction ``u_in`` to ``u_out``."""
    cos_theta = -float(np.dot(u_in, u_out))
    if cos_theta < -0.999999:  # straight on
        return math.inf
    if cos_theta > 0.999999:  # reversal
        return 0.0
    sin_half = math.sqrt(0.5 * (1.0 - cos_theta))
    return math.sqrt(lim.accel_mm_s2 * lim.junction_mm * sin_half / (1.0 - sin_half))


def vertex_speeds(lengths: np.ndarray, dirs: np.ndarray, caps: np.ndarray,
                  lim: Limits) -> np.ndarray:
    """The speed [mm/s] at each of the N + 1 vertices: 0 at both ends, within the caps of the
    segments it joins and the corner's limit, reachable and leavable at ``accel``."""
    n = len(lengths)
    v = np.zeros(n + 1)
    for j in range(1, n):
        v[j] = min(caps[j - 1], caps[j], junction_speed(dirs[j - 1], dirs[j], lim))
    a = lim.accel_mm_s2
    for j in range(n - 1, -1, -1):  # backward: able to slow down to the next vertex
        v[j] = min(v[j], math.sqrt(v[j + 1] ** 2 + 2.0 * a * lengths[j]))
    for j in range(n):  # forward: able to speed up from the previous vertex
        v[j + 1] = min(v[j + 1], math.sqrt(v[j] ** 2 + 2.0 * a * lengths[j]))
    return v


def segment_profile(length: float, v0: float, v1: float, cap: float,
                    a: float) -> tuple[float, float, float, float]:
    """A trapezoid (or triangle) over ``length`` [mm] from ``v0`` to ``v1`` [mm/s], at most
    ``cap``, at acceleration ``a``: (end of speeding up, start of slowing down, end [s],
    top speed [mm/s])."""
    d_up = (cap * cap - v0 * v0) / (2.0 * a)
    d_down = (cap * cap - v1 * v1) / (2.0 * a)
    if d_up + d_down <= length:
        t1 = (cap - v0) / a
        t2 = t1 + (length - d_up - d_down) / cap
        return t1, t2, t2 + (cap - v1) / a, cap
    top = max(math.sqrt(max((2.0 * a * length + v0 * v0 + v1 * v1) / 2.0, 0.0)), v0, v1)
    t1 = (top - v0) / a
    return t1, t1, t1 + (top - v1) / a, top


def distance_at(t: float, length: float, v0: float, a: float,
                prof: tuple[float, float, float, float]) -> float:
    """Distance [mm] covered ``t`` [s] into a segment of profile ``prof``."""
    t1, t2, end, top = prof
    t = min(max(t, 0.0), end)
    if t <= t1:
        s = v0 * t + 0.5 * a * t * t
    elif t <= t2:
        s = v0 * t1 + 0.5 * a * t1 * t1 + top * (t - t1)
    else:
        s1 = v0 * t1 + 0.5 * a * t1 * t1 + top * (t2 - t1)
        s = s1 + top * (t - t2) - 0.5 * a * (t - t2) ** 2
    return min(max(s, 0.0), length)


def plan_path(points, caps, lim: Limits) -> Timed:
    """Time the polyline ``points`` (N + 1, 2) [mm] from rest to rest, segment j at most
    ``caps[j]`` [mm/s] (and the limit's speed); see the module docstring."""
    pts = np.asarray(points, dtype=float)[:, :2]
    caps = np.minimum(np.asarray(caps, dtype=float), lim.speed_mm_s)
    d = np.diff(pts, axis=0)
    lengths = np.hypot(d[:, 0], d[:, 1])
    keep = lengths > 1e-9
    if not keep.any():
        return Timed(np.zeros(1), pts[:1].copy(), np.zeros(len(pts), dtype=int))
    index = np.concatenate(([0], np.flatnonzero(keep) + 1))  # vertices kept
    vertex_of = np.maximum(np.searchsorted(index, np.arange(len(pts)), side="right") - 1, 0)
    pts, lengths, caps = pts[index], lengths[keep], caps[keep]
    dirs = np.diff(pts, axis=0) / lengths[:, None]
    speeds = vertex_speeds(lengths, dirs, caps, lim)
    a = lim.accel_mm_s2
    profs = [segment_profile(lengths[j], speeds[j], speeds[j + 1], caps[j], a)
             for j in range(len(lengths))]
    vertex_t = np.concatenate(([0.0], np.cumsum([p[2] for p in profs])))

    def position(t: float) -> np.ndarray:
        j = min(int(np.searchsorted(vertex_t, t, side="right")) - 1, len(lengths) - 1)
        s = distance_at(t - vertex_t[j], lengths[j], speeds[j], a, profs[j])
        return pts[j] + dirs[j] * s

    sharp = np.zeros(len(pts), dtype=bool)
    sharp[1:-1] = np.einsum("ij,ij->i", dirs[:-1], dirs[1:]) < math.cos(math.radians(SHARP_DEG))
    times, xy = [0.0], [pts[0]]

    def add(t: float) -> None:  # a sample at a whole millisecond (exact SM durations)
        t = round(t * 1000.0) / 1000.0
        if t > times[-1]:
            times.append(t)
            xy.append(position(t))

    sample_of = np.zeros(len(pts), dtype=int)
    last = len(pts) - 1
    for j in range(1, len(pts)):
        t0 = times[-1]
        gap = vertex_t[j] - t0
        if gap > lim.slice_s:
            n = math.ceil(gap / lim.slice_s - 1e-9)
            for i in range(1, n):
                add(t0 + gap * i / n)
        if j == last:
            end = max(math.ceil(vertex_t[j] * 1000.0 - 1e-6) / 1000.0, times[-1] + 0.001)
            times.append(end)
            xy.append(pts[j])
            sample_of[j] = len(times) - 1
        elif gap > lim.slice_s or gap >= lim.min_move_s or sharp[j]:
            add(vertex_t[j])
            sample_of[j] = len(times) - 1
        else:
            sample_of[j] = len(times)  # reached by the next sample's move
    return Timed(np.array(times), np.array(xy), sample_of[vertex_of])


class StepCursor:
    """The motors' absolute step counts (``QS``'s, from home) as moves are planned; see the
    module docstring for the rounding."""

    def __init__(self, steps_per_mm: float, steps: tuple[int, int] = (0, 0)):
        self.k = float(steps_per_mm)
        self.steps = (int(steps[0]), int(steps[1]))

    def target(self, xy_mm) -> tuple[int, int]:
        """The nearest whole steps of a machine position [mm]."""
        s1, s2 = motor_steps(float(xy_mm[0]), float(xy_mm[1]), self.k)
        return round(s1), round(s2)

    def position_mm(self, steps: tuple[int, int] | None = None) -> np.ndarray:
        """The machine position [mm] of step counts (default: the cursor's)."""
        return np.array(carriage_mm(*(steps if steps is not None else self.steps), self.k))

    def moves(self, timed: Timed) -> tuple[list[Move], np.ndarray]:
        """The ``SM`` moves along ``timed`` from the cursor's steps (which end at its last
        sample's), and per sample the index of the move that reaches it (-1: none needed).

        A sample less than a step from the last goes without a move (its time rides on the
        next); one that needs steps but no whole millisecond rides on the next move; a move
        that would step an axis slower than the EBB can is preceded by a pause."""
        moves: list[Move] = []
        reached = np.full(len(timed.t), -1, dtype=int)
        waiting: list[int] = []  # samples whose steps ride on the next move
        elapsed = slip = 0
        for k in range(1, len(timed.t)):
            goal = self.target(timed.xy[k])
            s1, s2 = goal[0] - self.steps[0], goal[1] - self.steps[1]
            if s1 == 0 and s2 == 0:
                reached[k] = len(moves) - 1
                continue
            duration = round(timed.t[k] * 1000.0) + slip - elapsed
            if duration <= 0:
                if k < len(timed.t) - 1:
                    waiting.append(k)
                    continue
                slip += 1 - duration
                duration = 1
            while max(abs(s1), abs(s2)) * 1000.0 / duration > MAX_STEP_RATE * RATE_MARGIN:
                duration += 1
                slip += 1
            slowest = min(abs(s) for s in (s1, s2) if s)
            longest = int(slowest * 1000.0 / MIN_STEP_RATE)
            if duration > longest:  # the carriage waits, then moves
                moves.append(Move(duration - longest, 0, 0))
                elapsed += duration - longest
                duration = longest
            moves.append(Move(duration, s1, s2))
            elapsed += duration
            self.steps = goal
            for w in [*waiting, k]:
                reached[w] = len(moves) - 1
            waiting = []
        return moves, reached


def path_moves(cursor: StepCursor, points, caps, lim: Limits) -> tuple[list[Move], np.ndarray]:
    """:func:`plan_path` then :meth:`StepCursor.moves`; per input vertex, the index of the
    move that reaches it (-1: reached before the first move)."""
    timed = plan_path(points, caps, lim)
    moves, reached = cursor.moves(timed)
    return moves, reached[timed.vertex_sample]


__all__ = ["SHARP_DEG", "Limits", "Move", "StepCursor", "Timed", "distance_at",
           "junction_speed", "path_moves", "plan_path", "profile_limits",
           "segment_profile", "vertex_speeds"]
