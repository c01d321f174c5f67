"""Realising a plan file: a checked :class:`inkarm.io.planfile.PlanFile` into trajectories.

Each stroke becomes its mean trajectory and K sampled trajectories on the same time grid, with
the movement model of its kind: the LQT (seed 000; :mod:`inkarm.models.lqt`) for Gaussian and
key-point strokes, the Human Line Algorithm (seed 002; :mod:`inkarm.models.human_line`) and
minimum jerk (Flash & Hogan 1985; :mod:`inkarm.models.minjerk`). A Gaussian stroke's samples
come from the LQT trajectory distribution, a human-line stroke's from fresh squiggles; a
minimum-jerk stroke is deterministic and repeats its mean. The means are re-timed into one
:class:`Drawing`, strokes following each other with the plan's pen-up ``pause``.

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
from inkarm.errors import InkarmError, ScenarioError
from inkarm.io.planfile import PlanFile, PlannedStroke, stroke_seeds
from inkarm.io.plansections import MODEL_DEFAULTS
from inkarm.models import human_line
from inkarm.models.human_line import check_polyline, human_polylines, step_count
from inkarm.models.minjerk import spline_seconds, via_points


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
    it runs, its results included (see :func:`plan_bytes` for the formulas)."""
    dt, dim = stroke.model["dt"], stroke.dim
    if stroke.kind in ("gaussian", "keypoints"):
        from inkarm.models.lqt import cost
        from inkarm.models.lqt.problem import sizing

        size = sizing(stroke.plan, stroke.lqt_config())
        n = size.n_steps
        model = size.solve_bytes + cost.sample_bytes(
            samples, n, dim, size.method, stroke.model["sampling"]
        )
        return n, model + _kept(n, samples, dim)
    opts = stroke.options
    lines = stroke.points.shape[0] - 1
    if stroke.kind == "human_line":
        check_polyline(lines, opts["squiggle"], opts["px_mm"], opts["duration"], dt)
        n = step_count(lines, opts["duration"], dt)
        return n, _human_line_bytes(samples + 1, lines, n, dim, opts["duration"], dt)
    n = step_count(1, opts["duration"], dt)
    budget.require(
        n, budget.STEPS,
        f"time steps of the minimum-jerk stroke (duration {opts['duration']:g} s / dt {dt:g} s)",
        key="dt", value=dt,
    )
    return n, 8.0 * 3 * (6 * lines) ** 2 + 8.0 * 3 * n * (1 + 2 * dim) + 8.0 * samples * n * dim


