"""A batch of two members beside the two single plants of the same truths, driven alike: what
the batch-against-single tests share (tests/sim/test_jitter.py, tests/sim/test_stiction.py)."""

from __future__ import annotations

import numpy as np

from inkarm.core.plant import PositionCommand
from inkarm.sim.imperfections import PlantTruth
from inkarm.sim.plant import MujocoPlant

AMPLITUDE = np.array([0.2, -0.15, 0.2, 0.2, -0.3, 0.3, 0.4])  # [rad] of a 0.5 Hz sine per joint


def twins(cell, truths: list[PlantTruth], seeds: list[int]):
    """(the BatchPlant of ``truths``, the MujocoPlant of each)."""
    from inkarm.sim.batch import BatchPlant, member_model

    batch = BatchPlant([member_model(cell, t) for t in truths], cell, truths[0], seeds,
                       nthread=1)
    return batch, [MujocoPlant(member_model(cell, t), cell=cell, truth=t) for t in truths]


def sine_goals(q0: np.ndarray, dt: float, periods: int):
    """(q, qd) goals [rad, rad/s] of a 0.5 Hz sine about ``q0``, one per control period."""
    for k in range(periods):
        phase = 2 * np.pi * 0.5 * k * dt
        yield q0 + AMPLITUDE * np.sin(phase), AMPLITUDE * np.pi * np.cos(phase)


def command_both(batch, singles, q: np.ndarray, qd: np.ndarray) -> None:
    """The same goal to every single plant and every batch member, then one period each."""
    for plant in singles:
        plant.command(PositionCommand(q, qd))
        plant.step()
    n = len(singles)
    batch.command(np.arange(n), np.stack([q] * n), np.stack([qd] * n), np.zeros((n, len(q))))
    batch.step(np.arange(n))
