"""Plan files: motor plans written in TOML, read with :mod:`tomllib`, checked key by key.

A plan file lists the pen-down strokes of a drawing, each a sequence of Gaussian targets
(seed 000), key-points (GI eq. 6-7), a Human Line polyline (seed 002) or minimum-jerk
via-points (Flash & Hogan), together with the parameters of the model that turns it into a
trajectory. Lengths in [mm], covariances in [mm^2], times in [s], angles in [deg].
Array indices in error messages count from 0, as in ``strokes[1].targets[2].cov``.

Schema (every key optional unless marked required)::

    title   = "Letter A"     # free text
    seed    = 0              # integer >= 0: seeds sampling, semi-tied spreads, human lines
    samples = 0              # integer 0..10000: trajectories to sample per stroke
    pause   = 0.5            # pen-up time between strokes [s], 0..3600
    cov     = 25.0           # default target covariance (forms below); not with [semi_tied]

    [model]                  # LQT settings of every stroke (seed 000; inkarm.models.lqt)
    order = 4                # integrator chain order, integer 1..7
    dt = 0.01                # time step [s]; also the sampling step of every stroke kind
    d = 5.0                  # maximum displacement [mm], sets R = I / (omega^n d)^2 ...
    r = 1e-9                 # ... or the raw control weight: give one of d, r (default d = 5)
    discretisation = "euler" # or "zoh"
    end_at_rest = true       # zero derivatives at the last step
    segment_time = 0.5       # time per target T_s [s] (local isochrony); between key-points
    sampling = "exact"       # method of inkarm.models.lqt.sample: "exact" or "eigen" (eq. 16-17)
    solver = "auto"          # LQT solver: "auto", "cholesky", "augmented" or "batch"

    [semi_tied]              # covariances of targets without their own (seed 000 eq. 22)
    H = [[1.0, 0.5], [0.0, 1.0]]  # D x D oblique basis written row by row: its columns are
                             # the basis vectors (default I); as a handstyle's basis
    h = 16.0                 # required: magnitude [mm^2], Sigma_i = h_i H H^T
    rho = 0.0                # variance of h_i ~ N(h, rho), >= 0 (drawn with the plan seed)

    [human_line]             # Human Line Algorithm settings (seed 002 ch. 3)
    squiggle = 5.0           # largest normal displacement of a control point [px]
    px_mm = 0.0847           # size of one pixel [mm] (default 25.4/300: 300 dpi)
    duration = 2.0           # time per line [s]

    [minjerk]                # minimum-jerk settings (Flash & Hogan 1985)
    duration = 1.0           # movement time [s]
    via_times = [0.4]        # passage time of each via-point [s]; default: jerk-optimal

    [[strokes]]              # required, one table per stroke, in drawing order
    name = "left leg"        # free text
    kind = "gaussian"        # "gaussian" (default), "keypoints", "human_line", "minjerk"
    targets = [              # gaussian, keypoints (required): inline tables with
      { mean = [0.0, 0.0], cov = 9.0 },                    # mean [mm] (required) and
      { mean = [20.0, 60.0], std = [8.0, 2.0], angle = 30 },  # cov, or std [+ angle]
      { mean = [40.0, 0.0] },                              # or none: see precedence
    ]
    points = [[0.0, 0.0], [60.0, 0.0]]  # human_line, minjerk (required): at least 2 points
    cov = 9.0                # default covariance of this stroke's targets
    model = { d = 2.0 }      # per-stroke overrides, merged over the top-level tables;
    semi_tied = { h = 4.0 }  # setting one of d, r in a stroke replaces the inherited other
    human_line = { squiggle = 3.0 }
    minjerk = { duration = 0.8 }

Ranges (the models' safe arithmetic, see :mod:`inkarm.io.plansections`): coordinates within
+-1e6 mm, std in [1e-6, 1e6] mm, covariance variances (eigenvalues) in [1e-12, 1e12] mm^2 with
condition number <= 1e12, dt in [1e-4, 1] s, d in [1e-6, 1e6] mm, r in [1e-40, 1e40],
segment_time, durations, via times and pause up to 3600 s. Budgets (:mod:`inkarm.core.budget`):
``samples`` at most INKARM_MAX_SAMPLES (10000); when realised, each stroke's time steps at most
INKARM_MAX_STEPS and the plan's memory at most INKARM_MAX_MEMORY_MB
(:func:`inkarm.plans.realise.realise_plan`).

Covariance forms: a number (variance, spherical), a list of D variances (diagonal) or a D x D
symmetric positive definite matrix; or ``std``: a standard deviation [mm] or a list of D of
them, rotated by ``angle`` [deg, counter-clockwise] in 2-D, Sigma = R diag(std^2) R^T.
A target without ``cov``/``std`` takes, in this order: the stroke's ``cov`` or ``semi_tied``
(not both), the top-level ``cov`` or ``[semi_tied]`` (not both), and for key-points the
identity (GI eq. 7); otherwise it is an error. All targets of a plan have the same D (2 or 3).

Realising: :func:`load_plan` and :func:`parse_plan` give a checked :class:`PlanFile` (targets,
covariances, settings); :func:`inkarm.plans.realise.realise_plan` turns it into trajectories.
A Gaussian stroke's samples come from the LQT trajectory distribution, a human-line stroke's
from fresh squiggles; a minimum-jerk stroke is deterministic and repeats its mean.

Randomness: stroke i of a plan with seed s has its own streams, children of
``numpy.random.SeedSequence([s, i])`` (:func:`stroke_seeds`): one for the semi-tied
magnitudes h_i, one for the samples (LQT draws, human lines). They are independent of each
other and of every other stroke's, and the same seed gives the same plan and samples.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from inkarm.core import budget
from inkarm.core.plan import StrokePlan
from inkarm.io.plansections import (
    HUMAN_LINE_DEFAULTS,
    MAX_TIME,
    MINJERK_DEFAULTS,
    MODEL_DEFAULTS,
    in_range,
    read_model,
    read_options,
    read_points,
    read_semi_tied,
    read_targets,
)
from inkarm.io.toml import TomlReader, load_toml

KINDS = ("gaussian", "keypoints", "human_line", "minjerk")
TOP_KEYS = (
    "title",
    "seed",
    "samples",
    "pause",
    "cov",
    "model",
    "semi_tied",
    "human_line",
    "minjerk",
    "strokes",
)
STROKE_KEYS = (
    "name",
    "kind",
    "targets",
    "points",
    "cov",
    "model",
    "semi_tied",
    "human_line",
    "minjerk",
)


@dataclass(frozen=True)
class PlannedStroke:
    """One stroke of a plan file, checked and ready to realise.

    Attributes:
        index: Position in the file's ``strokes`` array.
        name: The stroke's name ("" when not given).
        kind: One of :data:`KINDS`.
        model: The merged ``[model]`` settings (LQT fields, segment_time, sampling).
        plan: The Gaussian targets (kinds gaussian, keypoints), else None.
        points: The points in [mm], (m, D) (kinds human_line, minjerk), else None.
        options: The merged ``[human_line]`` or ``[minjerk]`` settings of those kinds.
    """

    index: int
    name: str
    kind: str
    model: dict
    plan: StrokePlan | None = None
    points: np.ndarray | None = None
    options: dict = field(default_factory=dict)

    @property
    def dim(self) -> int:
        return self.plan.dim if self.plan is not None else int(self.points.shape[1])

    def lqt_config(self):
        """The :class:`inkarm.models.lqt.LQTConfig` of a Gaussian or key-point stroke."""
        from inkarm.models.lqt import LQTConfig

        keys = ("order", "dt", "d", "r", "discretisation", "end_at_rest", "solver")
        return LQTConfig(**{k: self.model[k] for k in keys})


@dataclass(frozen=True)
class PlanFile:
    """A parsed plan file: its strokes plus the run settings (seed, samples, pause)."""

    source: str
    title: str
    seed: int
    samples: int
    pause: float
    strokes: tuple[PlannedStroke, ...]

    @property
    def dim(self) -> int:
        return self.strokes[0].dim


STREAMS = ("covariances", "samples")
"""The random streams of a stroke, in the order they are spawned (see the module docstring)."""


def stroke_seeds(seed: int, index: int) -> dict[str, np.random.SeedSequence]:
    """The independent seed sequences of stroke ``index`` of a plan seeded with ``seed``, by
    purpose (:data:`STREAMS`): children of ``SeedSequence([seed, index])``."""
    return dict(zip(STREAMS, np.random.SeedSequence([seed, index]).spawn(len(STREAMS))))


# -- reading a plan ----------------------------------------------------------------------------


def _stroke(rd: TomlReader, raw, index: int, top: dict, seed: int) -> PlannedStroke:
    key = f"strokes[{index}]"
    stroke = rd.table(raw, key)
    rd.keys(stroke, STROKE_KEYS, key)
    kind = rd.choice(stroke.get("kind", "gaussian"), f"{key}.kind", KINDS)
    name = rd.text(stroke.get("name", ""), f"{key}.name")
    model = read_model(
        rd, rd.table(stroke.get("model", {}), f"{key}.model"), f"{key}.model", top["model"]
    )
    for section in ("human_line", "minjerk"):
        if section in stroke and kind != section:
            raise rd.error(
                f"{key}.{section}", f"only applies to {section} strokes, this one is {kind}"
            )
    if kind in ("human_line", "minjerk"):
        for name_ in ("targets", "cov", "semi_tied"):
            if name_ in stroke:
                raise rd.error(f"{key}.{name_}", f"not used by a {kind} stroke (it takes points)")
        if "points" not in stroke:
            raise rd.error(f"{key}.points", f"required for a {kind} stroke")
        points = read_points(rd, stroke["points"], f"{key}.points")
        options = read_options(
            rd, kind, rd.table(stroke.get(kind, {}), f"{key}.{kind}"), f"{key}.{kind}", top[kind]
        )
        if kind == "minjerk" and options["via_times"] is not None:
            n_via = points.shape[0] - 2
            if options["via_times"].shape[0] != n_via:
                raise rd.error(
                    f"{key}.minjerk.via_times",
                    f"expected {n_via} times for the {n_via} via-points, got {options['via_times'].shape[0]}",
                )
        return PlannedStroke(index, name, kind, model, points=points, options=options)
    if "points" in stroke:
        raise rd.error(f"{key}.points", f"not used by a {kind} stroke (it takes targets)")
    if "cov" in stroke and "semi_tied" in stroke:
        raise rd.error(key, "give one of cov and semi_tied, not both")
    if "cov" in stroke:
        cov_source = ("cov", stroke["cov"], f"{key}.cov")
    elif "semi_tied" in stroke:
        table = rd.table(stroke["semi_tied"], f"{key}.semi_tied")
        cov_source = (
            "semi_tied",
            read_semi_tied(rd, table, f"{key}.semi_tied", top["semi_tied"]),
            f"{key}.semi_tied",
        )
    else:
        cov_source = top["cov_source"]
    stream = stroke_seeds(seed, index)["covariances"]
    plan = read_targets(rd, stroke, key, kind, cov_source, stream, model["segment_time"])
    return PlannedStroke(index, name, kind, model, plan=plan)


def parse_plan(data: dict, source: str = "plan", seed: int | None = None) -> PlanFile:
    """Check parsed TOML ``data`` against the schema and build a :class:`PlanFile`.

    ``source`` names the file in error messages; ``seed`` overrides the file's seed.
    Raises :class:`ScenarioError` naming the file and the key at fault.
    """
    rd = TomlReader(source)
    rd.keys(data, TOP_KEYS, "")
    title = rd.text(data.get("title", ""), "title")
    file_seed = rd.integer(data.get("seed", 0), "seed", 0)
    seed = file_seed if seed is None else int(seed)
    samples = rd.integer(data.get("samples", 0), "samples", 0)
    budget.require(samples, budget.SAMPLES, "samples per stroke", key="samples", value=samples,
                   file=source)
    pause = in_range(rd, rd.number(data.get("pause", 0.5), "pause", 0.0), "pause", 0.0,
                     MAX_TIME, "s")
    model = read_model(rd, rd.table(data.get("model", {}), "model"), "model", MODEL_DEFAULTS)
    semi_tied = None
    if "semi_tied" in data:
        semi_tied = read_semi_tied(rd, rd.table(data["semi_tied"], "semi_tied"), "semi_tied", None)
    if "cov" in data and semi_tied is not None:
        raise rd.error("", "give one of the top-level cov and [semi_tied], not both")
    cov_source = None
    if "cov" in data:
        cov_source = ("cov", data["cov"], "cov")
    elif semi_tied is not None:
        cov_source = ("semi_tied", semi_tied, "semi_tied")
    top = {
        "model": model,
        "semi_tied": semi_tied,
        "cov_source": cov_source,
        "human_line": read_options(
            rd,
            "human_line",
            rd.table(data.get("human_line", {}), "human_line"),
            "human_line",
            HUMAN_LINE_DEFAULTS,
        ),
        "minjerk": read_options(
            rd, "minjerk", rd.table(data.get("minjerk", {}), "minjerk"), "minjerk", MINJERK_DEFAULTS
        ),
    }
    raw_strokes = data.get("strokes")
    if raw_strokes is None:
        raise rd.error("strokes", "required: at least one [[strokes]] table")
    if not isinstance(raw_strokes, list) or not raw_strokes:
        raise rd.error("strokes", "expected at least one [[strokes]] table")
    strokes = tuple(_stroke(rd, raw, i, top, seed) for i, raw in enumerate(raw_strokes))
    dims = [s.dim for s in strokes]
    for i, d in enumerate(dims):
        if d != dims[0]:
            raise rd.error(f"strokes[{i}]", f"is {d}-D but strokes[0] is {dims[0]}-D")
    return PlanFile(
        source=source, title=title, seed=seed, samples=samples, pause=pause, strokes=strokes
    )


def load_plan(path: str | Path, seed: int | None = None) -> PlanFile:
    """Read and check the plan file at ``path`` (see the module docstring for the schema)."""
    data = load_toml(path, "plan file")
    return parse_plan(data, source=str(path), seed=seed)
