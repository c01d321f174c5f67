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
    kind = "gaussian"        # "gaussian" (default), "keypoints", "human_line", "minjerk",
                             # an installed plug-in's, or "package.module:Class" (see below)
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

Stroke kinds: each kind is one object registered in the stroke-kind registry
(``inkarm.plugins.registry("stroke_kind")``; the :class:`StrokeKind` protocol) that reads its
stroke table and realises it: the built-ins are one module each in :mod:`inkarm.plans.kinds`;
an installed package adds one with the entry point ``stroke_kind.<name>`` of the group
``inkarm.plugins``, and a plan may name one as ``kind = "package.module:Class"``. A kind with
settings takes a table named after it, at the top (``[<name>]``) and in a stroke
(``<name> = {...}``), merged over its defaults as ``[human_line]`` is.

Randomness: stroke i of a plan with seed s has its own streams, children of
``numpy.random.SeedSequence([s, i])`` (:func:`stroke_seeds`): one for the semi-tied
magnitudes h_i, one for the samples (LQT draws, human lines). They are independent of each
other and of every other stroke's, and the same seed gives the same plan and samples.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from inkarm.core import budget
from inkarm.core.plan import StrokePlan
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InkarmError, InputError
from inkarm.io.plansections import (
    MAX_TIME,
    MODEL_DEFAULTS,
    in_range,
    read_model,
    read_points,
    read_semi_tied,
    read_targets,
)
from inkarm.io.toml import TomlReader, load_toml
from inkarm.plugins import registry

KINDS = ("gaussian", "keypoints", "human_line", "minjerk")
"""The built-in stroke kinds (:mod:`inkarm.plans.kinds`); :func:`stroke_kinds` adds plug-ins'."""
STROKE_KINDS = registry("stroke_kind")
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
        kind: The stroke kind's name (:func:`stroke_kinds`, or ``"package.module:Class"``).
        model: The merged ``[model]`` settings (LQT fields, segment_time, sampling).
        plan: The Gaussian targets (kinds gaussian, keypoints), else None.
        points: The points in [mm], (m, D) (kinds human_line, minjerk), else None.
        options: The kind's merged settings (``[human_line]``, ``[minjerk]``, a plug-in's).
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


# -- stroke kinds -----------------------------------------------------------------------------


@dataclass(frozen=True)
class StrokeContext:
    """What a stroke kind reads its stroke with, besides the stroke's own table.

    Attributes:
        index: Position in the file's ``strokes`` array.
        name: The stroke's name ("" when not given).
        kind: The kind's name as the plan gives it.
        model: The merged ``[model]`` settings (``dt`` is every kind's sampling step).
        settings: The plan's settings of this kind: its top-level table merged over its
            defaults ({} for a kind without settings).
        cov_source: The plan's default covariance: ``("cov", value, key)``,
            ``("semi_tied", settings, key)`` or None.
        semi_tied: The plan's ``[semi_tied]`` settings (a stroke's own table inherits them).
        seed: The plan seed (:func:`stroke_seeds` gives the stroke's streams).
    """

    index: int
    name: str
    kind: str
    model: dict
    settings: dict
    cov_source: tuple | None
    semi_tied: dict | None
    seed: int


