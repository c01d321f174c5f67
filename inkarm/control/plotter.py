"""The executor for Cartesian plants whose servo loop is their firmware (GRBL pen plotters).

The pen path is the arms' (:func:`inkarm.control.sequencing.sequence_pen`, pen depth 0: the
pen mechanism, not the reference, presses it): the descent becomes a pen-down command, each
draw row a position goal with its speed as feed-forward (joints x, y in [m]), the lift a
pen-up command, and a travel one rapid move to its end (the firmware plans the move). The
plant streams ahead of the machine, so measurements arrive after the commands: the log has
one row per status report (GRBL: <= 5 Hz), the plant's measured position as the tip; the
reference of a row is where the plant's planner model says the pen should be at that time
(:meth:`StreamingPlant.schedule`), and its phase and stroke those of the command then under
way. The :class:`~inkarm.core.log.DrawLog` is the arms' so :mod:`inkarm.analysis.metrics`
measures plotters unchanged.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from inkarm.control.config import LoopConfig
from inkarm.control.sequencing import PenPath, sequence_pen
from inkarm.core.log import APPROACH, DESCEND, DRAW, LIFT, TRAVEL, DrawLog
from inkarm.core.plant import Command, PenCommand, Plant, PlantState, PositionCommand
from inkarm.core.trajectory import Drawing

MIN_STEP_MM = 1e-3  # draw rows closer than this to the last goal are not sent


class StreamingPlant(Plant, Protocol):
    """A plant that runs ahead of its commands (``GrblPlant``)."""

    @property
    def failure(self) -> str:
        """Why the device stopped the job; empty while healthy."""
        ...

    def finish(self, progress=None) -> bool:
        """Wait until every command has been executed; False when the job failed."""
        ...

    def readings(self) -> list[PlantState]:
        """The states measured while it executed, times from its first command [s]."""
        ...

    def schedule(self) -> tuple[np.ndarray, Any]:
        """Per command, the time [s] it should end; and a plan with ``samples`` rows
        (t [s], x, y, z [mm], pen touching)."""
        ...


def plotter_commands(path: PenPath, dt: float) -> tuple[list[Command], list[int], list[int]]:
    """The commands for ``path`` (see the module docstring), the pen-path row each one ends
    at, and its phase (APPROACH for the first rapid move)."""
    commands: list[Command] = []
    rows: list[int] = []
    phases: list[int] = []
    xy = path.page_mm[:, :2] / 1000.0  # page [mm] -> joints [m]

    def add(command: Command, row: int, phase: int) -> None:
        commands.append(command)
        rows.append(row)
        phases.append(phase)

    add(PositionCommand(q=xy[0].copy()), 0, APPROACH)
    last = xy[0]
    n = len(path)
    for k in range(n):
        phase = int(path.phase[k])
        first = k == 0 or path.phase[k - 1] != phase
        final = k == n - 1 or path.phase[k + 1] != phase
        if phase == DESCEND and first:
            add(PenCommand(down=True), k, DESCEND)
        elif phase == LIFT and first:
            add(PenCommand(down=False), k, LIFT)
        elif phase == TRAVEL and final:
            add(PositionCommand(q=xy[k].copy()), k, TRAVEL)
            last = xy[k]
        elif phase == DRAW and np.linalg.norm(xy[k] - last) * 1000.0 >= MIN_STEP_MM:
            add(PositionCommand(q=xy[k].copy(), qd=(xy[k] - last) / dt), k, DRAW)
            last = xy[k]
    return commands, rows, phases


def run_plotter(drawing: Drawing, plant: StreamingPlant, config: LoopConfig,
                progress: Callable[[float, str], None] | None = None) -> DrawLog:
    """Draw ``drawing`` on ``plant`` with the arms' pen sequencing; the log of what the plant
    measured (see the module docstring). A job the device stopped returns the log so far; the
    caller reads ``plant.failure``."""
    wall0 = time.perf_counter()
    path = sequence_pen(drawing, config, 0.0, plant.dt)
    commands, rows, phases = plotter_commands(path, plant.dt)
    for i, command in enumerate(commands):
        plant.command(command)
        plant.step()
        if plant.failure:
            break
        if progress is not None and i % 50 == 0:
            progress(0.5 * i / len(commands), "stream")
    if not plant.failure:
        plant.finish(progress)
    log = plotter_log(path, rows, phases, plant.readings(), plant.schedule(), config)
    log.wall_s = time.perf_counter() - wall0
    return log


def plotter_log(path: PenPath, rows: list[int], phases: list[int],
                readings: list[PlantState], schedule, config: LoopConfig) -> DrawLog:
    """One log row per reading: measured tip, and the reference, phase and stroke the plan
    has at its time."""
    ends, plan = schedule
    ends = np.asarray(ends, dtype=float)
    k = len(readings)
    log = DrawLog.empty(k, 2)
    if k == 0:
        return log
    t = np.array([r.time for r in readings])
    log.time[:] = t
    log.q[:] = np.array([r.q[:2] for r in readings])
    log.qd[1:] = np.diff(log.q, axis=0) / np.maximum(np.diff(t), 1e-9)[:, None]
    tips = np.array([r.tip_mm if r.tip_mm is not None else np.full(3, np.nan)
                     for r in readings])
    tips[:, :2] = log.q * 1000.0
    tips[np.isnan(tips[:, 2]), 2] = config.hover_mm
    log.tip[:] = tips
    log.force[:] = [r.force if r.force is not None else 0.0 for r in readings]
    samples = plan.samples
    for c in range(2):
        log.reference[:, c] = np.interp(t, samples[:, 0], samples[:, 1 + c])
    # The command under way at t: the first whose planned end is at or after t.
    under_way = np.minimum(np.searchsorted(ends, t, side="left"), len(ends) - 1)
    row = np.asarray(rows)[under_way]
    log.phase[:] = np.asarray(phases, dtype=np.int8)[under_way]
    log.stroke[:] = np.where(log.phase == APPROACH, -1, path.stroke[row])
    log.reference[:, 2] = np.where(log.phase == DRAW, 0.0, path.page_mm[row, 2])
    return log
