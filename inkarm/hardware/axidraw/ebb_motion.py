"""The EiBotBoard's motion queue and its 25 kHz step generator, in whole ISR ticks (EBB firmware
3.0.3, ``app.X/source/ebb.c``: ``high_ISR``, the FIFO and ``process_*`` functions).

Facts implemented here:

* The step ISR fires every 40 us (25 kHz, ``HIGH_ISR_TICKS_PER_MS`` = 25). Each axis has a
  31-bit accumulator: every tick the rate is added to it and a step is taken when it reaches
  2^31 (which is then taken off); the rate is ``steps * 2^31 / ticks`` (an ``SM`` of ``N``
  steps in ``D`` ms has rate ``floor(N * (85899345.92 / D))`` in 32-bit floats). ``LM``-type
  moves add the acceleration to the rate (and the jerk to the acceleration) before each tick;
  a negative rate steps backwards when the accumulator goes below 0. Accumulators carry over
  from one move to the next unless the move's Clear bits say otherwise (``EM`` and ``CS``
  zero them).
* A move ends at the tick its last axis takes its last step (``LT``/``T3``: after their
  intervals); the next FIFO entry is loaded at the end of that same tick, so queued moves run
  back to back. A delay (``SM`` with no steps) lasts ``25 * ms`` ticks; a servo move or ``EM``
  runs in one tick, a servo move with a delay in ``25 * delay`` ticks.
* The FIFO holds ``gCurrentFIFOLength`` entries (1 at boot, up to 32 with ``CU,4``) besides the
  one executing; a parser that finds it full waits (:meth:`MotionQueue.has_room`).
* ``QM``'s "motor moving" is "a command executes and the current move's remaining steps on that
  axis are not zero" (stale after a delay follows an interrupted move, as in the firmware).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

TICKS_PER_MS = 25
TICK_S = 1.0 / (1000 * TICKS_PER_MS)
ONE = 1 << 31
FIFO_MAX = 32  # COMMAND_FIFO_MAX_LENGTH
CHUNK_TICKS = 25_000  # ticks computed at once (1 s)
CLEAR1, CLEAR2, NEGATE1, NEGATE2 = 1, 2, 4, 8  # SEState bits of a move


def _wrap32(values):
    """Signed 32-bit wrap of int64 values (the firmware's INT32 arithmetic)."""
    return ((values + ONE) % (1 << 32)) - ONE


@dataclass
class Move:
    """One FIFO entry.

    Attributes:
        kind: "steps" (SM, XM, HM, LM, L3), "timed" (LT, T3), "delay", "servo", "enable" or
            "engraver".
        rate, accel, jerk: Per axis, per tick (``LM``'s rate already less ``accel / 2``).
        steps: Per axis, steps to take ("timed": ``steps[0]`` is the ticks to run).
        signs: Per axis, +1/-1 for a fixed direction (SM family) or 0: the rate's sign.
        clear: Accumulator bits applied when loaded (:data:`CLEAR1` ...).
        delay_ticks: Ticks of delay ("delay", "servo").
        payload: What a "servo", "enable" or "engraver" entry carries.
    """

    kind: str
    rate: tuple[int, int] = (0, 0)
    steps: tuple[int, int] = (0, 0)
    accel: tuple[int, int] = (0, 0)
    jerk: tuple[int, int] = (0, 0)
    signs: tuple[int, int] = (1, 1)
    clear: int = 0
    delay_ticks: int = 0
    payload: tuple = ()

    @property
    def is_motion(self) -> bool:
        return self.kind in ("steps", "timed")


class MotionQueue:
    """The FIFO, the executing command and the step counters; :meth:`run` advances the ISR.

    Hooks (an object with ``on_servo(payload, tick)``, ``on_enable(payload, tick)`` and
    ``on_engraver(payload, tick)``) act on the non-motion entries when they execute.
    """

    def __init__(self, hooks) -> None:
        self.hooks = hooks
        self.fifo: deque[Move] = deque()
        self.capacity = 1
        self.tick = 0
        self.current: Move | None = None
        self.counters = [0, 0]  # globalStepCounter1/2
        self.acc = [0, 0]
        self.live_steps = [0, 0]  # CurrentCommand Steps[] (stale between moves, as in QM)
        self.delay_left = 0
        self._rate = [0, 0]
        self._accel = [0, 0]
        self._first = False
        self.steps_taken = 0

    # -- the parser's side --------------------------------------------------------------------

    def has_room(self) -> bool:
        return len(self.fifo) < self.capacity

    @property
    def idle(self) -> bool:
        """No command executing and none queued (``HM`` and ``CU,4`` wait for this)."""
        return self.current is None and not self.fifo and self.delay_left == 0

    def push(self, move: Move) -> None:
        self.fifo.append(move)

    def status(self) -> tuple[int, int, int, int]:
        """``process_QM``: (command executing, motor 1 moving, motor 2 moving, FIFO not empty)."""
        executing = int(self.current is not None or self.delay_left != 0 or bool(self.fifo))
        return (executing, int(executing and self.live_steps[0] != 0),
                int(executing and self.live_steps[1] != 0), int(bool(self.fifo)))

    def stop(self) -> bool:
        """``ES``: drop the executing command and the FIFO; whether a move was interrupted."""
        interrupted = (self.current is not None and self.current.is_motion) or bool(self.fifo)
        self.current = None
        self.fifo.clear()
        self.delay_left = 0
        return interrupted

    def clear_counters(self) -> None:
        """``CS`` (and an executed ``EM``): zero both step counters and both accumulators."""
        self.counters = [0, 0]
        self.acc = [0, 0]

    # -- the ISR's side -------------------------------------------------------------------------

    def run(self, until_tick: int):
        """Advance to ``until_tick``; yields (first tick, step deltas per tick (n, 2)) for every
        span of motion, so the caller can follow the carriage."""
        while self.tick < until_tick:
            if self.current is None:
                if not self.fifo:
                    self.tick = until_tick
                    return
                self._load(self.fifo.popleft())
            span = self._execute(until_tick - self.tick)
            if span is not None:
                yield span

    def _load(self, move: Move) -> None:
        self.current = move
        self._first = True
        if move.kind in ("delay", "servo"):
            self.delay_left = move.delay_ticks
        if move.is_motion:
            for axis, (clear, negate) in enumerate(((CLEAR1, NEGATE1), (CLEAR2, NEGATE2))):
                if move.clear & clear:
                    self.acc[axis] = 0
                if move.clear & negate:
                    self.acc[axis] = ONE - 1
            self._rate = list(move.rate)
            self._accel = list(move.accel)
            self.live_steps = list(move.steps) if move.kind == "steps" else [move.steps[0], 0]

    def _finish(self, ticks: int) -> None:
        self.tick += ticks
        self.current = None

    def _execute(self, budget: int):
        move = self.current
        if move.kind in ("delay", "servo"):
            if self._first and move.kind == "servo":
                self.hooks.on_servo(move.payload, self.tick + 1)
            self._first = False
            ticks = min(budget, max(self.delay_left, 1))
            self.delay_left = max(self.delay_left - ticks, 0)
            if self.delay_left == 0:
                self._finish(ticks)
            else:
                self.tick += ticks
            return None
        if move.kind in ("enable", "engraver"):
            getattr(self.hooks, "on_" + move.kind)(move.payload, self.tick + 1)
            if move.kind == "enable":
                self.clear_counters()
            self._finish(1)
            return None
        return self._step(move, min(budget, CHUNK_TICKS))

    def _step(self, move: Move, n: int):
        """Run a move for up to ``n`` ticks: (first tick, ticks used, sampler), the sampler
        giving the step deltas (k, 2) at tick offsets (1-based) within the span."""
        start = self.tick
        timed = move.kind == "timed"
        if timed:
            n = min(n, self.live_steps[0])
        samplers, ends = [], [0, 0]
        for axis in (0, 1):
            left = self.live_steps[0] if timed else self.live_steps[axis]
            sign = move.signs[axis] or 1
            if left == 0 or n == 0:
                samplers.append(None)
                continue
            if move.jerk[axis] == 0 and self._accel[axis] == 0:
                end, q_end, sampler = self._constant(axis, n, None if timed else left)
            else:
                end, q_end, sampler = self._accelerating(move, axis, n, None if timed else left)
            if not timed:
                self.live_steps[axis] = left - abs(q_end)
            self.counters[axis] += sign * q_end
            self.steps_taken += abs(q_end)
            samplers.append((sign, sampler))
            ends[axis] = end
        if timed:
            used = max(n, 1)
            self.live_steps[0] -= n
            done = self.live_steps[0] <= 0
        else:
            done = self.live_steps[0] == 0 and self.live_steps[1] == 0
            used = max(max(ends) if done else n, 1)
        if done:
            self._finish(used)
        else:
            self.tick += used

        def sample(offsets: np.ndarray) -> np.ndarray:
            out = np.zeros((len(offsets), 2))
            for axis, item in enumerate(samplers):
                if item is not None:
                    out[:, axis] = item[0] * item[1](np.minimum(offsets, ends[axis]))
            return out

        return start, used, sample

    def _constant(self, axis: int, n: int, left: int | None):
        """A constant-rate axis for up to ``n`` ticks: (ticks it stepped for, steps (signed),
        sampler); ``left`` None: no step limit (timed moves)."""
        acc, rate = self.acc[axis], self._rate[axis]
        end = n
        if left is not None and rate > 0:  # first tick at which the last step is taken
            end = min(n, -((acc - left * ONE) // rate))
        elif left is not None and rate < 0:
            end = min(n, -(-(acc + (left - 1) * ONE + 1) // -rate))
        total = acc + rate * end
        q_end = total // ONE
        if left is not None:
            q_end = max(-left, min(q_end, left))
        self.acc[axis] = (total - q_end * ONE) % ONE

        def sampler(offsets: np.ndarray) -> np.ndarray:
            q = (acc + rate * offsets.astype(np.int64)) // ONE
            return q if left is None else np.clip(q, -left, left)

        return end, int(q_end), sampler

    def _accelerating(self, move: Move, axis: int, n: int, left: int | None):
        """An axis with acceleration (and jerk), tick by tick in int64 arithmetic."""
        j = np.arange(1, n + 1, dtype=np.int64)
        accel = _wrap32(self._accel[axis] + move.jerk[axis] * j)
        rate = _wrap32(self._rate[axis] + np.cumsum(accel))
        total = self.acc[axis] + np.cumsum(rate)
        q = np.floor_divide(total, ONE)
        end = n
        if left is not None:
            count = np.cumsum(np.abs(np.diff(q, prepend=0)))
            hit = int(np.searchsorted(count, left))
            end = hit + 1 if hit < n else n
        self.acc[axis] = int(total[end - 1] % ONE)
        self._rate[axis] = int(rate[end - 1])
        self._accel[axis] = int(accel[end - 1])
        q = q[:end]

        def sampler(offsets: np.ndarray) -> np.ndarray:
            return q[np.clip(offsets, 1, end) - 1]

        return end, int(q[-1]), sampler


__all__ = ["FIFO_MAX", "ONE", "TICKS_PER_MS", "TICK_S", "MotionQueue", "Move"]
