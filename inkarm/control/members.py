"""The plants an executor steps together: one plant, or the members of a batched simulation.

The executor (:mod:`inkarm.control.executor`) drives N >= 1 plants with one period clock. It
reads and commands each member through the ordinary :class:`inkarm.core.plant.Plant` calls and
then advances them together: :meth:`Members.step` returns the members whose step faulted (a
diverged simulation, a device fault), with the fault, instead of raising, so that the others go
on. :class:`Solo` is a batch of one; a batched simulation (:class:`inkarm.sim.batch.BatchPlant`)
offers its members through :meth:`members` views of the same shape.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

from inkarm.core.plant import Plant
from inkarm.errors import RunFault


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


__all__ = ["Members", "Solo", "as_members"]
