"""GRBL 1.1h's stepper as the outside sees it (facts from ``stepper.c`` and ``config.h``;
inkarm's own code): the planner model (:mod:`.planner`) is the motion; these are the offsets
GRBL's step generation puts between that motion, the position it reports and the speed.

* The stepper executes segments of 10 ms (``ACCELERATION_TICKS_PER_SECOND`` = 100), prepared
  ahead by the main loop into a buffer of 6 (5 usable): beyond the one executing, about
  :data:`SEGMENTS_AHEAD` are ready. A feed hold or jog cancel only changes the segments still
  to prepare, so braking starts at the end of those (:func:`prepared_until`), and the feed a
  status report gives (``st_get_realtime_rate``) is the speed there (:func:`prepared_speed`).
* The position is whole steps: a block's step events done are all of them less the remaining
  ones rounded up, shared out per axis by Bresenham counters that start at half
  (:func:`step_position`).
* At the end of the motion ``st_go_idle`` waits ``$1`` ms before the cycle ends (state Run
  until then); see :meth:`~inkarm.hardware.plotter.machine.GrblMachine.advance`.
* A cycle that starts while no more line waits in the receive buffer (one command at a
  time) takes :data:`START_S` to its first step: the first stepper interrupt comes when the
  timer reaches its last compare value (up to 4 ms) and only loads the segment, and the main
  loop starts the cycle once it finds the buffer empty; fitted to the grbl-sim transcripts.
  A streamed job (more lines waiting) starts at once.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from inkarm.hardware.plotter.planner import profile_time

SEGMENT_S = 0.01  # 1 / ACCELERATION_TICKS_PER_SECOND [s]
START_S = 0.007  # a cycle started from an empty receive buffer: to its first step [s]
SEGMENTS_AHEAD = 4  # prepared segments beyond the executing one (fitted to grbl-sim's holds)


def prepared_until(now: float, cycle_start: float) -> float:
    """Machine time [s] up to which the stepper has its segments prepared at ``now``: the
    10 ms grid from ``cycle_start``, :data:`SEGMENTS_AHEAD` beyond the executing segment."""
    k = math.floor((now - cycle_start) / SEGMENT_S + 1e-9)
    return cycle_start + SEGMENT_S * (k + 1 + SEGMENTS_AHEAD)


def prepared_speed(planner, now: float, cycle_start: float, hold_from: float | None) -> float:
    """The speed [mm/s] at the end of the prepared segments: a copy of ``planner`` run on to
    :func:`prepared_until` (braking from ``hold_from`` when a hold is under way)."""
    ahead = prepared_until(now, cycle_start) - now
    shadow = copy.deepcopy(planner)
    if hold_from is not None:
        before = min(ahead, max(hold_from - now, 0.0))
        shadow.advance(before)
        shadow.advance(ahead - before, hold=True)
    else:
        shadow.advance(ahead)
    return shadow.speed


def prepared_blocks(planner, now: float, cycle_start: float) -> int:
    """How many of the planner's leading blocks the stepper has prepared to their end by
    now: GRBL discards a block from its planner then (``plan_discard_current_block`` in
    ``st_prep_buffer``), freeing its slot (``Bf:``) before the motion gets there."""
    if not planner.blocks:
        return 0
    horizon = prepared_until(now, cycle_start) - now
    done, t = 0, planner.time_to_finish_block()
    blocks = planner.blocks
    for k, block in enumerate(blocks):
        if k:
            exit_sqr = blocks[k + 1].entry_sqr if k + 1 < len(blocks) else 0.0
            t += profile_time(math.sqrt(block.entry_sqr), block.length, block.nominal,
                              math.sqrt(exit_sqr), block.accel)
        if t > horizon + 1e-9:
            break
        done += 1
    return done


def step_position(planner, position: np.ndarray, steps_per_mm: np.ndarray) -> np.ndarray:
    """The position [mm] GRBL's step counters hold (see the module docstring)."""
    block = planner.blocks[0] if planner.blocks else None
    if block is None or block.start is None or block.total <= 0:
        return np.round(position * steps_per_mm) / steps_per_mm
    s0 = np.round(block.start * steps_per_mm)
    s1 = np.round(block.target * steps_per_mm)
    delta = np.abs(s1 - s0)
    n = int(delta.max())
    if n == 0:
        return s0 / steps_per_mm
    events = n - math.ceil(max(block.length, 0.0) / block.total * n + 1e-7)
    steps = np.floor((n // 2 + events * delta - 1) / n).clip(0, delta)
    return (s0 + np.sign(s1 - s0) * steps) / steps_per_mm



class StepperView:
    """What :class:`~inkarm.hardware.plotter.machine.GrblMachine` (whose state it uses)
    reports through these: step positions, the blocks GRBL still holds, the reported feed."""

    def _quantised(self) -> np.ndarray:
        """The position as GRBL's step counters hold it [mm] (:func:`.step_position`)."""
        spm = np.array([self.settings[100], self.settings[101], self.settings[102]])
        return step_position(self.planner, self.position, spm)

    def _blocks_used(self) -> int:
        return len(self.held_blocks())

    def held_blocks(self) -> list:
        """The planner blocks GRBL still holds: those the stepper has not yet prepared to
        their end (:func:`.prepared_blocks`)."""
        blocks = list(self.planner.blocks)
        if not blocks or self.cycle_stop_at < math.inf or self.hold:
            return blocks
        done = prepared_blocks(self.planner, self.time, self.motion_t0)
        self.planner.prepared = max(self.planner.prepared, done)
        return blocks[done:]

    def _prep_speed(self) -> float:
        """GRBL's reported feed [mm/s] (:func:`.prepared_speed`)."""
        if self.planner.empty or self.cycle_stop_at < math.inf:
            return self.planner.speed
        hold_from = self.hold_from if self.hold else None
        return prepared_speed(self.planner, self.time, self.motion_t0, hold_from)


__all__ = ["SEGMENTS_AHEAD", "SEGMENT_S", "START_S", "StepperView", "prepared_blocks",
           "prepared_speed", "prepared_until", "step_position"]
