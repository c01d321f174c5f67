"""Backends: how a scenario reaches a robot, and the one assembly of a run for all of them.

A backend (:class:`Backend`) checks a scenario and opens a :class:`Session` on its device: the
drawing placed and checked, the plant open, what the device senses. :func:`run_backend` is the
one place that turns a scenario into a :class:`~inkarm.jobs.outcome.Run` on any backend:

1. open: place the drawing, check everything that can be checked before moving (errors name the
   scenario file and key), open the device;
2. execute the drawing (the arms: :func:`inkarm.control.executor.run_drawing` with the
   scenario's law and watchdogs; a plotter streams its G-code);
3. a fault (a watchdog, the device, a diverged simulation) ends the run with the pen up and the
   log kept: :func:`~inkarm.jobs.outcome.failed_run`; Ctrl-C raises
   :class:`~inkarm.jobs.outcome.RunInterrupted` with the partial run;
4. the metrics (the arms' :func:`~inkarm.jobs.outcome.measured`, or the backend's own) and the
   judge: :func:`~inkarm.jobs.outcome.finished_run`, on what the backend senses.

Built-in backends (``sim``, ``servo_sim``, ``dynamixel``, ``plotter``, ``axidraw``) register in
:func:`inkarm.plugins.registry` ``("backend")`` when first looked up; another is its package
plus one registration (or an ``inkarm.plugins`` entry point ``backend.<name>``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, runtime_checkable

from inkarm.core.log import DrawLog
from inkarm.core.run import Metrics, Senses
from inkarm.core.trajectory import Drawing
from inkarm.errors import InkarmError, InputError, RunFault
from inkarm.ink.canvas import Canvas
from inkarm.jobs.outcome import INTERRUPTED, Run, RunInterrupted, failed_run, finished_run
from inkarm.jobs.scenario import Scenario
from inkarm.plugins import registry

Progress = Callable[[float, str], None] | None
BACKENDS = registry("backend")


@dataclass(frozen=True)
class BackendOptions:
    """How to reach the device (the command line's; a scenario's ``[dynamixel]`` and
    ``[plotter]`` tables give the defaults).

    Attributes:
        port: Serial port (``/dev/ttyUSB0``, or the pseudo-terminal an emulator printed).
        profile: Backend-specific profile: the plotter's pen profile (a name or a TOML file),
            a Dynamixel arm's calibration file.
        baudrate: Serial speed in [bit/s].
        time_scale: Device seconds per wall-clock second (1 for real hardware; an emulator's
            speed-up factor).
        canvas: Where the ink lands when the run can see it (an in-process emulator's page);
            None: a fresh page of the scenario's ink.
        trace_path: Where a device's trace goes on a fault (the Dynamixel bus's, .npz).
    """

    port: str | None = None
    profile: str | None = None
    baudrate: int = 115200
    time_scale: float = 1.0
    canvas: Canvas | None = None
    trace_path: str | Path | None = None


class Session(Protocol):
    """A backend opened for one run: its attributes are fixed when it opens."""

    drawing: Drawing  # placed on the page, checked, page [mm] and [s]
    canvas: Canvas
    believed: object  # the controller's kinematic model (None for a plotter)
    senses: Senses  # what the judge may judge
    notes: tuple[str, ...]  # what the backend wants said about every run
    interrupted: str  # the reason of a Run stopped by Ctrl-C

    def execute(self, progress: Progress) -> DrawLog:
        """Draw; a fault raises :class:`RunFault` with the log so far in its ``log``."""
        ...

    def measure(self, log: DrawLog | None, finished: bool) -> Metrics | None:
        """The metrics of ``log`` where the backend measures its own (after :meth:`close`);
        None: the arms' (:func:`~inkarm.jobs.outcome.measured`)."""
        ...

    def close(self) -> None:
        """Leave the device safe (pen up; idempotent)."""
        ...


