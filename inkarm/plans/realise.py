"""Realising a plan file: a checked :class:`inkarm.io.planfile.PlanFile` into trajectories.

Each stroke becomes its mean trajectory and K sampled trajectories on the same time grid, with
the movement model of its kind: the LQT (seed 000; :mod:`inkarm.models.lqt`) for Gaussian and
key-point strokes, the Human Line Algorithm (seed 002; :mod:`inkarm.models.human_line`) and
minimum jerk (Flash & Hogan 1985; :mod:`inkarm.models.minjerk_spline`). A Gaussian stroke's samples
come from the LQT trajectory distribution, a human-line stroke's from fresh squiggles; a
minimum-jerk stroke is deterministic and repeats its mean. The means are re-timed into one
:class:`Drawing`, strokes following each other with the plan's pen-up ``pause``. Each kind is
one module of :mod:`inkarm.plans.kinds` (or a plug-in's), found through the stroke-kind registry
(:func:`inkarm.io.planfile.stroke_kind`); this module only asks it.

Budgets (:mod:`inkarm.core.budget`), all before any work: the samples per stroke against
INKARM_MAX_SAMPLES, each stroke's time steps against INKARM_MAX_STEPS, the memory of the whole
plan against INKARM_MAX_MEMORY_MB (:func:`plan_bytes`) and its time against
INKARM_MAX_COMPUTE_S (:func:`stroke_seconds`: the O((N D)^3) eigen draws and dense oracle of
LQT strokes, the K + 1 human polylines, the minimum-jerk systems); the error names the file
and the input that costs most (``strokes[i].model.sampling``, ``samples``, ...).

Randomness: the samples of stroke i come from its ``samples`` stream,
``stroke_seeds(seed, i)["samples"]`` (:func:`inkarm.io.planfile.stroke_seeds`), independent of
the stream that drew its semi-tied covariances when the file was read: the same plan and seed
give the same samples.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from inkarm.core import budget
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InkarmError, InputError, ScenarioError
from inkarm.io.planfile import PlanFile, PlannedStroke, stroke_kind, stroke_seeds
from inkarm.io.plansections import MODEL_DEFAULTS


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


def stroke_size(stroke: PlannedStroke, samples: int) -> tuple[int, float]:
    """(N, peak bytes) of realising ``stroke`` with K = ``samples`` samples, without doing it:
    N its time steps, checked against INKARM_MAX_STEPS, and the memory its model needs while
    it runs, its results included (see :func:`plan_bytes` for the formulas). (0, 0) for a
    kind that gives no estimate (``size``)."""
    size = getattr(_kind(stroke), "size", None)
    return size(stroke, samples) if size is not None else (0, 0.0)


def stroke_seconds(stroke: PlannedStroke, samples: int) -> list[tuple[float, str, object, str]]:
    """The estimated time of realising ``stroke`` with K = ``samples`` samples, without doing
    it, as its costly parts: (seconds, key, value, what) with the key that names the input
    behind each (``strokes[i].model.sampling``, ``samples``, ``strokes[i].points``, ...).
    Linear-time work (banded LQT solves, exact draws) is left out: the step and memory budgets
    bound it to seconds. The estimates are :mod:`inkarm.models.lqt.cost`'s,
    :func:`inkarm.models.human_line.polylines_seconds` and
    :func:`inkarm.models.minjerk_spline.spline_seconds` (each kind's ``seconds``)."""
    seconds = getattr(_kind(stroke), "seconds", None)
    return list(seconds(stroke, samples)) if seconds is not None else []


def kept_bytes(n: int, samples: int, dim: int) -> float:
    """Bytes of a realised stroke: mean (t, pos, vel) and K sampled paths."""
    return 8.0 * n * (1 + 2 * dim + samples * dim)


def realise_stroke(stroke: PlannedStroke, samples: int, seed: int) -> StrokeResult:
    """Turn one stroke into its mean trajectory and ``samples`` sampled trajectories, drawn
    from the stroke's ``samples`` stream of the plan ``seed`` (:func:`stroke_seeds`)."""
    stream = stroke_seeds(seed, stroke.index)["samples"]
    mean, pos = _kind(stroke).realise(stroke, samples, stream)
    pos = np.asarray(pos, dtype=float)
    if not isinstance(mean, Trajectory) or pos.shape != (samples, mean.n, mean.dim):
        got = type(mean).__name__ if not isinstance(mean, Trajectory) else f"samples {pos.shape}"
        raise InputError(f"stroke kind {stroke.kind!r} realised {got}; expected a Trajectory "
                         f"and samples of shape (K, N, D) = ({samples}, N, D) on its time grid",
                         key="kind", value=stroke.kind)
    return StrokeResult(stroke=stroke, mean=mean, samples=pos)


def _kind(stroke: PlannedStroke):
    return stroke_kind(stroke.kind)


def plan_bytes(sizes: list[tuple[int, float]], samples: int, dim: int) -> float:
    """Estimated peak memory of realising a plan whose strokes have ``sizes`` (N_i, peak_i)
    (:func:`stroke_size`) with K = ``samples``, then stacking its samples: the larger of

        max_i (kept_1 + ... + kept_(i-1) + peak_i)    while stroke i is realised
        kept_1 + ... + kept_m + 8 K D sum_i N_i       the results and the stacked samples

    with kept_i = 8 N_i (1 + 2 D + K D), a realised stroke's mean (t, pos, vel) and samples.
    The peak of a stroke, its results included: LQT :func:`inkarm.models.lqt.cost.solve_bytes`
    + :func:`~inkarm.models.lqt.cost.sample_bytes` + kept_i; human line
    16 (K + 1) N D (the K + 1 polylines' positions and velocities) + 72 (K + 1) L (squiggles of
    L lines) + the temporaries of one block of lines
    (:func:`inkarm.plans.kinds.human_line.polylines_bytes`); minimum
    jerk 24 (6 (m - 1))^2 (its dense linear system) + 24 N (1 + 2 D) + 8 K N D. Within 0.85x
    to 1.6x of the peaks measured with tracemalloc for plans of each kind (test_realise.py).
    """
    kept = [kept_bytes(n, samples, dim) for n, _ in sizes]
    during = max(sum(kept[:i]) + peak for i, (_, peak) in enumerate(sizes))
    after = sum(kept) + 8.0 * samples * dim * sum(n for n, _ in sizes)
    return max(during, after)


def realise_plan(plan: PlanFile, samples: int | None = None) -> PlanResult:
    """Realise every stroke of ``plan`` with ``samples`` samples each (default: the file's).

    Before any work: K against INKARM_MAX_SAMPLES, every stroke's time steps against
    INKARM_MAX_STEPS, the memory of the whole (:func:`plan_bytes`) against
    INKARM_MAX_MEMORY_MB and its time (the sum of :func:`stroke_seconds`) against
    INKARM_MAX_COMPUTE_S (:mod:`inkarm.core.budget`); errors name the file and the stroke, or
    the input that costs most.
    """
    k = plan.samples if samples is None else int(samples)
    key = "samples"
    if k < 0:
        raise ScenarioError(f"expected an integer >= 0, got {k}", file=plan.source, key=key,
                            value=k)
    budget.require(k, budget.SAMPLES, "samples per stroke", key=key, value=k, file=plan.source)
    sizes, bare = [], []  # with K samples, and with none
    for stroke in plan.strokes:
        with _naming(plan, stroke):
            sizes.append(stroke_size(stroke, k))
            bare.append(stroke_size(stroke, 0))
    total = plan_bytes(sizes, k, plan.dim)
    if plan_bytes(bare, 0, plan.dim) <= budget.MEMORY_MB.value * budget.MB:  # the samples
        where = {"key": key, "value": k}
    else:  # the strokes themselves: the biggest one
        where = {"key": f"strokes[{int(np.argmax([peak for _, peak in bare]))}]"}
    budget.require_memory(
        total,
        f"memory of realising the plan ({_count(len(sizes), 'stroke')}, "
        f"{_count(sum(n for n, _ in sizes), 'time step')}, {_count(k, 'sample')} each)",
        file=plan.source, **where,
    )
    require_plan_time(plan, k)
    results = []
    for stroke in plan.strokes:
        with _naming(plan, stroke):
            results.append(realise_stroke(stroke, k, plan.seed))
    drawing = Drawing([r.mean for r in results]).sequential(pause=plan.pause)
    return PlanResult(plan=plan, strokes=tuple(results), drawing=drawing)


def require_plan_time(plan: PlanFile, samples: int) -> None:
    """Refuse ``plan`` with K = ``samples`` when the sum of its strokes' estimated times
    (:func:`stroke_seconds`) exceeds INKARM_MAX_COMPUTE_S, naming the file and the input behind
    the costliest part (``strokes[i].model.sampling``, ``samples``, ``strokes[i].points``)."""
    parts = []
    for stroke in plan.strokes:
        with _naming(plan, stroke):
            parts.extend(stroke_seconds(stroke, samples))
    if not parts:
        return
    seconds, key, value, what = max(parts, key=lambda part: part[0])
    total = sum(part[0] for part in parts)
    if total > seconds:
        what = f"mostly {what}, about {seconds:.3g} s"
    budget.require(
        total, budget.COMPUTE_S,
        f"time of realising the plan ({_count(len(plan.strokes), 'stroke')}, "
        f"{_count(samples, 'sample')} each; {what})",
        key=key, value=value, file=plan.source,
    )


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


@contextmanager
def _naming(plan: PlanFile, stroke: PlannedStroke):
    """Errors of a stroke's model name the plan file and ``strokes[i]``, with the settings as
    the file spells them: ``strokes[i].model.dt``, ``strokes[i].human_line.duration``."""
    try:
        yield
    except InkarmError as e:
        where = f"strokes[{stroke.index}]"
        name = e.key.split(".")[0] if e.key else None
        if name in MODEL_DEFAULTS:
            where += ".model"
        elif name in stroke.options:  # human_line or minjerk settings
            where += f".{stroke.kind}"
        raise e.within(file=plan.source, key=where) from None
