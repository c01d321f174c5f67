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


def schedule_from(lines: list[str], settings: dict[int, float] | None = None,
                  start_mm=(0.0, 0.0, 0.0), params: np.ndarray | None = None,
                  pen: PenConfig | None = None, samples: bool = False) -> Schedule:
    """:func:`simulate` of ``lines`` on a machine set up as a device is when a job starts:
    standing at ``start_mm`` (machine [mm]) with the stored G54 and G28/G30 positions of
    ``params`` (8 x 3 [mm], machine: G54-G59, G28, G30; zeros when None). The set-up lines
    (``G10 L2``, ``G53 G0``, ``G28.1``/``G30.1``) run first and are cut off: times count
    from the job's first line; ``samples`` are in machine coordinates."""
    params = np.zeros((8, 3)) if params is None else np.asarray(params, dtype=float)
    pre = ["G21 G90"]
    for k, (x, y, z) in enumerate(params[:6]):
        if np.any(params[k]):
            pre.append(f"G10 L2 P{k + 1} X{x:.4f} Y{y:.4f} Z{z:.4f}")
    for k, store in ((6, "G28.1"), (7, "G30.1")):
        if np.any(params[k]):
            x, y, z = params[k]
            pre += [f"G53 G0 X{x:.4f} Y{y:.4f} Z{z:.4f}", store]
    x, y, z = (float(v) for v in start_mm)
    pre += [f"G53 G0 X{x:.4f} Y{y:.4f} Z{z:.4f}", "G4 P0"]
    plan = simulate(pre + list(lines), settings, pen, samples)
    begin = float(plan.line_end_s[len(pre) - 1])
    cut = None
    if plan.samples is not None:
        cut = plan.samples[plan.samples[:, 0] >= begin].copy()
        cut[:, 0] -= begin
    return Schedule(plan.seconds - begin, plan.line_end_s[len(pre):] - begin, cut)


def estimate_seconds(lines: Iterable[str], settings: dict[int, float] | None = None,
                     pen: PenConfig | None = None) -> float:
    """Execution time [s] of ``lines`` on the planner model (:func:`simulate`)."""
    return simulate(lines, settings, pen).seconds


__all__ = ["BLOCK_BUFFER", "Schedule", "estimate_seconds", "schedule_from", "simulate"]
