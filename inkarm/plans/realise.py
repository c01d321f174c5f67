"""Realising a plan file: a checked :class:`inkarm.io.planfile.PlanFile` into trajectories.

Each stroke becomes its mean trajectory and K sampled trajectories on the same time grid, with
the movement model of its kind: the LQT (seed 000; :mod:`inkarm.models.lqt`) for Gaussian and
key-point strokes, the Human Line Algorithm (seed 002; :mod:`inkarm.models.human_line`) and
minimum jerk (Flash & Hogan 1985; :mod:`inkarm.models.minjerk`). A Gaussian stroke's samples
come from the LQT trajectory distribution, a human-line stroke's from fresh squiggles; a
minimum-jerk stroke is deterministic and repeats its mean. The means are re-timed into one
:class:`Drawing`, strokes following each other with the plan's pen-up ``pause``.

Randomness: the samples of stroke i come from its ``samples`` stream,
``stroke_seeds(seed, i)["samples"]`` (:func:`inkarm.io.planfile.stroke_seeds`), independent of
the stream that drew its semi-tied covariances when the file was read: the same plan and seed
give the same samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InkarmError, ScenarioError
from inkarm.io.planfile import PlanFile, PlannedStroke, stroke_seeds
from inkarm.models.human_line import human_polyline
from inkarm.models.minjerk import via_points


@dataclass(frozen=True)
class StrokeResult:
    """A realised stroke: its mean trajectory (t from 0) and samples (K, N, D) in [mm] on the
    same time grid."""

    stroke: PlannedStroke
    mean: Trajectory
    samples: np.ndarray


@dataclass(frozen=True)
class PlanResult:
    """A realised plan: per-stroke results and the drawing of the means, re-timed to follow
    each other with the plan's pen-up ``pause`` between strokes."""

    plan: PlanFile
    strokes: tuple[StrokeResult, ...]
    drawing: Drawing

    @property
    def n_samples(self) -> int:
        return int(self.strokes[0].samples.shape[0])

    def stacked_samples(self) -> dict[str, np.ndarray]:
        """Samples of all strokes concatenated along time, in stroke order: ``pos`` (K, N, D)
        with N the total number of samples of the drawing, plus ``t`` (N,) in [s] (the times
        of the drawing, as in mean.csv) and ``stroke`` (N,), the stroke index of each column."""
        return {
            "pos": np.concatenate([s.samples for s in self.strokes], axis=1),
            "t": np.concatenate([s.t for s in self.drawing.strokes]),
            "stroke": np.concatenate([np.full(s.mean.n, i) for i, s in enumerate(self.strokes)]),
        }


def realise_stroke(stroke: PlannedStroke, samples: int, seed: int) -> StrokeResult:
    """Turn one stroke into its mean trajectory and ``samples`` sampled trajectories, drawn
    from the stroke's ``samples`` stream of the plan ``seed`` (:func:`stroke_seeds`)."""
    dt = stroke.model["dt"]
    stream = stroke_seeds(seed, stroke.index)["samples"]
    if stroke.kind in ("gaussian", "keypoints"):
        from inkarm.models import lqt

        cfg = stroke.lqt_config()
        mean = lqt.solve(stroke.plan, cfg)
        if samples > 0:
            pos = np.asarray(
                lqt.sample(
                    stroke.plan,
                    cfg,
                    k=samples,
                    seed=np.random.default_rng(stream),
                    method=stroke.model["sampling"],
                ),
                dtype=float,
            )
        else:
            pos = np.zeros((0, mean.n, mean.dim))
    elif stroke.kind == "human_line":
        opts = stroke.options
        seeds = [int(x) for x in stream.generate_state(samples + 1)]
        lines = [
            human_polyline(stroke.points, s, opts["squiggle"], opts["px_mm"], opts["duration"], dt)
            for s in seeds
        ]
        mean = lines[0]
        pos = np.array([line.pos for line in lines[1:]]).reshape(samples, mean.n, mean.dim)
    else:
        opts = stroke.options
        mean = via_points(stroke.points, opts["duration"], opts["via_times"], dt)
        pos = np.repeat(mean.pos[None], samples, axis=0)
    return StrokeResult(stroke=stroke, mean=mean, samples=pos)


def realise_plan(plan: PlanFile, samples: int | None = None) -> PlanResult:
    """Realise every stroke of ``plan`` with ``samples`` samples each (default: the file's)."""
    k = plan.samples if samples is None else int(samples)
    if k < 0:
        raise ScenarioError(f"{plan.source}: samples must be >= 0, got {k}")
    results = []
    for stroke in plan.strokes:
        try:
            results.append(realise_stroke(stroke, k, plan.seed))
        except InkarmError as e:
            raise type(e)(f"{plan.source}: strokes[{stroke.index}]: {e}") from None
    drawing = Drawing([r.mean for r in results]).sequential(pause=plan.pause)
    return PlanResult(plan=plan, strokes=tuple(results), drawing=drawing)