@runtime_checkable
class StrokeKind(Protocol):
    """One kind of stroke: how a plan file's ``[[strokes]]`` table of that kind is read and how
    it becomes trajectories. Registered as an instance or a class (made once, without
    arguments). Required: :meth:`parse` and :meth:`realise`; optional (read with defaults):

    * ``keys``: the stroke keys it reads besides ``name``, ``kind`` and ``model`` (default ());
    * ``settings``: the defaults of its settings table, named after the kind (``[<kind>]`` at
      the top, ``<kind> = {...}`` in a stroke), or None for none (default);
    * ``read_settings(rd, table, key, inherited) -> dict``: checks a settings table and merges
      it over ``inherited`` (default: the keys of ``settings``, values as given);
    * ``size(stroke, samples) -> (N, peak bytes)`` and
      ``seconds(stroke, samples) -> [(seconds, key, value, what), ...]``: the estimates the
      budgets check before any work (:mod:`inkarm.plans.realise`; default: none, the kind is
      not budgeted).
    """

    def parse(self, rd: TomlReader, stroke: dict, key: str,
              context: StrokeContext) -> PlannedStroke:
        """The checked stroke from its table ``stroke`` (at ``key``, ``strokes[i]``), with its
        Gaussian targets (``plan``) or its points (m, D) set: they give its dimension. Errors by
        ``rd.error(key, message)``; :func:`read_targets_stroke`, :func:`read_points_stroke`
        and :func:`read_stroke_settings` read the common forms."""
        ...

    def realise(self, stroke: PlannedStroke, samples: int,
                stream: np.random.SeedSequence) -> tuple[Trajectory, np.ndarray]:
        """The mean trajectory (t from 0, page mm) and ``samples`` sampled paths (K, N, D) on
        its time grid, drawn from ``stream`` (the stroke's ``samples`` stream)."""
        ...


def stroke_kinds() -> tuple[str, ...]:
    """The names of the stroke kinds: the built-ins (:data:`KINDS`), then installed plug-ins'."""
    return STROKE_KINDS.names()


def stroke_kind(name: str, key: str = "kind") -> StrokeKind:
    """The stroke kind ``name`` (registered, a plug-in's, or ``"package.module:Class"``); an
    :class:`InputError` naming ``key`` when there is none or it lacks ``parse``/``realise``."""
    item = STROKE_KINDS.get(name, key=key)
    missing = [m for m in ("parse", "realise") if not callable(getattr(item, m, None))]
    if missing:
        raise InputError(f"{name!r} is not a stroke kind: a stroke kind has parse(rd, stroke, "
                         f"key, context) and realise(stroke, samples, stream) (missing: "
                         f"{', '.join(missing)})", key=key, value=name)
    return _made(item) if inspect.isclass(item) else item


@cache
def _made(cls: type) -> Any:
    return cls()


def kind_settings(kind: StrokeKind) -> Mapping | None:
    """The defaults of ``kind``'s settings table, or None when it takes none."""
    return getattr(kind, "settings", None)


def read_kind_settings(rd: TomlReader, kind: StrokeKind, table: dict, key: str,
                       inherited: Mapping) -> dict:
    """``kind``'s settings ``table`` (at ``key``) merged over ``inherited``."""
    reader = getattr(kind, "read_settings", None)
    if reader is not None:
        return reader(rd, table, key, dict(inherited))
    rd.keys(table, tuple(kind_settings(kind) or ()), key)
    return {**inherited, **table}


def read_stroke_settings(rd: TomlReader, stroke: dict, key: str,
                         context: StrokeContext) -> dict:
    """The settings of a stroke of kind ``context.kind``: its table ``<kind> = {...}`` merged
    over the plan's."""
    kind, name = stroke_kind(context.kind), context.kind
    inherited = context.settings or kind_settings(kind) or {}
    return read_kind_settings(rd, kind, rd.table(stroke.get(name, {}), f"{key}.{name}"),
                              f"{key}.{name}", inherited)


def read_targets_stroke(rd: TomlReader, stroke: dict, key: str,
                        context: StrokeContext) -> PlannedStroke:
    """A stroke of Gaussian targets (``targets``; ``cov`` or ``semi_tied`` of its own, else the
    plan's): the reading of the kinds gaussian and keypoints."""
    kind = context.kind
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
            read_semi_tied(rd, table, f"{key}.semi_tied", context.semi_tied),
            f"{key}.semi_tied",
        )
    else:
        cov_source = context.cov_source
    stream = stroke_seeds(context.seed, context.index)["covariances"]
    plan = read_targets(rd, stroke, key, kind, cov_source, stream, context.model["segment_time"])
    return PlannedStroke(context.index, context.name, kind, context.model, plan=plan)


