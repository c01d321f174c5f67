"""The ``human_line`` stroke kind: the Human Line Algorithm through ``points`` (seed 002;
:mod:`inkarm.models.human_line`), with the settings ``[human_line]`` (squiggle [px], px_mm
[mm], duration [s] per line). The mean is the polyline of the first seed of the stroke's
``samples`` stream, the K samples those of the next K seeds (fresh squiggles)."""

from __future__ import annotations

import numpy as np

from inkarm.core.trajectory import Trajectory
from inkarm.io.planfile import PlannedStroke, StrokeContext, read_points_stroke
from inkarm.io.plansections import HUMAN_LINE_DEFAULTS, read_options
from inkarm.io.toml import TomlReader
from inkarm.models import human_line
from inkarm.models.human_line import check_polyline, human_polylines, step_count


class HumanLine:
    """Points ``points = [[x, y], ...]`` (at least 2) and the ``human_line`` settings."""

    keys = ("points",)
    settings = HUMAN_LINE_DEFAULTS

    def read_settings(self, rd: TomlReader, table: dict, key: str, inherited: dict) -> dict:
        return read_options(rd, "human_line", table, key, inherited)

    def parse(self, rd: TomlReader, stroke: dict, key: str,
              context: StrokeContext) -> PlannedStroke:
        return read_points_stroke(rd, stroke, key, context)

    def size(self, stroke: PlannedStroke, samples: int) -> tuple[int, float]:
        opts, dt = stroke.options, stroke.model["dt"]
        lines = stroke.points.shape[0] - 1
        check_polyline(lines, opts["squiggle"], opts["px_mm"], opts["duration"], dt)
        n = step_count(lines, opts["duration"], dt)
        return n, polylines_bytes(samples + 1, lines, n, stroke.dim, opts["duration"], dt)

    def seconds(self, stroke: PlannedStroke, samples: int) -> list[tuple[float, str, object, str]]:
        opts, dt, where = stroke.options, stroke.model["dt"], f"strokes[{stroke.index}]"
        m = stroke.points.shape[0]
        duration = opts["duration"]
        one = human_line.polylines_seconds(1, m - 1, duration, dt)
        line = f"{m - 1} line{'' if m == 2 else 's'} of {duration:g} s / dt {dt:g} s"
        parts = [(one, f"{where}.points", m, f"the human polyline of {where} ({line})")]
        if samples > 0:
            parts.append((human_line.polylines_seconds(samples, m - 1, duration, dt), "samples",
                          samples, f"{samples} sampled human polylines of {where} ({line})"))
        return parts

    def realise(self, stroke: PlannedStroke, samples: int,
                stream: np.random.SeedSequence) -> tuple[Trajectory, np.ndarray]:
        opts = stroke.options  # polyline j from seed j: the mean, then the samples
        seeds = [int(x) for x in stream.generate_state(samples + 1)]
        t, pos, vel = human_polylines(stroke.points, seeds, opts["squiggle"], opts["px_mm"],
                                      opts["duration"], stroke.model["dt"])
        mean = Trajectory(t=t, pos=pos[0].copy(), vel=vel[0].copy())
        del vel
        return mean, pos[1:]


def polylines_bytes(count: int, lines: int, n: int, dim: int, duration: float,
                    dt: float) -> float:
    """Peak bytes of :func:`human_polylines` for ``count`` polylines of N = ``n`` samples:
    positions and velocities 16 count N D, their squiggles (at most 9 a line) and the
    temporaries of one block of lines, about 8 arrays of (block, D)."""
    per_line = max(human_line.ARC_TABLE, step_count(1, duration, dt))
    block = min(count, max(1, human_line._BLOCK // per_line)) * per_line
    return 8.0 * (count * n * 2 * dim + n + 9 * count * lines + 8 * block * dim)
