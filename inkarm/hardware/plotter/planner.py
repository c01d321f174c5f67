"""GRBL 1.1's motion planner, as a model: blocks, junction deviation, look-ahead and the
trapezoidal speed profile of the block being executed. Millimetres and seconds.

The facts (from GRBL's ``planner.c`` and its documentation; no code copied):

* The buffer holds at most :data:`BLOCK_BUFFER` = 15 straight-line blocks, the one being
  executed included.
* A block's acceleration and nominal speed are limited per axis: with unit direction u,
  ``a = min_i a_i / |u_i|`` and ``v_max = min_i r_i / |u_i|`` over the axes that move.
* Junction deviation: at a corner between directions u_prev and u, with
  ``cos(theta) = -u_prev . u`` (theta the angle between the incoming line, reversed, and the
  outgoing one: 180 deg for a straight continuation), the largest entry speed is

      v_j^2 = a_j * delta * sin(theta/2) / (1 - sin(theta/2)),   sin(theta/2) = sqrt((1 - cos)/2)

  where delta is ``$11`` and a_j the acceleration along the junction vector u - u_prev limited
  per axis like a block's; no limit for a straight line, zero for a full reversal. The entry
  speed is also at most both blocks' nominal speeds.
* Look-ahead: the last block must be able to stop at its end. A backward pass from the last
  block sets ``v_entry^2 = min(v_max_entry^2, v_next^2 + 2 a d)``; a forward pass from the
  executing block (whose entry is its current speed) caps ``v_next^2 <= v_entry^2 + 2 a d``.
* Each block runs a trapezoid: accelerate at a to its peak, cruise at the nominal speed,
  decelerate at a to the next block's entry speed.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

BLOCK_BUFFER = 15  # GRBL's BLOCK_BUFFER_SIZE (16) less the slot its ring buffer keeps empty
MINIMUM_FEED_MM_S = 1.0 / 60.0  # GRBL config.h MINIMUM_FEED_RATE (1 mm/min)
STRAIGHT_COS = 0.999999  # GRBL's thresholds on cos(theta) for reversals and straight lines


def limit_by_axes(limits, unit) -> float:
    """The largest value along ``unit`` whose every axis component stays within ``limits``:
    ``min_i limits_i / |unit_i|`` over the axes with ``unit_i != 0``."""
    # Plain floats: three components, called for every block (NumPy's overhead dominates).
    best = math.inf
    for limit, u in zip(limits, unit, strict=True):
        u = abs(float(u))
        if u > 1e-12:
            best = min(best, float(limit) / u)
    return best


def junction_speed_sqr(prev_unit, unit, accel, deviation_mm: float) -> float:
    """The junction-deviation limit v_j^2 in [mm^2/s^2] at the corner from direction
    ``prev_unit`` into ``unit``, with per-axis accelerations ``accel`` [mm/s^2] and the
    junction deviation ``deviation_mm`` [mm] (GRBL ``$11``); see the module docstring."""
    p, u = [float(v) for v in prev_unit], [float(v) for v in unit]
    cos_theta = -(p[0] * u[0] + p[1] * u[1] + p[2] * u[2])
    if cos_theta > STRAIGHT_COS:  # a full reversal: stop
        return 0.0
    if cos_theta < -STRAIGHT_COS:  # straight on
        return math.inf
    junction = [a - b for a, b in zip(u, p, strict=True)]
    norm = math.sqrt(sum(c * c for c in junction))
    accel_j = limit_by_axes(accel, [c / norm for c in junction])
    sin_half = math.sqrt(0.5 * (1.0 - cos_theta))
    return accel_j * deviation_mm * sin_half / (1.0 - sin_half)


@dataclass
class Block:
    """One straight move in the planner.

    Attributes:
        target: End point (x, y, z) in machine [mm].
        unit: Direction of travel (3,).
        length: Distance still to go in [mm] (shrinks while it executes).
        accel: Acceleration along the move in [mm/s^2].
        nominal: Cruise speed in [mm/s] (the feed, limited per axis).
        max_entry_sqr: Largest entry speed squared allowed by the junction and both nominals.
        entry_sqr: Planned entry speed squared.
        line: The G-code line number (1-based, as received) that made this block.
        start: Where the block starts [mm].
        total: Its whole length [mm].
        programmed: The programmed speed [mm/s] (the axes' limit for a rapid).
        limit: The axes' speed limit along the move [mm/s].
        rapid: A G0 (the rapid override applies, not the feed override).
        override: Whether the feed override applies (not to jogs and homing).
        junction_sqr: The junction-deviation limit at its start [mm^2/s^2].
    """

    target: np.ndarray
    unit: np.ndarray
    length: float
    accel: float
    nominal: float
    max_entry_sqr: float
    entry_sqr: float = 0.0
    line: int = 0
    start: np.ndarray | None = None
    total: float = 0.0
    programmed: float = 0.0
    limit: float = math.inf
    rapid: bool = False
    override: bool = True
    junction_sqr: float = 0.0


class Planner:
    """The block buffer with GRBL's look-ahead, and the execution of its first block.

    Args:
        accel: Per-axis accelerations (3,) in [mm/s^2] (``$120``-``$122``).
        max_rate: Per-axis speed limits (3,) in [mm/s] (``$110``-``$112``, which are mm/min).
        deviation_mm: Junction deviation in [mm] (``$11``).
    """

    def __init__(self, accel, max_rate, deviation_mm: float):
        self.accel = tuple(float(a) for a in accel)
        self.max_rate = tuple(float(r) for r in max_rate)
        self.deviation_mm = float(deviation_mm)
        self.blocks: deque[Block] = deque()
        self.speed = 0.0  # along the executing block [mm/s]
        self._last_unit: np.ndarray | None = None  # direction of the newest block
        self._last_nominal = 0.0
        self.overrides = (100, 100)  # feed, rapid [%]
        self.prepared = 0  # leading blocks whose speeds are final (set by the machine)
        self.last_target = np.zeros(3)  # end of the last block executed [mm]

    # -- filling -----------------------------------------------------------------------------

    @property
    def full(self) -> bool:
        return len(self.blocks) >= BLOCK_BUFFER

    @property
    def empty(self) -> bool:
        return not self.blocks

    def add(self, start: np.ndarray, target: np.ndarray, feed: float, line: int = 0,
            rapid: bool = False, override: bool = True) -> bool:
        """Queue the move from ``start`` to ``target`` [mm] at ``feed`` [mm/s] (programmed;
        ``rapid``: the axes' limit) and re-plan; False (nothing queued) for a move shorter
        than a micrometre, as GRBL drops moves of no steps. ``override``: the feed override
        applies (not to jogs and homing)."""
        target = np.asarray(target, dtype=float)
        delta = (target - np.asarray(start, dtype=float)).tolist()
        length = math.sqrt(delta[0] ** 2 + delta[1] ** 2 + delta[2] ** 2)
        if length < 1e-3:
            return False
        unit = np.array(delta) / length
        accel = limit_by_axes(self.accel, unit)
        limit = limit_by_axes(self.max_rate, unit)
        block = Block(target, unit, length, accel, 0.0, 0.0, 0.0, line,
                      np.asarray(start, dtype=float), length, min(float(feed), limit), limit,
                      rapid, override)
        if not self.blocks or self._last_unit is None:
            block.junction_sqr = 0.0  # starting from rest
        else:
            block.junction_sqr = junction_speed_sqr(self._last_unit, unit, self.accel,
                                                    self.deviation_mm)
        block.nominal = self._nominal(block)
        block.max_entry_sqr = min(block.junction_sqr, block.nominal**2, self._last_nominal**2)
        self.blocks.append(block)
        self._last_unit, self._last_nominal = unit, block.nominal
        self.recalculate()
        return True

    def _nominal(self, block: Block) -> float:
        """GRBL's plan_compute_profile_nominal_speed: the programmed speed times the rapid or
        feed override, within the axes' limit, at least MINIMUM_FEED_RATE (1 mm/min)."""
        if block.rapid:
            speed = block.programmed * self.overrides[1] / 100.0
        else:
            speed = block.programmed * (self.overrides[0] / 100.0 if block.override else 1.0)
            speed = min(speed, block.limit)
        return max(speed, MINIMUM_FEED_MM_S)

    def set_overrides(self, feed_pct: int, rapid_pct: int) -> None:
        """New feed and rapid overrides [%]: every queued block's nominal speed and entry
        limit recomputed, then re-planned (GRBL's plan_update_velocity_profile_parameters)."""
        self.overrides = (feed_pct, rapid_pct)
        previous = math.inf
        for block in self.blocks:
            block.nominal = self._nominal(block)
            block.max_entry_sqr = min(block.junction_sqr, block.nominal**2, previous**2)
            previous = block.nominal
        if self.blocks:
            self._last_nominal = previous
        self.recalculate()

    def recalculate(self) -> None:
        """GRBL's reverse and forward passes over the buffer (see the module docstring); the
        first :attr:`prepared` blocks (the stepper has them ready: their speeds are final)
        and the entry of the next stay as they are."""
        blocks = self.blocks
        if not blocks:
            return
        anchor = min(self.prepared, len(blocks) - 1)
        if anchor == 0:
            blocks[0].entry_sqr = self.speed**2  # the executing block enters at its speed
        exit_sqr = 0.0
        for idx in range(len(blocks) - 1, anchor, -1):
            block = blocks[idx]
            block.entry_sqr = min(block.max_entry_sqr, exit_sqr + 2 * block.accel * block.length)
            exit_sqr = block.entry_sqr
        for idx in range(anchor, len(blocks) - 1):
            prev, nxt = blocks[idx], blocks[idx + 1]
            reachable = prev.entry_sqr + 2 * prev.accel * prev.length
            nxt.entry_sqr = min(nxt.entry_sqr, reachable)

    def clear(self) -> None:
        """Forget every block and stop (soft reset, alarm)."""
        self.blocks.clear()
        self.prepared = 0
        self.speed = 0.0
        self._last_unit = None

    # -- executing ---------------------------------------------------------------------------

    def exit_sqr(self) -> float:
        """Planned speed squared at the end of the executing block."""
        return self.blocks[1].entry_sqr if len(self.blocks) > 1 else 0.0

    def time_to_finish_block(self) -> float:
        """Time in [s] until the executing block ends at the current plan; inf when empty."""
        if not self.blocks:
            return math.inf
        b = self.blocks[0]
        return profile_time(self.speed, b.length, b.nominal, math.sqrt(self.exit_sqr()), b.accel)

    def advance(self, dt: float, hold: bool = False) -> tuple[float, list[int]]:
        """Move along the plan for ``dt`` [s] (decelerating to a stop when ``hold``); returns
        the time actually moved [s] (less than ``dt`` when the buffer ran dry or a hold
        stopped) and the G-code lines whose blocks finished."""
        moved, finished = 0.0, []
        while dt - moved > 1e-12 and self.blocks:
            b = self.blocks[0]
            if hold:
                if self.speed <= 0.0:
                    break
                t_stop = self.speed / b.accel
                d_stop = 0.5 * self.speed * t_stop
                if d_stop > b.length:  # stopping runs past this block: decelerate through it
                    t_need = (self.speed - math.sqrt(max(self.speed**2 - 2 * b.accel * b.length,
                                                         0.0))) / b.accel
                else:
                    t_need = t_stop
                tau = min(dt - moved, t_need)
                ds = self.speed * tau - 0.5 * b.accel * tau * tau
                self.speed = max(self.speed - b.accel * tau, 0.0)
                b.length -= ds
                moved += tau
                if b.length <= 1e-9:
                    finished.append(self._pop())
                continue
            v_exit = math.sqrt(self.exit_sqr())
            ds, v, tau, done = profile_step(self.speed, b.length, b.nominal, v_exit, b.accel,
                                            dt - moved)
            b.length -= ds
            self.speed = v
            moved += tau
            if done:
                self.speed = v_exit
                finished.append(self._pop())
        if not self.blocks:
            self.speed = 0.0
        return moved, finished

    def position(self) -> np.ndarray | None:
        """Current position [mm] inside the executing block; None when the buffer is empty."""
        if not self.blocks:
            return None
        b = self.blocks[0]
        return b.target - b.unit * b.length

    def _pop(self) -> int:
        block = self.blocks.popleft()
        self.prepared = max(self.prepared - 1, 0)
        self.last_target = block.target
        if self.blocks:
            self.recalculate()
        return block.line


def _peak(v0: float, d: float, vn: float, ve: float, a: float) -> float:
    """The highest speed of a trapezoid from v0 to ve over d at acceleration a, capped at vn."""
    return min(vn, math.sqrt(max(0.5 * (2 * a * d + v0 * v0 + ve * ve), 0.0)))


def _phases(v0: float, d: float, vn: float, ve: float, a: float):
    """The trapezoid's phases (acceleration, duration, distance); None when it must brake
    uniformly (entering faster than it can slow down to ``ve`` at ``a``)."""
    vp = _peak(v0, d, vn, ve, a)
    if v0 <= vp + 1e-9:
        d1 = (vp * vp - v0 * v0) / (2 * a)
        d3 = max((vp * vp - ve * ve) / (2 * a), 0.0)
        d2 = max(d - d1 - d3, 0.0)
        return ((a, max(vp - v0, 0.0) / a, d1), (0.0, d2 / vp if vp > 0 else 0.0, d2),
                (-a, max(vp - ve, 0.0) / a, d3))
    # Entering above the nominal (an override lowered it): slow to it at a, cruise, stop.
    ve = min(ve, vn)
    d1 = (v0 * v0 - vn * vn) / (2 * a)
    d3 = max((vn * vn - ve * ve) / (2 * a), 0.0)
    if v0 > vn > 0 and d1 + d3 <= d:
        d2 = d - d1 - d3
        return ((-a, (v0 - vn) / a, d1), (0.0, d2 / vn, d2), (-a, (vn - ve) / a, d3))
    return None


def profile_time(v0: float, d: float, vn: float, ve: float, a: float) -> float:
    """Duration in [s] of the trapezoid from speed v0 to ve [mm/s] over d [mm], cruising at
    most at vn, accelerating at a [mm/s^2]."""
    if d <= 0:
        return 0.0
    phases = _phases(v0, d, vn, ve, a)
    if phases is None:  # entering too fast (a hold released, a plan tightened): brake to ve
        ve = min(ve, v0, vn)
        return 2 * d / (v0 + ve) if v0 + ve > 0 else math.inf
    return sum(duration for _, duration, _ in phases)


def profile_step(v0: float, d: float, vn: float, ve: float, a: float,
                 dt: float) -> tuple[float, float, float, bool]:
    """Follow the trapezoid of :func:`profile_time` for up to ``dt`` [s]: returns the distance
    moved [mm], the speed reached [mm/s], the time used [s] and whether the block ended."""
    if d <= 1e-12:  # (rounding left nothing of the block)
        return max(d, 0.0), min(v0, ve) if ve > 0 else 0.0, 0.0, True
    phases = _phases(v0, d, vn, ve, a)
    if phases is None:
        # Brake uniformly so that the block ends at ve (or at its peak when ve > v0).
        ve = min(ve, _peak(v0, d, vn, ve, a))
        decel = max((v0 * v0 - ve * ve) / (2 * d), 1e-9)
        t_all = (v0 - ve) / decel
        if dt >= t_all:
            return d, ve, t_all, True
        return v0 * dt - 0.5 * decel * dt * dt, v0 - decel * dt, dt, False
    moved, t, v = 0.0, 0.0, v0
    for acc, duration, distance in phases:
        if duration <= 0:
            continue
        if t + duration >= dt:
            tau = dt - t
            return moved + v * tau + 0.5 * acc * tau * tau, v + acc * tau, dt, False
        t += duration
        moved += distance
        v += acc * duration
    return d, ve, t, True
