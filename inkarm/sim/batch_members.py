"""The members of a :class:`inkarm.sim.batch.BatchPlant` as the executor's
:class:`inkarm.control.members.Members`: each member a plant of its own to read and command,
all of them stepped as one batch.

A member's reading is its row of the batch's reading (taken once per period, for all members,
and split into rows once); its position command waits until :meth:`BatchMembers.step` hands
every pending command to the batch in one call (as (N, n) arrays) and steps the batch. Members
on their compiled lanes skip both: one C call reads their rows of the batch's reading and writes
their commands into rows of the period's command arrays (:meth:`BatchMembers.lane_rows`,
:mod:`inkarm.control.batch_lanes`), which :meth:`BatchMembers.step` hands over with the others'.
"""

from __future__ import annotations

import numpy as np

from inkarm.core.plant import PlantState, PositionCommand, unsupported
from inkarm.errors import InputError, RunFault
from inkarm.sim.batch import BatchPlant, BatchState


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


def _lane_ready(a: np.ndarray) -> bool:
    """Whether the compiled period takes ``a``'s rows as they are (float64, C order): else
    each member reads its own and its lane decides (period() refuses what it cannot take)."""
    return type(a) is np.ndarray and a.dtype == np.float64 and a.flags.c_contiguous


class BatchMembers:
    """Every member of ``plant`` (:class:`BatchPlant`), for :func:`inkarm.control.executor.
    execute`."""

    def __init__(self, plant: BatchPlant):
        self.plant = plant
        self.dt = plant.dt
        self.orders: list[PositionCommand | None] = [None] * plant.n_members  # pending
        self._zero = np.zeros(plant.n)
        self._reading: BatchState | None = None
        self._states: list[PlantState] | None = None
        # This period's command rows written by the compiled lanes (None: none yet): q [rad],
        # qd [rad/s], tau_ff [N m], and which members gave theirs.
        self._rows: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        self.plants = tuple(BatchMember(self, m) for m in range(plant.n_members))

    def now(self) -> float:
        return self.plant.now()

    def reading(self) -> BatchState:
        """The batch's reading of this period (read once, for every member)."""
        if self._reading is None:
            self._reading = self.plant.read()
        return self._reading

    def states(self) -> list[PlantState]:
        """The batch's reading as each member's :class:`PlantState` (rows of the arrays, forces
        as floats), read once a period for all of them."""
        if self._states is None:
            s = self.reading()
            n = self.plant.n_members
            times = [s.time] * n if s.times is None else s.times.tolist()  # (jitter: its own)
            self._states = [PlantState(*row[:5], torque=row[5]) for row in zip(
                times, s.q, s.qd, s.force.tolist(), s.tip_mm, s.torque)]
        return self._states

    def lane_rows(self) -> tuple | None:
        """This period's reading and command rows for the members' compiled periods in one
        call (``_member_batch.c``'s ``periods``): (time [s], times (N,) or None, q, qd, torque
        (N, n), force (N,), tip_mm (N, 3), then the commands' q, qd, tau_ff (N, n) and given
        (N,) bool, which the call writes). None where the reading's arrays are not float64 in C
        order: each member then reads its :class:`PlantState` (:meth:`states`)."""
        s = self.reading()
        if not all(map(_lane_ready, (s.q, s.qd, s.torque, s.force, s.tip_mm))) or (
                s.times is not None and not _lane_ready(s.times)):
            return None
        return (s.time, s.times, s.q, s.qd, s.torque, s.force, s.tip_mm, *self._command_rows())

    def _command_rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """This period's command rows (new each period: a delayed command holds its own)."""
        if self._rows is None:
            shape = (self.plant.n_members, self.plant.n)
            self._rows = (np.empty(shape), np.empty(shape), np.empty(shape),
                          np.zeros(shape[0], dtype=bool))
        return self._rows

    def step(self, members: list[int]) -> dict[int, RunFault]:
        zero = self._zero
        q, qd, tau, gave = self._command_rows()  # (the lanes' rows, and the others' orders)
        for m, order in enumerate(self.orders):
            if order is not None:
                q[m] = order.q
                qd[m] = zero if order.qd is None else order.qd
                tau[m] = zero if order.torque is None else order.torque
                gave[m] = True
        ids = np.flatnonzero(gave)
        if len(ids) == len(gave):
            self.plant.command(ids, q, qd, tau)
        elif len(ids):
            self.plant.command(ids, q[ids], qd[ids], tau[ids])
        self.orders = [None] * len(self.orders)
        self._rows = self._reading = self._states = None
        return self.plant.step(np.asarray(members))


__all__ = ["BatchMember", "BatchMembers"]
