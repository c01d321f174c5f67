"""DrawLog: what happened during a run, one row per control period; to and from ``.npz``."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from inkarm.core.npz import read_npz
from inkarm.errors import InputError

PHASES = ("approach", "descend", "draw", "lift", "travel", "home")
APPROACH, DESCEND, DRAW, LIFT, TRAVEL, HOME = range(len(PHASES))


@dataclass(eq=False)
class DrawLog:
    """What happened, one row per control period.

    Attributes:
        time: Plant time in [s], (K,).
        q, qd, torque: Measured joint angles [rad], speeds [rad/s], commanded torques [N m], (K, n).
        tip: Pen tip in the page frame (x, y, z) in [mm], (K, 3): the plant's measurement when
            it has one, else forward kinematics of the measured q.
        force: Measured pen contact force in [N], (K,) (NaN when the plant cannot sense it).
        reference: Planned pen tip (x, y, z) in page [mm], (K, 3); z < 0 while pressing.
        phase: Index into :data:`PHASES`, (K,).
        stroke: Stroke index (during travel: the stroke travelled to), -1 during approach
            and home, (K,).
        wall_s: Wall-clock duration of the run in [s], planning included.
        notes: What the planner changed to make the run possible (e.g. slowed to speed limits).
    """

    time: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    torque: np.ndarray
    tip: np.ndarray
    force: np.ndarray
    reference: np.ndarray
    phase: np.ndarray
    stroke: np.ndarray
    wall_s: float = 0.0
    notes: tuple[str, ...] = ()

    @staticmethod
    def empty(capacity: int, n: int) -> DrawLog:
        return DrawLog(
            time=np.zeros(capacity),
            q=np.zeros((capacity, n)),
            qd=np.zeros((capacity, n)),
            torque=np.zeros((capacity, n)),
            tip=np.zeros((capacity, 3)),
            force=np.zeros(capacity),
            reference=np.zeros((capacity, 3)),
            phase=np.zeros(capacity, dtype=np.int8),
            stroke=np.zeros(capacity, dtype=np.int32),
        )

    def truncated(self, k: int) -> DrawLog:
        """The first ``k`` rows."""
        return self.rows(0, k)

    def rows(self, start: int, stop: int) -> DrawLog:
        """Rows ``start`` to ``stop`` (views, as slices are)."""
        cut = slice(start, stop)
        return DrawLog(
            self.time[cut],
            self.q[cut],
            self.qd[cut],
            self.torque[cut],
            self.tip[cut],
            self.force[cut],
            self.reference[cut],
            self.phase[cut],
            self.stroke[cut],
            self.wall_s,
            self.notes,
        )

    def __len__(self) -> int:
        return self.time.shape[0]

    @property
    def drawing(self) -> np.ndarray:
        """Boolean mask of the rows where a stroke is being tracked (phase draw)."""
        return self.phase == DRAW

    @property
    def realtime_factor(self) -> float:
        """Simulated time over wall-clock time."""
        span = float(self.time[-1] - self.time[0]) if len(self) > 1 else 0.0
        return span / self.wall_s if self.wall_s > 0 else float("inf")

    def tracking_error(self) -> np.ndarray:
        """In-plane distance |tip - reference| in [mm] on the draw rows."""
        mask = self.drawing
        return np.linalg.norm(self.tip[mask, :2] - self.reference[mask, :2], axis=1)

    def to_npz(self, path) -> None:
        """Write every column and ``wall_s`` to an ``.npz`` file (with the phase names)."""
        columns = {f.name: getattr(self, f.name) for f in fields(self)}
        columns["notes"] = np.array(self.notes, dtype=str)
        np.savez(path, **columns, phases=np.array(PHASES))

    @classmethod
    def from_npz(cls, path) -> DrawLog:
        """Read a log written by :meth:`to_npz`; the same arrays, bit for bit."""
        data = read_npz(path, "a DrawLog")
        missing = [f.name for f in fields(cls) if f.name not in data and f.name != "notes"]
        if missing:
            raise InputError(f"not a DrawLog: missing {', '.join(missing)}", file=str(path))
        phases = tuple(data["phases"].tolist()) if "phases" in data else PHASES
        if phases != PHASES:
            raise InputError(f"phase names {phases} differ from {PHASES}", file=str(path))
        columns = {f.name: data[f.name] for f in fields(cls) if f.name in data}
        columns["wall_s"] = float(columns["wall_s"])
        columns["notes"] = tuple(columns.get("notes", np.array([], dtype=str)).tolist())
        return cls(**columns)

    def __eq__(self, other) -> bool:
        if not isinstance(other, DrawLog):
            return NotImplemented
        return self.notes == other.notes and all(
            np.array_equal(getattr(self, f.name), getattr(other, f.name), equal_nan=True)
            for f in fields(self) if f.name != "notes")

    __hash__ = None  # type: ignore[assignment]
