"""The Plant protocol: what every backend (MuJoCo, Dynamixel bus, GRBL plotter) implements.

Controllers see only this interface and a kinematic model, never the simulator or a port.
Joint quantities are SI (rad, rad/s, N m); the page-to-robot transform converts from mm once.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np


@dataclass
class PlantState:
    """A reading of the plant.

    Attributes:
        time: Plant time in [s].
        q: Joint positions in [rad] (or [m] for prismatic joints), shape (nq,).
        qd: Joint velocities, shape (nq,).
        torque: Measured joint torque/effort where the device has it, else None.
        errors: Device error flags or messages, empty when healthy.
    """

    time: float
    q: np.ndarray
    qd: np.ndarray
    torque: np.ndarray | None = None
    errors: list[str] = field(default_factory=list)


@runtime_checkable
class Plant(Protocol):
    """A robot the controller can drive, simulated or real."""

    @property
    def dt(self) -> float:
        """Control period in [s]."""
        ...

    def read(self) -> PlantState:
        """Current state."""
        ...

    def command(
        self,
        torque: np.ndarray | None = None,
        q_goal: np.ndarray | None = None,
        qd_ff: np.ndarray | None = None,
        pen_down: bool | None = None,
    ) -> None:
        """Set joint torques, or joint position goals with velocity feed-forward (and the pen
        state where the device has a separate pen actuator)."""
        ...

    def step(self) -> None:
        """Advance one control period (simulation) or wait until it has passed (hardware)."""
        ...

    def close(self) -> None:
        """Leave the device safe: pen up, torque off. Idempotent."""
        ...
