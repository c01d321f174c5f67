"""The members of a :class:`inkarm.sim.batch.BatchPlant` as the executor's
:class:`inkarm.control.members.Members`: each member a plant of its own to read and command,
all of them stepped as one batch.

A member's reading is its row of the batch's reading (taken once per period, for all members);
its position command waits in the member until :meth:`BatchMembers.step` hands every pending
command to the batch in one call and steps the batch.
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
        s = self._members.reading()
        m = self.index
        time = s.time if s.times is None else float(s.times[m])  # (read-out jitter: its own)
        return PlantState(time, s.q[m], s.qd[m], float(s.force[m]), s.tip_mm[m],
                          torque=s.torque[m])

    def command(self, command) -> None:
        if type(command) is not PositionCommand:
            raise InputError(unsupported(self, command), key="controller.law")
        self._members.pending[self.index] = command

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
        self.pending: dict[int, PositionCommand] = {}
        self._reading = None
        self.plants = tuple(BatchMember(self, m) for m in range(plant.n_members))

    def now(self) -> float:
        return self.plant.now()

    def reading(self):
        if self._reading is None:
            self._reading = self.plant.read()
        return self._reading

    def step(self, members: list[int]) -> dict[int, RunFault]:
        ids = np.asarray(sorted(self.pending), dtype=np.intp)
        if len(ids):
            orders = [self.pending[m] for m in ids.tolist()]
            n = len(orders[0].q)
            zero = np.zeros(n)
            self.plant.command(
                ids, np.stack([o.q for o in orders]),
                np.stack([o.qd if o.qd is not None else zero for o in orders]),
                np.stack([o.torque if o.torque is not None else zero for o in orders]))
            self.pending.clear()
        self._reading = None
        return self.plant.step(np.asarray(members))


__all__ = ["BatchMember", "BatchMembers"]
