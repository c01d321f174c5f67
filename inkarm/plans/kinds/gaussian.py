"""The ``gaussian`` stroke kind: Gaussian targets, each held for ``segment_time``, tracked by
the LQT (seed 000; :mod:`inkarm.models.lqt`). Its samples come from the LQT trajectory
distribution, drawn from the stroke's ``samples`` stream."""

from __future__ import annotations

import numpy as np

from inkarm.core.trajectory import Trajectory
from inkarm.io.planfile import PlannedStroke, StrokeContext, read_targets_stroke
from inkarm.io.toml import TomlReader
from inkarm.plans.realise import kept_bytes


class Gaussian:
    """Targets ``targets = [{ mean, cov | std [+ angle] }, ...]`` with the stroke's or the
    plan's ``cov`` or ``semi_tied`` (:mod:`inkarm.io.planfile`)."""

    keys = ("targets", "cov", "semi_tied")
    settings = None

    def parse(self, rd: TomlReader, stroke: dict, key: str,
              context: StrokeContext) -> PlannedStroke:
        return read_targets_stroke(rd, stroke, key, context)

    def size(self, stroke: PlannedStroke, samples: int) -> tuple[int, float]:
        """(N, peak bytes): the LQT's solve and draws (:mod:`inkarm.models.lqt.cost`) and the
        results."""
        from inkarm.models.lqt import cost
        from inkarm.models.lqt.problem import sizing

        dim = stroke.dim
        size = sizing(stroke.plan, stroke.lqt_config())
        n = size.n_steps
        model = size.solve_bytes + cost.sample_bytes(
            samples, n, dim, size.method, stroke.model["sampling"]
        )
        return n, model + kept_bytes(n, samples, dim)

    def seconds(self, stroke: PlannedStroke, samples: int) -> list[tuple[float, str, object, str]]:
        """The O((N D)^3) parts: the dense oracle (``solver = "batch"``) and eigen draws."""
        from inkarm.models.lqt import cost
        from inkarm.models.lqt.problem import sizing

        dim, where = stroke.dim, f"strokes[{stroke.index}]"
        parts = []
        n = sizing(stroke.plan, stroke.lqt_config()).n_steps
        size = n * dim
        if stroke.model["solver"] == "batch":
            what = (f"the dense oracle of {where} ({n} steps x {dim}-D: O((N D)^3) with "
                    f"N D = {size}; solver = \"auto\" is linear in N)")
            parts.append((cost.batch_seconds(n, dim), f"{where}.model.solver", "batch", what))
        if samples > 0 and stroke.model["sampling"] == "eigen":
            what = (f"the eigen draws of {where} (eigenpairs of a dense {size} x {size} matrix, "
                    f"O((N D)^3); sampling = \"exact\", the default, draws in O(N))")
            parts.append((cost.eigen_seconds(n, dim, 9), f"{where}.model.sampling", "eigen",
                          what))
        return parts

    def realise(self, stroke: PlannedStroke, samples: int,
                stream: np.random.SeedSequence) -> tuple[Trajectory, np.ndarray]:
        from inkarm.models import lqt

        model = lqt.LQT(stroke.plan, stroke.lqt_config())  # factorised once, for both
        mean = model.mean()
        if samples > 0:
            pos = np.asarray(
                model.sample(
                    samples, seed=np.random.default_rng(stream), method=stroke.model["sampling"]
                ),
                dtype=float,
            )
        else:
            pos = np.zeros((0, mean.n, mean.dim))
        return mean, pos