def read_points_stroke(rd: TomlReader, stroke: dict, key: str,
                       context: StrokeContext) -> PlannedStroke:
    """A stroke through ``points`` (required, at least 2) with the kind's settings: the reading
    of the kinds human_line and minjerk."""
    kind = context.kind
    for name_ in ("targets", "cov", "semi_tied"):
        if name_ in stroke:
            raise rd.error(f"{key}.{name_}", f"not used by a {kind} stroke (it takes points)")
    if "points" not in stroke:
        raise rd.error(f"{key}.points", f"required for a {kind} stroke")
    points = read_points(rd, stroke["points"], f"{key}.points")
    options = read_stroke_settings(rd, stroke, key, context)
    return PlannedStroke(context.index, context.name, kind, context.model, points=points,
                         options=options)


# -- reading a plan ----------------------------------------------------------------------------


def _stroke(rd: TomlReader, raw, index: int, top: dict, seed: int) -> PlannedStroke:
    key = f"strokes[{index}]"
    stroke = rd.table(raw, key)
    kind = stroke.get("kind", "gaussian")
    by_path = isinstance(kind, str) and ":" in kind  # "package.module:Class", looked up
    kind_ = _kind(rd, kind, key) if by_path else None
    allowed = top["stroke_keys"]
    if by_path:  # its own keys are valid too
        allowed = tuple(dict.fromkeys((*allowed, *_keys_of(kind, kind_))))
    rd.keys(stroke, allowed, key)
    if not by_path:
        kind = rd.choice(kind, f"{key}.kind", top["kinds"])
        kind_ = _kind(rd, kind, key)
    name = rd.text(stroke.get("name", ""), f"{key}.name")
    model = read_model(
        rd, rd.table(stroke.get("model", {}), f"{key}.model"), f"{key}.model", top["model"]
    )
    for section in top["settings"]:
        if section in stroke and kind != section:
            raise rd.error(
                f"{key}.{section}", f"only applies to {section} strokes, this one is {kind}"
            )
    settings = top["settings"].get(kind, dict(kind_settings(kind_) or {}))
    context = StrokeContext(index, name, kind, model, settings, top["cov_source"],
                            top["semi_tied"], seed)
    return kind_.parse(rd, stroke, key, context)


def _keys_of(name: str, kind: StrokeKind) -> tuple[str, ...]:
    """The stroke keys a kind reads (its ``keys``, and its settings table's name)."""
    return (*getattr(kind, "keys", ()), *((name,) if kind_settings(kind) is not None else ()))


def _kind(rd: TomlReader, name: str, key: str) -> StrokeKind:
    try:
        return stroke_kind(name, key=f"{key}.kind")
    except InkarmError as e:
        raise e.within(file=rd.source) from None


def _kinds(rd: TomlReader) -> dict[str, StrokeKind]:
    """The registered stroke kinds by name (a broken plug-in is named with the file)."""
    try:
        return {name: stroke_kind(name) for name in stroke_kinds()}
    except InkarmError as e:
        raise e.within(file=rd.source) from None


def parse_plan(data: dict, source: str = "plan", seed: int | None = None) -> PlanFile:
    """Check parsed TOML ``data`` against the schema and build a :class:`PlanFile`.

    ``source`` names the file in error messages; ``seed`` overrides the file's seed.
    Raises :class:`ScenarioError` naming the file and the key at fault.
    """
    rd = TomlReader(source)
    kinds = _kinds(rd)
    sections = [n for n, kind in kinds.items() if kind_settings(kind) is not None]
    top_keys = tuple(dict.fromkeys((*TOP_KEYS[:-1], *sections, "strokes")))
    rd.keys(data, top_keys, "")
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
        "kinds": tuple(kinds),
        "stroke_keys": tuple(dict.fromkeys((*STROKE_KEYS, *(
            k for n, kind in kinds.items() for k in _keys_of(n, kind))))),
        "settings": {  # each kind's plan-level settings, in registration order
            n: read_kind_settings(rd, kinds[n], rd.table(data.get(n, {}), n), n,
                                  kind_settings(kinds[n]))
            for n in sections
        },
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
