"""A stroke kind: a circle, ``centre`` [mm] and ``radius`` [mm], drawn at a constant speed in
``duration`` [s] (its settings table ``[circle]``: ``duration``, ``turns``)."""

from typing import ClassVar

import numpy as np

from inkarm.core.trajectory import Trajectory
from inkarm.io.planfile import PlannedStroke, read_stroke_settings


class Circle:
    keys = ("centre", "radius")
    settings: ClassVar[dict] = {"duration": 1.0, "turns": 1.0}

    def read_settings(self, rd, table, key, inherited):
        rd.keys(table, tuple(self.settings), key)
        return {**inherited, **{k: rd.number(v, f"{key}.{k}", 0.0, strict=True)
                                for k, v in table.items()}}

    def parse(self, rd, stroke, key, context):
        for name in ("targets", "points", "cov", "semi_tied"):
            if name in stroke:
                raise rd.error(f"{key}.{name}", "not used by a circle stroke")
        if "radius" not in stroke:
            raise rd.error(f"{key}.radius", "required for a circle stroke")
        centre = rd.array(stroke.get("centre", [0.0, 0.0]), f"{key}.centre", 1)
        if centre.shape != (2,):
            raise rd.error(f"{key}.centre", f"expected 2 coordinates, got {centre.shape[0]}")
        radius = rd.number(stroke["radius"], f"{key}.radius", 0.0, strict=True)
        options = {**read_stroke_settings(rd, stroke, key, context), "radius": radius}
        return PlannedStroke(context.index, context.name, context.kind, context.model,
                             points=centre[None], options=options)

    def size(self, stroke, samples):
        n = round(stroke.options["duration"] / stroke.model["dt"]) + 1
        return n, 8.0 * n * 5 * (1 + samples)

    def realise(self, stroke, samples, stream):
        opts = stroke.options
        n = self.size(stroke, 0)[0]
        t = np.linspace(0.0, opts["duration"], n)
        angle = 2 * np.pi * opts["turns"] * t / opts["duration"]
        pos = stroke.points[0] + opts["radius"] * np.column_stack([np.cos(angle), np.sin(angle)])
        mean = Trajectory(t=t, pos=pos)
        return mean, np.repeat(pos[None], samples, axis=0)
