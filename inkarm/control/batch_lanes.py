"""A batch's members on their compiled lanes: a period of all of them in one C call.

Each member of an execution is a generator (:func:`inkarm.control.executor._member`) that
:func:`inkarm.control.members.lockstep` resumes once per period. On its lane
(:mod:`inkarm.control.member_lane`) a resume does little besides calls into C: the advance of
the period before, the reading, the period's steps 2-4 (``MemberPeriod.period``) and the
command. Where the members are a batch's whose reading and commands are (N, ...) arrays
(:meth:`inkarm.sim.batch_members.BatchMembers.lane_rows`), ``_member_batch.c``'s ``periods``
does all of that for every member in one call, reading their rows of the batch's arrays and
writing their commands into rows of the period's command arrays; the generators wait at their
yield.

A member goes back to its generator (:meth:`BatchLanes.drop`, for the rest of its run) where
its next period is not for the call: its plan ends, its reading is not one its lane takes, or
its period raised (a watchdog's fault, the search's, a Ctrl-C), or the batch's step faulted it,
or a Ctrl-C reached the others. Then the generator goes on as if it had run every period
itself: its plan row and log row are its kernel's (it reads them from there), its advance is
pending as after its own period, and a fault thrown in at its yield finds its kernel's
``MemberPeriod.fresh`` set where the C period took a reading and did not command it: that
reading, not its own last one, is the one to stop from.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

from inkarm.control.compiled import member_module


class BatchLanes:
    """The members whose periods one C call takes, in ascending order (``ids``)."""

    def __init__(self, periods: Callable, fetch: Callable, rows: list[int]):
        self._periods = periods  # (_member_batch.c's periods)
        self._fetch = fetch  # (BatchMembers.lane_rows)
        self._kernels: tuple = ()
        self.ids: list[int] = []
        self.offered: dict[int, object] = {}  # (each member's kernel, by its first period)
        self.taken: set[int] = set()  # (ids as a set)
        self._rows = rows  # (the Board's plan rows, the progress)

    def take(self, members: list[int], stopping: list[bool]) -> None:
        """Take, beside those taken already, the periods of ``members`` whose lanes are
        ``offered`` (their kernels, given by each member's first period) and who are not
        stopping; ``offered`` is emptied."""
        kernels = list(self._kernels) or [None] * len(self._rows)
        new = {m for m in members if m in self.offered and not stopping[m]}
        for m in new:
            kernels[m] = self.offered[m]
        self.offered.clear()
        self._kernels = tuple(kernels)
        self.taken.update(new)  # (in place: lockstep holds it)
        self.ids = sorted(self.taken)

    def drop(self, m: int) -> None:
        """Member ``m`` goes on in its generator."""
        self.ids.remove(m)
        self.taken.discard(m)

    def period(self) -> Iterator[tuple[int, BaseException | None]]:
        """One period of every member taken, in one C call from one hand-back to the next:
        yields each member that goes back to its generator, with the exception its period
        raised (None: its period is its generator's), dropped already."""
        ids, k = self.ids, 0
        while k < len(ids):
            k, fault = self._periods(self._kernels, ids, k, self._fetch, self._rows)
            if k == len(ids):
                return
            m = ids[k]
            self.drop(m)  # (then ids[k] is the one after it)
            yield m, fault


def batch_lanes(members, board) -> BatchLanes | None:
    """The C call for ``members`` where they offer their rows (``lane_rows``) and the
    extension is usable (``INKARM_COMPILED``); then ``board.lanes`` takes the members' offers."""
    fetch = getattr(members, "lane_rows", None)
    periods = None if fetch is None else getattr(member_module(), "periods", None)
    if periods is None:
        return None
    board.lanes = BatchLanes(periods, fetch, board.rows)
    return board.lanes


__all__ = ["BatchLanes", "batch_lanes"]
