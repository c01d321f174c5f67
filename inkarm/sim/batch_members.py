"""The members of a :class:`inkarm.sim.batch.BatchPlant` as the executor's
:class:`inkarm.control.members.Members`: each member a plant of its own to read and command,
all of them stepped as one batch.

A member's reading is its row of the batch's reading (taken once per period, for all members,
and split into rows once); its position command waits until :meth:`BatchMembers.step` hands
every pending command to the batch in one call (as (N, n) arrays) and steps the batch.
"""

from __future__ import annotations

import numpy as np

from inkarm.core.plant import PlantState, PositionCommand, unsupported
from inkarm.errors import InputError, RunFault
from inkarm.sim.batch import BatchPlant


class BatchMember:
    """Member ``index`` of ``members``: a plant that takes position commands (its ``step`` is
    the batch's)."""

    commands = BatchPlant.commands
    senses = BatchPlant.senses

    def __init__(self, members: BatchMembers, index: int):
        self._members = members
        self.index = index
        self.dt = members.dt

    def read(self) -> PlantState:
        return self._members.states()[self.index]

    def command(self, command) -> None:
        if type(command) is not PositionCommand:
            raise InputError(unsupported(self, command), key="controller.law")
        self._members.orders[self.index] = command

    def step(self) -> None:
        raise InputError("a batch member steps with its batch (BatchMembers.step)")

    def close(self) -> None:
        """Nothing to release: the batch's members' pens are lifted when their canvases are
        fed."""


class BatchMembers:
    """Every member of ``plant`` (:class:`BatchPlant`), for :func:`inkarm.control.executor.
    execute`."""

    def __init__(self, plant: BatchPlant):
        self.plant = plant
        self.dt = plant.dt
        self.orders: list[PositionCommand | None] = [None] * plant.n_members  # pending
        self._zero = np.zeros(plant.n)
        self._states: list[PlantState] | None = None
        self.plants = tuple(BatchMember(self, m) for m in range(plant.n_members))

    def now(self) -> float:
        return self.plant.now()

    def states(self) -> list[PlantState]:
        """The batch's reading as each member's :class:`PlantState` (rows of the arrays, forces
        as floats), read once a period for all of them."""
        if self._states is None:
            s = self.plant.read()
            n = self.plant.n_members
            times = [s.time] * n if s.times is None else s.times.tolist()  # (jitter: its own)
            self._states = [PlantState(*row[:5], torque=row[5]) for row in zip(
                times, s.q, s.qd, s.force.tolist(), s.tip_mm, s.torque)]
        return self._states

    def step(self, members: list[int]) -> dict[int, RunFault]:
        ids = [m for m, order in enumerate(self.orders) if order is not None]
        if ids:
            given, zero = [self.orders[m] for m in ids], self._zero
            self.plant.command(
                np.array(ids, dtype=np.intp), np.array([o.q for o in given], dtype=float),
                np.array([zero if o.qd is None else o.qd for o in given], dtype=float),
                np.array([zero if o.torque is None else o.torque for o in given], dtype=float))
            self.orders = [None] * len(self.orders)
        self._states = None
        return self.plant.step(np.asarray(members))


__all__ = ["BatchMember", "BatchMembers"]
