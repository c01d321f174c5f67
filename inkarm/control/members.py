"""The plants an executor steps together: one plant, or the members of a batched simulation.

The executor (:mod:`inkarm.control.executor`) drives N >= 1 plants with one period clock. It
reads and commands each member through the ordinary :class:`inkarm.core.plant.Plant` calls and
then advances them together: :meth:`Members.step` returns the members whose step faulted (a
diverged simulation, a device fault), with the fault, instead of raising, so that the others go
on. :class:`Solo` is a batch of one; a batched simulation (:class:`inkarm.sim.batch.BatchPlant`)
offers its members through :meth:`members` views of the same shape. :func:`lockstep` runs the
members' periods (each a generator that yields once per period) with one clock.
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Sequence
from typing import Protocol

import numpy as np

from inkarm.control.batch_lanes import batch_lanes
from inkarm.core.log import PHASES, DrawLog
from inkarm.core.plant import Plant
from inkarm.errors import RunFault

Progress = Callable[[float, str], None] | None


class Members(Protocol):
    """N plants advanced together."""

    @property
    def dt(self) -> float:
        """Control period [s], shared by every member."""
        ...

    @property
    def plants(self) -> Sequence[Plant]:
        """One plant per member: read and command it as any plant; its ``step`` is not
        called (:meth:`step` advances them all)."""
        ...

    def now(self) -> float | None:
        """The members' shared clock [s] where they have one (readings may be older)."""
        ...

    def step(self, members: list[int]) -> dict[int, RunFault]:
        """Advance ``members`` one period; the faults of those whose step failed."""
        ...


_NO_FAULTS: dict[int, RunFault] = {}  # (shared, never written: returned every period)


class Solo:
    """One plant as a batch of one."""

    def __init__(self, plant: Plant):
        self.plant = plant
        self.plants = (plant,)
        self.dt = plant.dt
        self._step = plant.step

    def now(self) -> float | None:
        now = getattr(self.plant, "now", None)
        return now() if now is not None else None

    def step(self, members: list[int]) -> dict[int, RunFault]:
        try:
            self._step()
        except RunFault as fault:
            return {0: fault}
        return _NO_FAULTS


def as_members(plant: Plant | Members) -> Members:
    """``plant`` as :class:`Members` (a single plant becomes a :class:`Solo`)."""
    return plant if hasattr(plant, "plants") else Solo(plant)


class Board:
    """What the members tell the executor between periods: each one's plan row (the progress),
    whether it is stopping after a fault (then it is not told of a Ctrl-C: it is lifting
    already), whether a Ctrl-C reached one of them (then every other one stops too), and, from a
    member stepped alone that ran whole periods in C, how many (for the progress; its plant needs
    no step this time); and the batch's C call that may take the members' periods."""

    __slots__ = ("interrupted", "lanes", "ran", "rows", "stopping")

    def __init__(self, n: int):
        self.rows = [0] * n
        self.stopping = [False] * n
        self.interrupted = False
        self.ran = 0  # periods a member stepped alone ran whole in C, its plant's steps too
        # the C call that may take the members' periods (inkarm.control.batch_lanes.BatchLanes:
        # each member's first period offers its compiled period there); None: no such call
        self.lanes = None


def lockstep(runs: list[Generator], members: Members, board: Board, n_ref: int,
              phases: np.ndarray, progress: Progress) -> list[DrawLog | RunFault]:
    """Advance every member one period at a time until each has finished or faulted.

    A member resumed by a fault (thrown in at its yield) commands the first period of its safe
    stop at once: it is ``ready`` and is stepped before it is resumed again. Where the members
    offer their rows to one C call (:mod:`inkarm.control.batch_lanes`), the members on their
    compiled lanes take their periods there after their first, until they go back to their
    generators (then for good)."""
    rows = board.rows
    results: list = [None] * len(runs)
    active = list(range(len(runs)))
    ready: set[int] = set()  # members that have commanded the coming step already
    told: set[int] = set()  # members told of a Ctrl-C
    report_every = max(1, round(0.1 / members.dt))
    interrupt: KeyboardInterrupt | None = None
    period = reported = 0
    lanes = batch_lanes(members, board)  # (None: every period in the members' generators)
    taken = lanes.taken if lanes is not None else ()

    def keep(m: int, end: BaseException) -> None:
        """Member ``m`` ended with ``end``: keep its result."""
        nonlocal interrupt
        if isinstance(end, StopIteration):
            results[m] = end.value
        else:
            results[m] = end
            if isinstance(end, KeyboardInterrupt):
                interrupt = interrupt or end
                told.add(m)

    def resume(m: int, fault: BaseException | None = None) -> bool:
        """Run member ``m`` to its next yield (``fault`` thrown in first); False when it
        ended, its result kept."""
        try:
            if fault is None:
                next(runs[m])
            else:
                runs[m].throw(fault)
            return True
        except (StopIteration, RunFault, KeyboardInterrupt) as end:
            keep(m, end)
        return False

    advance = [run.__next__ for run in runs]
    while active:
        try:
            if lanes is not None and lanes.offered and interrupt is None:
                lanes.take(active, board.stopping)
            ended: set[int] = set()
            rest = active
            if taken:  # the taken members' periods in one C call (the others' below)
                rest = [m for m in active if m not in taken] if len(taken) < len(active) else ()
                if interrupt is None:
                    for m, fault in lanes.period():
                        if not resume(m, fault):
                            ended.add(m)
                else:  # Ctrl-C: lift and stop
                    for m in list(lanes.ids):
                        told.add(m)
                        lanes.drop(m)
                        if not resume(m, KeyboardInterrupt()):
                            ended.add(m)
            if ready or interrupt is not None:
                for m in rest:
                    if m in ready:
                        ready.discard(m)
                        continue
                    if interrupt is not None and m not in told and not board.stopping[m]:
                        told.add(m)  # Ctrl-C: lift and stop
                        alive = resume(m, KeyboardInterrupt())
                    else:
                        alive = resume(m)
                    if not alive:
                        ended.add(m)
            else:  # (the common case, without a call per member: this runs every period)
                for m in rest:
                    try:
                        advance[m]()
                    except (StopIteration, RunFault, KeyboardInterrupt) as end:
                        keep(m, end)
                        ended.add(m)
            if ended:
                active = [m for m in active if m not in ended]
            if board.interrupted and interrupt is None:  # a member met Ctrl-C: all stop
                interrupt = KeyboardInterrupt()
            if not active:
                break
            ran, board.ran = board.ran, 0  # (a member stepped alone: its periods in C)
            faults = _NO_FAULTS if ran else members.step(active)
            if faults:
                for m, fault in faults.items():
                    if m in taken:
                        lanes.drop(m)
                    if resume(m, fault):
                        ready.add(m)
                    else:
                        active.remove(m)
            period += ran or 1
            if progress is not None and period // report_every > reported and active:
                reported = period // report_every
                last = min(rows[m] for m in active)
                progress(last / n_ref, PHASES[phases[min(last, n_ref - 1)]])
        except KeyboardInterrupt as stop:  # outside a member: in a step or the progress
            interrupt = interrupt or stop
            board.ran = 0  # (a safe stop's commands are stepped as any)
    if interrupt is not None:
        stop = KeyboardInterrupt()
        stop.logs = [getattr(r, "log", r if isinstance(r, DrawLog) else None) for r in results]
        stop.log = stop.logs[0]
        raise stop
    if progress is not None:  # (the execution is over, whether the members drew or failed)
        progress(1.0, PHASES[phases[-1]])
    return results


__all__ = ["Board", "Members", "Solo", "as_members", "lockstep"]