@runtime_checkable
class Backend(Protocol):
    """One way to draw a scenario: ``name`` (``--backend``), a ``help`` line, whether it
    ``needs_port``; :meth:`check` is what ``inkarm draw --check`` prints (None: the arm's checks
    only), :meth:`open` opens a :class:`Session`."""

    name: str
    help: str
    needs_port: bool

    def check(self, scenario: Scenario, options: BackendOptions) -> str | None: ...

    def open(self, scenario: Scenario, options: BackendOptions) -> Session: ...


def register(backend: type[Backend] | Backend) -> type[Backend] | Backend:
    """Add ``backend`` (a class, or an instance) to the registry under its ``name``, replacing
    one of the same name, and return it."""
    return BACKENDS.register(backend.name, backend)


def backend_names() -> tuple[str, ...]:
    """The registered backend names, ``sim`` first."""
    return BACKENDS.names()


def get_backend(name: str) -> Backend:
    """The backend called ``name``; an :class:`InputError` naming the closest one otherwise."""
    backend = BACKENDS.get(name, key="--backend")
    if isinstance(backend, type):
        backend = backend()
    missing = [m for m in ("name", "help", "needs_port", "check", "open")
               if not hasattr(backend, m)]
    if missing:
        raise InputError(f"{name!r} is not a backend (missing: {', '.join(missing)})",
                         key="--backend", value=name)
    return backend


def run_backend(name: str, scenario: Scenario, options: BackendOptions | None = None,
                progress: Progress = None) -> Run:
    """Draw ``scenario`` on backend ``name`` (module docstring): the :class:`Run`, judged by
    the scenario's ``[judge]`` on what the backend senses. A backend that needs a port is
    refused without one before anything opens."""
    backend = get_backend(name)
    options = options or BackendOptions()
    if backend.needs_port and not options.port:
        raise InputError(f"the {name} backend needs a serial port (--port PORT; `inkarm emulate "
                         f"{name}` prints one)", key="--port")
    try:
        session = backend.open(scenario, options)
    except InkarmError as e:  # (a device's own error names its option, not the scenario)
        raise (e if (e.key or "").startswith("--") else e.within(file=scenario.path)) from None
    try:
        log = session.execute(progress)
    except RunFault as fault:
        session.close()
        partial = getattr(fault, "log", None)
        return failed_run(scenario, session.drawing, fault, session.canvas, session.believed,
                          senses=session.senses, log=partial,
                          metrics=session.measure(partial, finished=False),
                          notes=_notes(session, partial))
    except KeyboardInterrupt as stop:
        session.close()
        raise RunInterrupted(Run(scenario, INTERRUPTED, session.drawing,
                                 getattr(stop, "log", None), session.canvas,
                                 reason=session.interrupted)) from None
    except InkarmError as e:  # a setting refused while running names the scenario's key
        session.close()
        fields = set(type(scenario.controller).__dataclass_fields__)
        raise e.within(file=scenario.path,
                       key="controller" if e.key in fields else None) from None
    except BaseException:
        session.close()
        raise
    session.close()
    return finished_run(scenario, session.drawing, log, session.canvas, session.believed,
                        senses=session.senses, metrics=session.measure(log, finished=True),
                        notes=_notes(session, log))


def _notes(session: Session, log: DrawLog | None) -> tuple[str, ...]:
    return tuple(session.notes) + (tuple(log.notes) if log is not None else ())


def check_backend(name: str, scenario: Scenario,
                  options: BackendOptions | None = None) -> str | None:
    """What backend ``name`` checks before it moves anything, without a device (``draw
    --check``): its one-line summary; None for a backend without a check of its own (an arm
    is checked as the simulated one is: source, budgets, sheet, reach)."""
    backend = get_backend(name)
    try:
        return backend.check(scenario, options or BackendOptions())
    except InkarmError as e:
        raise e.within(file=scenario.path) from None


__all__ = ["BACKENDS", "Backend", "BackendOptions", "Session", "backend_names", "check_backend",
           "get_backend", "register", "run_backend"]
