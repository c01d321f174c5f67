"""The ``minjerk`` stroke kind: the minimum-jerk path through via-points (Flash & Hogan 1985;
:mod:`inkarm.models.minjerk_spline`), with the settings ``[minjerk]`` (duration [s], via_times
[s]: one per via-point, default jerk-optimal). Deterministic: its samples repeat the mean."""

from __future__ import annotations

import numpy as np

from inkarm.core import budget
from inkarm.core.trajectory import Trajectory
from inkarm.io.planfile import PlannedStroke, StrokeContext, read_points_stroke
from inkarm.io.plansections import MINJERK_DEFAULTS, read_options
from inkarm.io.toml import TomlReader
from inkarm.models.human_line import step_count
from inkarm.models.minjerk_spline import spline_seconds, via_points


class MinJerk:
    """Points ``points = [[x, y], ...]`` (start, via-points, end) and the ``minjerk``
    settings."""

    keys = ("points",)
    settings = MINJERK_DEFAULTS

    def read_settings(self, rd: TomlReader, table: dict, key: str, inherited: dict) -> dict:
        return read_options(rd, "minjerk", table, key, inherited)

    def parse(self, rd: TomlReader, stroke: dict, key: str,
              context: StrokeContext) -> PlannedStroke:
        planned = read_points_stroke(rd, stroke, key, context)
        via_times, points = planned.options["via_times"], planned.points
        if via_times is not None:
            n_via = points.shape[0] - 2
            if via_times.shape[0] != n_via:
                raise rd.error(
                    f"{key}.minjerk.via_times",
                    f"expected {n_via} times for the {n_via} via-points, got {via_times.shape[0]}",
                )
        return planned

    def size(self, stroke: PlannedStroke, samples: int) -> tuple[int, float]:
        """(N, peak bytes): its dense linear system, the mean and the repeated samples."""
        opts, dt, dim = stroke.options, stroke.model["dt"], stroke.dim
        lines = stroke.points.shape[0] - 1
        n = step_count(1, opts["duration"], dt)
        budget.require(
            n, budget.STEPS,
            f"time steps of the minimum-jerk stroke (duration {opts['duration']:g} s / dt {dt:g} s)",
            key="dt", value=dt,
        )
        return n, (8.0 * 3 * (6 * lines) ** 2 + 8.0 * 3 * n * (1 + 2 * dim)
                   + 8.0 * samples * n * dim)

    def seconds(self, stroke: PlannedStroke, samples: int) -> list[tuple[float, str, object, str]]:
        m, where = stroke.points.shape[0], f"strokes[{stroke.index}]"
        search = stroke.options["via_times"] is None and m >= 4
        hint = "; give via_times to skip the via-time search" if search else ""
        return [(spline_seconds(m, search), f"{where}.points", m,
                 f"the minimum-jerk path of {where} through {m} points{hint}")]

    def realise(self, stroke: PlannedStroke, samples: int,
                stream: np.random.SeedSequence) -> tuple[Trajectory, np.ndarray]:
        opts = stroke.options
        mean = via_points(stroke.points, opts["duration"], opts["via_times"], stroke.model["dt"])
        return mean, np.repeat(mean.pos[None], samples, axis=0)