def _human_line_bytes(count: int, lines: int, n: int, dim: int, duration: float,
                      dt: float) -> float:
    """Peak bytes of :func:`human_polylines` for ``count`` polylines of N = ``n`` samples:
    positions and velocities 16 count N D, their squiggles (at most 9 a line) and the
    temporaries of one block of lines, about 8 arrays of (block, D)."""
    per_line = max(human_line.ARC_TABLE, step_count(1, duration, dt))
    block = min(count, max(1, human_line._BLOCK // per_line)) * per_line
    return 8.0 * (count * n * 2 * dim + n + 9 * count * lines + 8 * block * dim)


def stroke_seconds(stroke: PlannedStroke, samples: int) -> list[tuple[float, str, object, str]]:
    """The estimated time of realising ``stroke`` with K = ``samples`` samples, without doing
    it, as its costly parts: (seconds, key, value, what) with the key that names the input
    behind each (``strokes[i].model.sampling``, ``samples``, ``strokes[i].points``, ...).
    Linear-time work (banded LQT solves, exact draws) is left out: the step and memory budgets
    bound it to seconds. The estimates are :mod:`inkarm.models.lqt.cost`'s,
    :func:`inkarm.models.human_line.polylines_seconds` and
    :func:`inkarm.models.minjerk.spline_seconds`."""
    dt, dim, i = stroke.model["dt"], stroke.dim, stroke.index
    where = f"strokes[{i}]"
    parts = []
    if stroke.kind in ("gaussian", "keypoints"):
        from inkarm.models.lqt import cost
        from inkarm.models.lqt.problem import sizing

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
    opts = stroke.options
    m = stroke.points.shape[0]
    if stroke.kind == "human_line":
        duration = opts["duration"]
        one = human_line.polylines_seconds(1, m - 1, duration, dt)
        line = f"{m - 1} line{'' if m == 2 else 's'} of {duration:g} s / dt {dt:g} s"
        parts.append((one, f"{where}.points", m, f"the human polyline of {where} ({line})"))
        if samples > 0:
            parts.append((human_line.polylines_seconds(samples, m - 1, duration, dt), "samples",
                          samples, f"{samples} sampled human polylines of {where} ({line})"))
        return parts
    search = opts["via_times"] is None and m >= 4
    hint = "; give via_times to skip the via-time search" if search else ""
    parts.append((spline_seconds(m, search), f"{where}.points", m,
                  f"the minimum-jerk path of {where} through {m} points{hint}"))
    return parts


def _kept(n: int, samples: int, dim: int) -> float:
    """Bytes of a realised stroke: mean (t, pos, vel) and K sampled paths."""
    return 8.0 * n * (1 + 2 * dim + samples * dim)


def realise_stroke(stroke: PlannedStroke, samples: int, seed: int) -> StrokeResult:
    """Turn one stroke into its mean trajectory and ``samples`` sampled trajectories, drawn
    from the stroke's ``samples`` stream of the plan ``seed`` (:func:`stroke_seeds`)."""
    dt = stroke.model["dt"]
    stream = stroke_seeds(seed, stroke.index)["samples"]
    if stroke.kind in ("gaussian", "keypoints"):
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
    elif stroke.kind == "human_line":  # polyline j from seed j: the mean, then the samples
        opts = stroke.options
        seeds = [int(x) for x in stream.generate_state(samples + 1)]
        t, pos, vel = human_polylines(stroke.points, seeds, opts["squiggle"], opts["px_mm"],
                                      opts["duration"], dt)
        mean = Trajectory(t=t, pos=pos[0].copy(), vel=vel[0].copy())
        del vel
        pos = pos[1:]
    else:
        opts = stroke.options
        mean = via_points(stroke.points, opts["duration"], opts["via_times"], dt)
        pos = np.repeat(mean.pos[None], samples, axis=0)
    return StrokeResult(stroke=stroke, mean=mean, samples=pos)


def plan_bytes(sizes: list[tuple[int, float]], samples: int, dim: int) -> float:
    """Estimated peak memory of realising a plan whose strokes have ``sizes`` (N_i, peak_i)
    (:func:`stroke_size`) with K = ``samples``, then stacking its samples: the larger of

        max_i (kept_1 + ... + kept_(i-1) + peak_i)    while stroke i is realised
        kept_1 + ... + kept_m + 8 K D sum_i N_i       the results and the stacked samples

    with kept_i = 8 N_i (1 + 2 D + K D), a realised stroke's mean (t, pos, vel) and samples.
    The peak of a stroke, its results included: LQT :func:`inkarm.models.lqt.cost.solve_bytes`
    + :func:`~inkarm.models.lqt.cost.sample_bytes` + kept_i; human line
    16 (K + 1) N D (the K + 1 polylines' positions and velocities) + 72 (K + 1) L (squiggles of
    L lines) + the temporaries of one block of lines (:func:`_human_line_bytes`); minimum
    jerk 24 (6 (m - 1))^2 (its dense linear system) + 24 N (1 + 2 D) + 8 K N D. Within 0.85x
    to 1.6x of the peaks measured with tracemalloc for plans of each kind (test_realise.py).
    """
    kept = [_kept(n, samples, dim) for n, _ in sizes]
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
