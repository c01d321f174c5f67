"""Where a G-code job's pen is when, and how fast, on the emulator's planner: the data of
``inkarm preview``.

The job runs on :func:`~inkarm.hardware.plotter.timing.simulate` (the emulator's own machine,
kept fed as a character-counting sender keeps it, advanced event by event), which samples the
position every few milliseconds of machine time (``machine.MAX_SUBSTEP_S``); each sample is
given to the line being executed (the first line whose motion ends at or after it), and a
sample belongs to a drawing move when that line's motion mode is a feed (G1, G2, G3), to a
travel when it is a rapid (G0): the pen is down on feed moves in the files vpype-gcode,
Inkscape and inkarm write. The total time is the schedule's, so it equals
:func:`~inkarm.hardware.plotter.timing.estimate_seconds` of the same lines and settings.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.hardware.plotter.gcode_file import GcodeJob
from inkarm.hardware.plotter.settings import DEFAULT_SETTINGS
from inkarm.hardware.plotter.timing import simulate

GRID_S = 0.01  # the timeline's sample period [s, machine]
MAX_POINTS = 200_000  # (a coarser grid for longer jobs)


@dataclass(frozen=True, eq=False)
class Timeline:
    """A job's planned run.

    Attributes:
        seconds: Machine time from the first line to idle [s].
        t: Sample times [s] (n,), evenly spaced (``GRID_S``, coarser past ``MAX_POINTS``).
        xyz: Positions [mm] (n, 3), the file's coordinates.
        speed: Speed in the page's plane (X, Y) [mm/s] (n,) over the step that ends at each
            sample (0 for the first); a pen lifted or lowered on Z does not count.
        drawing: Whether each sample's line is a feed move (pen down) (n,).
        line: The file's line number of each sample (n,): the line executed at the middle
            of the step that ends at the sample.
        travel_mm: The machine's X and Y travel [mm] (``$130``, ``$131``).
    """

    seconds: float
    t: np.ndarray
    xyz: np.ndarray
    speed: np.ndarray
    drawing: np.ndarray
    line: np.ndarray
    travel_mm: tuple[float, float]

    @property
    def drawing_s(self) -> float:
        """Time spent on pen-down (feed) moves [s]."""
        dt = np.diff(self.t, prepend=self.t[:1])
        return float(dt[self.drawing].sum())


def job_timeline(job: GcodeJob, settings: dict[int, float] | None = None) -> Timeline:
    """The planned run of ``job`` with ``settings`` (``$`` settings over the emulator's
    defaults) from machine zero without offsets (module docstring)."""
    full = {**DEFAULT_SETTINGS, **(settings or {})}
    plan = simulate(job.lines, full, samples=True)
    samples = plan.samples if plan.samples is not None and len(plan.samples) else \
        np.zeros((1, 5))
    t_raw = samples[:, 0]
    # A uniform grid: the trace's steps are of uneven length (down to a microsecond at a
    # block's end) and its positions whole motor steps, so speeds from its own steps jump.
    n = int(min(max(plan.seconds / GRID_S, 2), MAX_POINTS))
    t = np.linspace(0.0, max(plan.seconds, float(t_raw[-1])), n)
    xyz = np.column_stack([np.interp(t, t_raw, samples[:, k]) for k in (1, 2, 3)])
    speed = np.concatenate(([0.0], np.linalg.norm(np.diff(xyz[:, :2], axis=0), axis=1)
                            / max(float(t[1] - t[0]), 1e-12)))
    # each sample's step (the one its speed is over) belongs to the line at its midpoint
    middle = t - 0.5 * (t[1] - t[0])
    index = np.clip(np.searchsorted(plan.line_end_s, middle, side="left"), 0,
                    len(job.lines) - 1)
    drawing = np.asarray(job.drawing, dtype=bool)[index] if job.drawing else \
        np.zeros(len(t), dtype=bool)
    line = np.asarray(job.numbers, dtype=int)[index]
    return Timeline(plan.seconds, t, xyz, speed, drawing, line,
                    (float(full[130]), float(full[131])))


__all__ = ["Timeline", "job_timeline"]
