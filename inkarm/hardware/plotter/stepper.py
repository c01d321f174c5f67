"""GRBL 1.1h's stepper as the outside sees it (facts from ``stepper.c`` and ``config.h``;
inkarm's own code): the planner model (:mod:`.planner`) is the motion; these are the offsets
GRBL's step generation puts between that motion, the position it reports and the speed.

* The stepper executes segments of 10 ms (``ACCELERATION_TICKS_PER_SECOND`` = 100), prepared
  ahead by the main loop into a buffer of 6 (5 usable): beyond the one executing,
  :data:`SEGMENTS_AHEAD` are ready, once the main loop has refilled the slot a finished one
  freed (:data:`REFILL_S`). A feed hold, a jog cancel or an override only changes the
  segments still to prepare, so it acts from the end of those (:func:`prepared_until`), and
  the feed a status report gives (``st_get_realtime_rate``) is the speed there
  (:func:`prepared_speed`).
* The position is whole steps. A segment runs its steps evenly in ticks of the stepper
  interrupt, 2^level per step under adaptive multi-axis step smoothing (:func:`amass_level`),
  with Bresenham counters that start at half: below 8 kHz a step comes half-way through its
  interval, so the position is the continuous one rounded (:func:`step_position`). From rest
  the first segments are lengthened until they hold 1.25 steps, so early steps come at their
  mean rate (:func:`segmented_start`). A hold stops on the last whole step, and its last
  segment ends once that step is done, before the continuous profile stops
  (:func:`hold_tail_s`).
* At the end of the motion ``st_go_idle`` waits ``$1`` ms before the cycle ends (state Run
  until then); see :meth:`~inkarm.hardware.plotter.machine.GrblMachine.advance`.
* A cycle that starts while no more line waits in the receive buffer (one command at a
  time) takes :data:`START_S` to its first stepper interrupt: the main loop starts the cycle
  once it finds the buffer empty and the interrupt comes when the timer next reaches its
  compare value (0 to 4 ms later, by the phase of a timer left running: not reproducible, see
  ``tests/hardware/plotter/test_grbl_transcripts.py``). A streamed job starts at once.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from inkarm.hardware.plotter.planner import profile_time

SEGMENT_S = 0.01  # 1 / ACCELERATION_TICKS_PER_SECOND [s]
START_S = 0.0005  # a cycle started from an empty receive buffer: to its first interrupt [s]
# (fitted: 0.3-0.6 ms reproduce the committed transcripts, with REFILL_S at 0.2-0.8 ms)
MAX_AMASS_LEVEL = 3  # stepper.c: the block's step counts are kept shifted by this
REQ_STEPS = 1.25  # stepper.c REQ_MM_INCREMENT_SCALAR: a segment's least travel [steps]
REFILL_S = 0.0003  # a freed segment slot to its refill by the main loop [s] (fitted)
TIE_STEPS = 1e-3  # float32 precision of GRBL's steps remaining (2^-24 x 10^4) [steps]
SEGMENTS_AHEAD = 4  # prepared segments beyond the executing one (fitted to grbl-sim's holds)


def prepared_until(now: float, cycle_start: float) -> float:
    """Machine time [s] up to which the stepper has its segments prepared at ``now``: the
    10 ms grid from ``cycle_start``, :data:`SEGMENTS_AHEAD` beyond the executing segment."""
    k = math.floor((now - cycle_start - REFILL_S) / SEGMENT_S + 1e-9)
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


def amass_level(step_rate_hz: float) -> int:
    """GRBL's adaptive multi-axis step smoothing level for a step rate [steps/s]: 0 at and
    above 8 kHz, 1 below 8, 2 below 4, 3 below 2 kHz (``config.h`` AMASS level cut-offs, set
    in ``st_prep_buffer`` from the segment's cycles per step)."""
    for level, limit in ((3, 2000.0), (2, 4000.0), (1, 8000.0)):
        if step_rate_hz < limit:
            return level
    return 0


def segmented_start(done: float, speed: float, accel_steps: float, entry_sqr: float) -> float:
    """The step events [steps] the stepper has run ``done`` continuous ones into a block that
    started from rest (``entry_sqr`` 0) and is still accelerating at ``accel_steps``
    [steps/s^2], now at ``speed`` [steps/s]: segments run their steps evenly, and from rest
    the first ones are lengthened by 10 ms until they hold 1.25 steps (``st_prep_buffer``),
    so early in the motion the steps come at the segment's mean rate, ahead of the
    parabola."""
    if entry_sqr > 1e-12 or speed <= 0 or accel_steps <= 0 or done <= 0:
        return done
    tau = math.sqrt(2.0 * done / accel_steps)  # time since the block started [s]
    if speed < 0.999 * accel_steps * tau:  # (past its acceleration: cruising or braking)
        return done

    def at(t: float) -> float:
        return 0.5 * accel_steps * t * t

    start = 0.0
    while start <= tau:
        end = start + SEGMENT_S
        while at(end) - at(start) < REQ_STEPS:
            end += SEGMENT_S
        if tau < end:
            return at(start) + (at(end) - at(start)) * (tau - start) / (end - start)
        start = end
    return done


def step_position(planner, position: np.ndarray, steps_per_mm: np.ndarray) -> np.ndarray:
    """The position [mm] GRBL's step counters hold (see the module docstring)."""
    block = planner.blocks[0] if planner.blocks else None
    if block is None or block.start is None or block.total <= 0:
        return np.round(position * steps_per_mm) / steps_per_mm
    s0 = np.round(block.start * steps_per_mm)
    s1 = np.round(block.target * steps_per_mm)
    delta = np.abs(s1 - s0).astype(np.int64)
    n = int(delta.max())
    if n == 0:
        return s0 / steps_per_mm
    done = n - max(block.length, 0.0) / block.total * n  # step events of the block [steps]
    done = segmented_start(done, planner.speed * n / block.total,
                           block.accel * n / block.total, block.entry_sqr)
    level = amass_level(planner.speed * n / block.total)
    if planner.speed <= 0:  # stopped in a hold: every whole step of the segments was taken
        # (a stop on a step boundary to float precision: GRBL's float32 steps remaining,
        # rounded up, leave that step untaken)
        ticks = max(math.floor(done - TIE_STEPS), 0) << level
    else:  # the ISR ticks once as it loads a segment, then every 1/2^level of a step
        ticks = math.floor(done * (1 << level) + 1e-6) + 1
    counter0 = (n << MAX_AMASS_LEVEL) >> 1  # stepper ISR: the counters start at half
    increment = (delta << MAX_AMASS_LEVEL) >> level
    steps = ((counter0 + ticks * increment - 1) // (n << MAX_AMASS_LEVEL)).clip(0, delta)
    return (s0 + np.sign(s1 - s0) * steps) / steps_per_mm


def hold_tail_s(block, steps_per_mm: np.ndarray, hold_from: float, stop: float) -> float:
    """How much earlier [s] than the continuous stop at ``stop`` GRBL's stepper runs out of
    steps in a feed hold that braked at ``block.accel`` from ``hold_from`` (facts from
    ``stepper.c`` ``st_prep_buffer``): braking segments are 10 ms, lengthened by 10 ms until
    they hold 1.25 steps (``REQ_MM_INCREMENT_SCALAR``) or reach the stop; a segment runs its
    whole steps (ceil of the steps remaining before it less after it) at the rate of its
    fractional ones plus the time the last segment's partial step did not use, so each one
    ends that partial step's time before the continuous profile does; a segment with no
    whole step is not made and the hold ends with the one before."""
    if block.start is None or block.total <= 0 or stop <= hold_from:
        return 0.0
    n = float(np.abs(np.round(block.target * steps_per_mm)
                     - np.round(block.start * steps_per_mm)).max())
    per_mm = n / block.total  # step events per mm along the block
    if per_mm <= 0:
        return 0.0

    def remaining(t: float) -> float:  # step events left in the block at t [steps]
        return (max(block.length, 0.0) + 0.5 * block.accel * (stop - t) ** 2) * per_mm

    start, steps = hold_from, remaining(hold_from)
    speed = block.accel * (stop - hold_from) * per_mm  # [steps/s] as the braking starts
    left = (math.ceil(steps - 1e-9) - steps) / max(speed, 1e-9)  # the partial step's time
    while start < stop - 1e-9:
        end = start + SEGMENT_S
        while end < stop - 1e-9 and steps - remaining(end) < REQ_STEPS:
            end += SEGMENT_S
        end = min(end, stop)
        after = remaining(end)
        before = math.ceil(steps - 1e-9)
        if before - math.ceil(after - 1e-9) <= 0:  # no whole step: not made, the hold ends
            return stop - (start - left)
        inv_rate = (end - start + left) / max(before - after, 1e-12)
        left = (math.ceil(after - 1e-9) - after) * inv_rate
        start, steps = end, after
    return left


class StepperView:
    """What :class:`~inkarm.hardware.plotter.machine.GrblMachine` (whose state it uses)
    reports through these: step positions, the blocks GRBL still holds, the reported feed."""

    def _steps_per_mm(self) -> np.ndarray:
        return np.array([self.settings[100], self.settings[101], self.settings[102]])

    def _quantised(self) -> np.ndarray:
        """The position as GRBL's step counters hold it [mm] (:func:`.step_position`)."""
        return step_position(self.planner, self.position, self._steps_per_mm())

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


__all__ = ["SEGMENTS_AHEAD", "SEGMENT_S", "START_S", "StepperView", "amass_level", "hold_tail_s",
           "prepared_blocks", "prepared_speed", "prepared_until", "step_position"]
