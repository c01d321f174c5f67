"""The pen's touches of a batched plant's members: every physics step's normal force and tip, kept
as rows of arrays that grow, and fed to a member's canvas afterwards.

Row s holds the step's start time t_s [s], which members stepped (S, N), their pen forces [N]
(0 where a member did not step) and their tips [m] (world frame) at the state the step left
from, as MujocoPlant gives its canvas ``touch(p, F, t)`` during its run. The rows are written in
place, by :meth:`Touches.add` (the NumPy step) or by the compiled substeps
(:mod:`inkarm.sim.batch_substeps`) after :meth:`Touches.reserve`.
"""

from __future__ import annotations

import numpy as np


class Touches:
    """The touch rows of an ``n_members`` batch."""

    def __init__(self, n_members: int):
        self.n_members = n_members
        self.count = 0
        self.t = np.zeros(0)
        self.on = np.zeros((0, n_members), dtype=bool)
        self.force = np.zeros((0, n_members))
        self.tip = np.zeros((0, n_members, 3))
        self._stacked: tuple | None = None

    def reserve(self, rows: int) -> None:
        """Room for ``rows`` more rows (the arrays double as they fill)."""
        if self.count + rows <= len(self.t):
            return
        size = max(2 * len(self.t), self.count + rows, 1024)

        def grown(a: np.ndarray) -> np.ndarray:
            out = np.zeros((size, *a.shape[1:]), dtype=a.dtype)
            out[: self.count] = a[: self.count]
            return out

        self.t, self.on, self.force, self.tip = (grown(a) for a in
                                                 (self.t, self.on, self.force, self.tip))

    def add(self, t: float, stepped: np.ndarray | bool, force: np.ndarray,
            tip: np.ndarray) -> None:
        """One step's row: start time [s], the members that stepped, forces [N], tips [m]."""
        self.reserve(1)
        row = self.count
        self.t[row], self.on[row], self.force[row], self.tip[row] = t, stepped, force, tip
        self.count += 1

    def rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(t, on, force, tip) of the rows written so far (views)."""
        c = self.count
        return self.t[:c], self.on[:c], self.force[:c], self.tip[:c]

    def feed(self, member: int, canvas, to_page: np.ndarray, offset: np.ndarray) -> None:
        """Give ``canvas`` every touch of ``member`` so far, in order, as MujocoPlant gives its
        canvas during the run (``touch`` while the force is positive, ``lift`` when the contact
        ends, and at the end), in one ``touch_many`` call; tips on the page [mm], p A - o with
        each member's ``to_page`` A (N, 3, 3) and ``offset`` o (N, 3)."""
        if not self.count:
            return
        if self._stacked is None or len(self._stacked[0]) != self.count:
            t, stepped, force, tips = self.rows()
            # every step's tips on the page [mm] at once, each member's p A - o (element-wise)
            A, o, (x, y, z) = to_page, offset, np.moveaxis(tips, 2, 0)
            self._stacked = (t, stepped, force,
                             x * A[:, 0, 0] + y * A[:, 1, 0] + z * A[:, 2, 0] - o[:, 0],
                             x * A[:, 0, 1] + y * A[:, 1, 1] + z * A[:, 2, 1] - o[:, 1])
        t, stepped, force, px, py = self._stacked
        f, on = force[:, member], stepped[:, member]
        contact = on & (f > 0.0)
        ends = np.flatnonzero(on[1:] & contact[:-1] & ~contact[1:]) + 1
        rows = np.union1d(np.flatnonzero(contact), ends)  # (touch_many lifts at the ends)
        canvas.touch_many(np.column_stack((f, px[:, member], py[:, member], t))[rows])
        canvas.lift()


__all__ = ["Touches"]
