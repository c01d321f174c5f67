"""Plan files: motor plans written in TOML, read with :mod:`tomllib`, checked key by key.

A plan file lists the pen-down strokes of a drawing, each a sequence of Gaussian targets
(seed 000), key-points (GI eq. 6-7), a Human Line polyline (seed 002) or minimum-jerk
via-points (Flash & Hogan), together with the parameters of the model that turns it into a
trajectory. Lengths in [mm], covariances in [mm^2], times in [s], angles in [deg].
Array indices in error messages count from 0, as in ``strokes[1].targets[2].cov``.

Schema (every key optional unless marked required)::

    title   = "Letter A"     # free text
    seed    = 0              # integer >= 0: seeds sampling, semi-tied spreads, human lines
    samples = 0              # integer >= 0: trajectories to sample per stroke
    pause   = 0.5            # pen-up time between strokes [s]
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

Covariance forms: a number (variance, spherical), a list of D variances (diagonal) or a D x D
symmetric positive definite matrix; or ``std``: a standard deviation [mm] or a list of D of
them, rotated by ``angle`` [deg, counter-clockwise] in 2-D, Sigma = R diag(std^2) R^T.
A target without ``cov``/``std`` takes, in this order: the stroke's ``cov`` or ``semi_tied``
(not both), the top-level ``cov`` or ``[semi_tied]`` (not both), and for key-points the
identity (GI eq. 7); otherwise it is an error. All targets of a plan have the same D (2 or 3).

Samples: a Gaussian stroke's samples come from the LQT trajectory distribution, a human-line
stroke's from fresh squiggles; a minimum-jerk stroke is deterministic and repeats its mean.

Randomness: stroke i of a plan with seed s has its own streams, children of
``numpy.random.SeedSequence([s, i])`` (:func:`stroke_seeds`): one for the semi-tied
magnitudes h_i, one for the samples (LQT draws, human lines). They are independent of each
other and of every other stroke's, and the same seed gives the same plan and samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from inkarm.core.plan import GaussianTarget, StrokePlan, check_covariance
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InkarmError, PlanError, ScenarioError
from inkarm.io.toml import TomlReader, describe, load_toml
from inkarm.models.human_line import human_polyline
from inkarm.models.minjerk import via_points

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
TARGET_KEYS = ("mean", "cov", "std", "angle")
MODEL_DEFAULTS = {
    "order": 4,
    "dt": 0.01,
    "d": 5.0,
    "r": None,
    "discretisation": "euler",
    "end_at_rest": True,
    "segment_time": 0.5,
    "sampling": "exact",
    "solver": "auto",
}
SEMI_TIED_DEFAULTS = {"H": None, "h": None, "rho": 0.0}
HUMAN_LINE_DEFAULTS = {"squiggle": 5.0, "px_mm": 25.4 / 300.0, "duration": 2.0}
MINJERK_DEFAULTS = {"duration": 1.0, "via_times": None}


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


# -- the sections ------------------------------------------------------------------------------


def _model(rd: TomlReader, table: dict, key: str, inherited: dict) -> dict:
    rd.keys(table, tuple(MODEL_DEFAULTS), key)
    out = dict(inherited)
    if "d" in table and "r" in table:
        raise rd.error(key, "give one of d (maximum displacement) and r (control weight), not both")
    if "d" in table:
        out["d"], out["r"] = rd.number(table["d"], f"{key}.d", 0.0, strict=True), None
    if "r" in table:
        out["r"], out["d"] = rd.number(table["r"], f"{key}.r", 0.0, strict=True), None
    if "order" in table:
        out["order"] = rd.integer(table["order"], f"{key}.order", 1, 7)
    for name in ("dt", "segment_time"):
        if name in table:
            out[name] = rd.number(table[name], f"{key}.{name}", 0.0, strict=True)
    if "discretisation" in table:
        out["discretisation"] = rd.choice(
            table["discretisation"], f"{key}.discretisation", ("euler", "zoh")
        )
    if "end_at_rest" in table:
        out["end_at_rest"] = rd.boolean(table["end_at_rest"], f"{key}.end_at_rest")
    if "sampling" in table:
        out["sampling"] = rd.choice(table["sampling"], f"{key}.sampling", ("exact", "eigen"))
    if "solver" in table:
        out["solver"] = rd.choice(
            table["solver"], f"{key}.solver", ("auto", "cholesky", "augmented", "batch")
        )
    if out["segment_time"] < out["dt"]:
        raise rd.error(
            f"{key}.segment_time" if "segment_time" in table else f"{key}.dt",
            f"segment_time ({out['segment_time']:g} s) must be at least dt ({out['dt']:g} s)",
        )
    return out


def _semi_tied(rd: TomlReader, table: dict, key: str, inherited: dict | None) -> dict:
    rd.keys(table, tuple(SEMI_TIED_DEFAULTS), key)
    out = dict(inherited or SEMI_TIED_DEFAULTS)
    if "H" in table:
        out["H"] = rd.array(table["H"], f"{key}.H", 2)
        h = out["H"]
        if h.ndim != 2 or h.shape[0] != h.shape[1] or h.shape[0] not in (2, 3):
            raise rd.error(f"{key}.H", f"expected a 2 x 2 or 3 x 3 matrix, got shape {h.shape}")
        if abs(np.linalg.det(h)) <= 1e-12 * max(np.max(np.abs(h)), 1e-300) ** h.shape[0]:
            raise rd.error(f"{key}.H", "the basis is singular (its columns are not independent)")
    if "h" in table:
        out["h"] = rd.number(table["h"], f"{key}.h", 0.0, strict=True)
    if "rho" in table:
        out["rho"] = rd.number(table["rho"], f"{key}.rho", 0.0)
    if out["h"] is None:
        raise rd.error(f"{key}.h", "required: the covariance magnitude in mm^2")
    return out


def _options(rd: TomlReader, kind: str, table: dict, key: str, inherited: dict) -> dict:
    defaults = HUMAN_LINE_DEFAULTS if kind == "human_line" else MINJERK_DEFAULTS
    rd.keys(table, tuple(defaults), key)
    out = dict(inherited)
    if kind == "human_line":
        if "squiggle" in table:
            out["squiggle"] = rd.number(table["squiggle"], f"{key}.squiggle", 0.0)
        for name in ("px_mm", "duration"):
            if name in table:
                out[name] = rd.number(table[name], f"{key}.{name}", 0.0, strict=True)
    else:
        if "duration" in table:
            out["duration"] = rd.number(table["duration"], f"{key}.duration", 0.0, strict=True)
        if "via_times" in table:
            out["via_times"] = rd.array(table["via_times"], f"{key}.via_times", 1)
    return out


def _covariance(rd: TomlReader, value, dim: int, key: str) -> np.ndarray:
    if isinstance(value, list) and value and isinstance(value[0], list):
        arr = rd.array(value, key, 2)
    elif isinstance(value, list):
        arr = rd.array(value, key, 1)
    else:
        arr = np.asarray(rd.number(value, key))
    try:
        return check_covariance(arr, dim, f"{rd.source}: {key}")
    except PlanError as e:
        raise ScenarioError(str(e)) from None


def _std_covariance(rd: TomlReader, target: dict, dim: int, key: str) -> np.ndarray:
    std_value = target["std"]
    if isinstance(std_value, list):
        std = rd.array(std_value, f"{key}.std", 1)
        if std.shape[0] != dim:
            raise rd.error(f"{key}.std", f"has {std.shape[0]} entries, expected {dim}")
    else:
        std = np.full(dim, rd.number(std_value, f"{key}.std"))
    if np.any(std <= 0):
        raise rd.error(f"{key}.std", f"standard deviations must be positive, got {std.tolist()}")
    cov = np.diag(std**2)
    if "angle" in target:
        if dim != 2:
            raise rd.error(f"{key}.angle", "an angle only orients 2-D targets; give cov for 3-D")
        a = math.radians(rd.number(target["angle"], f"{key}.angle"))
        rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        cov = rot @ cov @ rot.T  # seed 000 eq. 8
    return cov


def _points(rd: TomlReader, value, key: str) -> np.ndarray:
    if not isinstance(value, list):
        raise rd.error(key, f"expected an array of points, got {describe(value)}")
    pts = rd.array(value, key, 2)
    if pts.shape[0] < 2:
        raise rd.error(key, f"expected at least 2 points, got {pts.shape[0]}")
    if pts.shape[1] not in (2, 3):
        raise rd.error(key, f"points must have 2 or 3 coordinates, got {pts.shape[1]}")
    return pts


STREAMS = ("covariances", "samples")
"""The random streams of a stroke, in the order they are spawned (see the module docstring)."""


def stroke_seeds(seed: int, index: int) -> dict[str, np.random.SeedSequence]:
    """The independent seed sequences of stroke ``index`` of a plan seeded with ``seed``, by
    purpose (:data:`STREAMS`): children of ``SeedSequence([seed, index])``."""
    return dict(zip(STREAMS, np.random.SeedSequence([seed, index]).spawn(len(STREAMS))))


def _generated_covariances(
    rd: TomlReader, settings: dict, m: int, dim: int, key: str, seed: np.random.SeedSequence
) -> np.ndarray:
    from inkarm.models.lqt import semi_tied_covariances

    basis = np.eye(dim) if settings["H"] is None else settings["H"]
    if basis.shape[0] != dim:
        raise rd.error(
            f"{key}.H", f"is {basis.shape[0]} x {basis.shape[0]} but the targets are {dim}-D"
        )
    try:
        covs = semi_tied_covariances(
            m, basis, settings["h"], rho=settings["rho"], seed=np.random.default_rng(seed)
        )
    except InkarmError as e:
        raise rd.error(key, str(e)) from None
    return np.asarray(covs, dtype=float)


def _targets(
    rd: TomlReader,
    stroke: dict,
    key: str,
    kind: str,
    cov_source: tuple | None,
    seed: np.random.SeedSequence,
    segment_time: float,
) -> StrokePlan:
    """Read ``targets``; cov_source is ("cov", value, key) or ("semi_tied", settings, key) or None."""
    raw = stroke.get("targets")
    if raw is None:
        raise rd.error(f"{key}.targets", f"required for a {kind} stroke")
    if not isinstance(raw, list) or not raw:
        raise rd.error(
            f"{key}.targets", "expected a non-empty array of tables { mean = [...], ... }"
        )
    means, explicit = [], []
    for i, target in enumerate(raw):
        tkey = f"{key}.targets[{i}]"
        target = rd.table(target, tkey)
        rd.keys(target, TARGET_KEYS, tkey)
        if "mean" not in target:
            raise rd.error(f"{tkey}.mean", "required: the target centre in mm")
        mean = rd.array(target["mean"], f"{tkey}.mean", 1)
        if mean.shape[0] not in (2, 3):
            raise rd.error(f"{tkey}.mean", f"expected 2 or 3 coordinates, got {mean.shape[0]}")
        if means and mean.shape[0] != means[0].shape[0]:
            raise rd.error(
                f"{tkey}.mean",
                f"has {mean.shape[0]} coordinates but {key}.targets[0] has {means[0].shape[0]}",
            )
        means.append(mean)
        if "cov" in target and "std" in target:
            raise rd.error(tkey, "give one of cov and std, not both")
        if "angle" in target and "std" not in target:
            raise rd.error(f"{tkey}.angle", "only allowed together with std")
        dim = mean.shape[0]
        if "cov" in target:
            explicit.append(_covariance(rd, target["cov"], dim, f"{tkey}.cov"))
        elif "std" in target:
            explicit.append(_std_covariance(rd, target, dim, tkey))
        else:
            explicit.append(None)
    dim = means[0].shape[0]
    covs = list(explicit)
    missing = [i for i, c in enumerate(covs) if c is None]
    if missing:
        if cov_source is None:
            if kind != "keypoints":
                raise rd.error(
                    f"{key}.targets[{missing[0]}]",
                    "no covariance: give cov or std, or a cov or [semi_tied] for the stroke or the plan",
                )
            fill = [np.eye(dim)] * len(covs)  # GI eq. 7: identity weight at each key-point
        elif cov_source[0] == "cov":
            fill = [_covariance(rd, cov_source[1], dim, cov_source[2])] * len(covs)
        else:
            fill = _generated_covariances(rd, cov_source[1], len(covs), dim, cov_source[2], seed)
        for i in missing:
            covs[i] = fill[i]
    targets = []
    for i, (mean, cov) in enumerate(zip(means, covs)):
        try:
            targets.append(GaussianTarget(mean, cov))
        except PlanError as e:
            raise rd.error(f"{key}.targets[{i}]", str(e)) from None
    return StrokePlan(tuple(targets), segment_time=segment_time, keypoints=kind == "keypoints")


def _stroke(rd: TomlReader, raw, index: int, top: dict, seed: int) -> PlannedStroke:
    key = f"strokes[{index}]"
    stroke = rd.table(raw, key)
    rd.keys(stroke, STROKE_KEYS, key)
    kind = rd.choice(stroke.get("kind", "gaussian"), f"{key}.kind", KINDS)
    name = rd.text(stroke.get("name", ""), f"{key}.name")
    model = _model(
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
        points = _points(rd, stroke["points"], f"{key}.points")
        options = _options(
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
            _semi_tied(rd, table, f"{key}.semi_tied", top["semi_tied"]),
            f"{key}.semi_tied",
        )
    else:
        cov_source = top["cov_source"]
    stream = stroke_seeds(seed, index)["covariances"]
    plan = _targets(rd, stroke, key, kind, cov_source, stream, model["segment_time"])
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
    pause = rd.number(data.get("pause", 0.5), "pause", 0.0)
    model = _model(rd, rd.table(data.get("model", {}), "model"), "model", MODEL_DEFAULTS)
    semi_tied = None
    if "semi_tied" in data:
        semi_tied = _semi_tied(rd, rd.table(data["semi_tied"], "semi_tied"), "semi_tied", None)
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
        "human_line": _options(
            rd,
            "human_line",
            rd.table(data.get("human_line", {}), "human_line"),
            "human_line",
            HUMAN_LINE_DEFAULTS,
        ),
        "minjerk": _options(
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


# -- realising a plan --------------------------------------------------------------------------


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
