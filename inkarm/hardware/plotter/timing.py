"""How long a G-code job takes: the emulator's own machine (:mod:`.machine`), fed line by line
as a character-counting sender keeps it fed, advanced from event to event instead of against
the clock. Same planner, same look-ahead, same dwells and pen synchronisation: what the
emulator takes, less the serial link's latencies (which a full buffer hides).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from inkarm.hardware.plotter.machine import GrblMachine, PenConfig
from inkarm.hardware.plotter.planner import BLOCK_BUFFER
from inkarm.hardware.plotter.stepper import SEGMENT_S


@dataclass(frozen=True, eq=False)
class Schedule:
    """The planned execution of a job.

    Attributes:
        seconds: Machine time from the first line to idle [s].
        line_end_s: For each line, the machine time [s] at which its motion (or wait) ended.
        samples: (t [s], x, y, z [mm], pen touching) rows every few milliseconds, when asked.
    """

    seconds: float
    line_end_s: np.ndarray
    samples: np.ndarray | None = None


def simulate(lines: Iterable[str], settings: dict[int, float] | None = None,
             pen: PenConfig | None = None, samples: bool = False) -> Schedule:
    """Run ``lines`` on an emulated machine with an always-full receive buffer."""
    trace: list | None = [] if samples else None
    # No homing lock and no soft limits: the estimate runs the lines wherever they go.
    machine = GrblMachine({**(settings or {}), 20: 0, 22: 0}, pen, trace=trace)
    machine.outbox.clear()
    machine.streaming = True  # (an always-full receive buffer)
    pending = list(lines)
    n = len(pending)
    line_end = np.full(n, np.nan)
    taken = marked = 0
    while True:
        while taken < n and machine.accepts_line():
            machine.take_line(pending[taken])
            taken += 1
            machine.pump()
        machine.pump()
        marked = _record(machine, line_end, taken, marked)
        if machine.alarm:
            raise RuntimeError(f"line {machine.lines_done}: ALARM:{machine.alarm} "
                               f"({'; '.join(machine.outbox[-3:])})")
        if taken >= n and machine.idle:
            break
        dt = machine.next_event_s()
        if not math.isfinite(dt):
            dt = 1e-3
        if machine.planner.blocks:  # (blocks leave the planner as the stepper prepares them)
            dt = min(dt, SEGMENT_S)
        machine.advance(max(dt, 1e-9))
    _record(machine, line_end, taken, marked)
    # Lines that only set state end when the line before them did.
    line_end = np.fmax.accumulate(np.nan_to_num(line_end, nan=0.0))
    return Schedule(machine.time, line_end,
                    np.array(trace, dtype=float) if trace is not None else None)


def _record(machine: GrblMachine, line_end: np.ndarray, taken: int, marked: int) -> int:
    """Mark the lines whose work is behind the machine now: every line before the oldest
    block still in the planner (and before the line being worked on). The first ``marked``
    lines are marked already; returns how many are now."""
    machine.held_blocks()  # (the planner learns which blocks the stepper has prepared)
    blocks = machine.planner.blocks
    oldest = blocks[0].line if blocks else taken + 1
    if machine.work or machine.time < machine.dwell_until:
        oldest = min(oldest, machine.lines_done)
    done = max(0, min(oldest - 1, taken))
    line_end[marked:done] = machine.time
    return max(marked, done)


def estimate_seconds(lines: Iterable[str], settings: dict[int, float] | None = None,
                     pen: PenConfig | None = None) -> float:
    """Execution time [s] of ``lines`` on the planner model (:func:`simulate`)."""
    return simulate(lines, settings, pen).seconds


__all__ = ["BLOCK_BUFFER", "Schedule", "estimate_seconds", "simulate"]
