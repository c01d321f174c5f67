"""The Plant protocol: what every backend (MuJoCo, Dynamixel bus, GRBL plotter) implements.

Controllers see only this interface and a kinematic model, never the simulator or a port.
Joint quantities are SI (rad, rad/s, N m, A); page quantities are millimetres.

A plant says what it can sense (:attr:`Plant.senses`: a subset of :data:`SENSES`) and which
commands it takes (:attr:`Plant.commands`: a subset of :data:`COMMANDS`); a reading leaves the
senses it lacks at None. :meth:`Plant.step` advances a simulation by one period, or waits on a
real device until its clock has reached the next period.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np

SENSES = frozenset({"force", "tip", "current", "torque"})
COMMANDS = frozenset({"torque", "position", "pen"})


@dataclass(slots=True)
class PlantState:
    """A reading of the plant.

    Attributes:
        time: Plant time in [s].
        q: Joint positions in [rad] (or [m] for prismatic joints), shape (n,).
        qd: Joint velocities, shape (n,).
        force: Pen contact force along the paper normal in [N], where sensed.
        tip_mm: Pen tip (x, y, z) in the page frame in [mm], where measured.
        current: Motor currents in [A], (n,), where sensed.
        torque: Joint torques in [N m] (applied or measured), (n,), where known.
        errors: Device error flags or messages, empty when healthy.
    """

    time: float
    q: np.ndarray
    qd: np.ndarray
    force: float | None = None
    tip_mm: np.ndarray | None = None
    current: np.ndarray | None = None
    torque: np.ndarray | None = None
    errors: tuple[str, ...] = ()


# Commands are immutable values (a plant may queue them). Named tuples rather than frozen
# dataclasses: a controller builds one every control period, and a frozen dataclass's
# constructor costs five times as much.


class TorqueCommand(NamedTuple):
    """Hold joint torques ``torque`` (n,) in [N m] until the next command."""

    torque: np.ndarray


class PositionCommand(NamedTuple):
    """Joint position goals ``q`` (n,) in [rad] for a device with its own servo loop, with
    velocity [rad/s], acceleration [rad/s^2] and torque [N m] feed-forward where it takes
    them."""

    q: np.ndarray
    qd: np.ndarray | None = None
    qdd: np.ndarray | None = None
    torque: np.ndarray | None = None


class PenCommand(NamedTuple):
    """Put a separately actuated pen down or lift it."""

    down: bool


Command = TorqueCommand | PositionCommand | PenCommand
COMMAND_KIND = {TorqueCommand: "torque", PositionCommand: "position", PenCommand: "pen"}


class Clock(Protocol):
    """Where a plant's time comes from."""

    def now(self) -> float:
        """Current time in [s]."""
        ...

    def wait_until(self, t: float) -> None:
        """Return once ``now() >= t``."""
        ...


@dataclass
class SimulatedClock:
    """A clock that only moves when the simulation advances it (never sleeps)."""

    time: float = 0.0

    def now(self) -> float:
        return self.time

    def wait_until(self, t: float) -> None:
        self.time = max(self.time, t)


@dataclass
class WallClock:
    """Monotonic wall-clock time, from when the clock was made; waits by sleeping."""

    start: float = field(default_factory=time.monotonic)

    def now(self) -> float:
        return time.monotonic() - self.start

    def wait_until(self, t: float) -> None:
        while (remaining := t - self.now()) > 0:
            time.sleep(min(remaining, 0.05))


@runtime_checkable
class Plant(Protocol):
    """A robot the controller can drive, simulated or real.

    Optionally, ``compiled_port()`` offers read, command and step as C functions
    (``inkarm/core/_plant.h``; an object with ``enter()`` -> a PyCapsule or None, and
    ``leave()``), or None: the executor then runs whole periods in C where its member's steps
    are compiled too (:mod:`inkarm.control.member_lane`; :class:`inkarm.sim.compiled.Port`).
    """

    @property
    def dt(self) -> float:
        """Control period in [s]."""
        ...

    @property
    def senses(self) -> frozenset[str]:
        """What :meth:`read` fills in beyond time, q and qd (a subset of :data:`SENSES`)."""
        ...

    @property
    def commands(self) -> frozenset[str]:
        """The command kinds :meth:`command` takes (a subset of :data:`COMMANDS`)."""
        ...

    def read(self) -> PlantState:
        """Current state."""
        ...

    def command(self, command: Command) -> None:
        """Apply a typed command until the next one of its kind."""
        ...

    def step(self) -> None:
        """Advance one control period (simulation) or wait until it has passed (hardware)."""
        ...

    def close(self) -> None:
        """Leave the device safe: pen up, then torque off or hold. Idempotent."""
        ...


def unsupported(plant: object, command: Command) -> str:
    """The message for a command kind a plant does not take."""
    kinds = ", ".join(sorted(getattr(plant, "commands", ())))
    return (f"{type(plant).__name__} does not take {COMMAND_KIND[type(command)]} commands; it "
            f"takes: {kinds}")
