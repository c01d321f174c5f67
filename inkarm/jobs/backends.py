"""Backends: how a scenario reaches a robot, by name.

``sim`` is the MuJoCo arm of :func:`inkarm.jobs.run.run`; each hardware backend opens its plant
on a port, drives it with the shared pen sequencing and returns the same
:class:`inkarm.jobs.run.Run` (status, reason, drawing, log, canvas, metrics), so writing,
reporting and regression do not care which robot drew.

Adding a backend is one :func:`register` call with a :class:`Backend`: a name, a help line,
whether it needs ``--port``, and ``run(scenario, options, progress) -> Run``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from inkarm.errors import InputError, unknown_name
from inkarm.jobs.run import Run
from inkarm.jobs.scenario import Scenario

Progress = Callable[[float, str], None] | None


@dataclass(frozen=True)
class BackendOptions:
    """How to reach the device.

    Attributes:
        port: Serial port (``/dev/ttyUSB0``, or the pseudo-terminal an emulator printed).
        profile: Backend-specific profile: a name or a TOML file (the plotter's pen profile).
        baudrate: Serial speed in [bit/s].
        time_scale: Device seconds per wall-clock second (1 for real hardware; an emulator's
            speed-up factor).
    """

    port: str | None = None
    profile: str | None = None
    baudrate: int = 115200
    time_scale: float = 1.0


@dataclass(frozen=True)
class Backend:
    """One way to draw a scenario."""

    name: str
    help: str
    needs_port: bool
    run: Callable[[Scenario, BackendOptions, Progress], Run]
    check: Callable[[Scenario, BackendOptions], str] | None = None
    """Everything ``run`` checks before it opens the port; returns a one-line summary."""


_BACKENDS: dict[str, Backend] = {}


def register(backend: Backend) -> Backend:
    """Add ``backend`` to the registry (replacing one of the same name) and return it."""
    _BACKENDS[backend.name] = backend
    return backend


def backend_names() -> tuple[str, ...]:
    """The registered backend names, ``sim`` first."""
    return tuple(_BACKENDS)


def get_backend(name: str) -> Backend:
    """The backend called ``name``; an :class:`InputError` naming the closest one otherwise."""
    if name not in _BACKENDS:
        raise unknown_name("backend", name, tuple(_BACKENDS), key="--backend")
    return _BACKENDS[name]


def run_backend(name: str, scenario: Scenario, options: BackendOptions | None = None,
                progress: Progress = None) -> Run:
    """Draw ``scenario`` on backend ``name``; the :class:`Run` as :func:`inkarm.jobs.run.run`
    returns it. A hardware backend without ``options.port`` is refused before anything opens."""
    backend = get_backend(name)
    options = options or BackendOptions()
    if backend.needs_port and not options.port:
        raise InputError(f"the {name} backend needs a serial port (--port PORT; `inkarm emulate "
                         f"{name}` prints one)", key="--port")
    return backend.run(scenario, options, progress)


def check_backend(name: str, scenario: Scenario,
                  options: BackendOptions | None = None) -> str | None:
    """What backend ``name`` checks before it moves anything, without a device (``draw
    --check``): its one-line summary; None for a backend without a check of its own (an arm
    is checked as the simulated one is: source, budgets, sheet, reach)."""
    backend = get_backend(name)
    return None if backend.check is None else backend.check(scenario, options or BackendOptions())


def _run_sim(scenario: Scenario, options: BackendOptions, progress: Progress) -> Run:
    from inkarm.jobs.run import run

    return run(scenario, progress=progress)


def _run_plotter(scenario: Scenario, options: BackendOptions, progress: Progress) -> Run:
    from inkarm.jobs.plotter import run_plotter_scenario

    return run_plotter_scenario(scenario, options.port, profile=options.profile,
                                baudrate=options.baudrate, time_scale=options.time_scale,
                                progress=progress)


def _run_dynamixel(scenario: Scenario, options: BackendOptions, progress: Progress) -> Run:
    from inkarm.jobs.dynamixel import run_dynamixel

    # --profile names the arm's calibration file (default: beside the robot profile)
    return run_dynamixel(scenario, options.port, calibration=options.profile, progress=progress)


def _check_plotter(scenario: Scenario, options: BackendOptions) -> str:
    from inkarm.jobs.plotter import check_plotter_scenario

    return check_plotter_scenario(scenario, profile=options.profile)


register(Backend("sim", "the MuJoCo arm of the scenario (default)", False, _run_sim))
register(Backend("plotter", "a GRBL 1.1 pen plotter on a serial port", True, _run_plotter,
                 _check_plotter))
register(Backend("dynamixel", "a Dynamixel X-series arm (Protocol 2.0) on a serial port", True,
                 _run_dynamixel))

__all__ = ["Backend", "BackendOptions", "backend_names", "check_backend", "get_backend",
           "register", "run_backend"]
