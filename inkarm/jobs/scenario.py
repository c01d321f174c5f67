"""Scenarios: a drawing job in TOML, checked key by key, run as a pure function.

``run(scenario, out_dir) -> RunResult`` builds the drawing from its source, places it on the
page, refuses it before simulating if the arm cannot reach it, draws it with the simulated arm
and writes ``canvas.png``, ``trace.npz``, ``metrics.json`` and ``report.png``. The same scenario
and seed give the same canvas and metrics, run after run (the wall-clock real-time factor aside).

Schema (lengths [mm], times [s], forces [N], angles [deg]; every key optional unless marked)::

    title = "Letter N"
    seed  = 0                      # seeds every random choice of the source

    [source]                       # required: what to draw
    kind = "plan"                  # "plan", "trajectory", "text", "tag" or "trace"
    file = "plans/N_samples.toml"  # plan, trajectory (CSV t,x,y[,stroke]), trace (CSV or SVG);
                                   # relative to the scenario file
    sample = 2                     # plan: draw this sample of the trajectory distribution
                                   # (0-based) instead of the mean; a list of samples draws
    spacing_mm = 60.0              # one copy of each, spaced along x by spacing_mm
    plan = { strokes = [...] }     # plan: an inline plan (the plan-file schema) instead of file
    text = "inkarm"                # text: the words to write
    style = "faithful"             # text, tag: a handstyle preset; trace: "geometric" or
                                   # "semi-tied" covariances (inkarm.plans.restyle)
    height_mm = 10.0               # text: letter height
    compression = 0.75             # trace: DPPLA compression rate in (0, 1)

    [placement]                    # where the drawing lands on the page
    centre_mm = [105.0, 148.5]     # page point of the centre of the drawing's bounding box
    height_mm = 60.0               # scale the drawing to this height ...
    scale = 1.0                    # ... or by this factor (not both)
    rotation_deg = 0.0             # counter-clockwise, about the bounding-box centre
    time_scale = 1.0               # > 1 draws slower (times multiplied)

    [cell]                         # inkarm.sim.cell.CellConfig fields, e.g.
    paper_size_mm = [210.0, 297.0]
    paper_centre_mm = [600.0, 0.0] # robot base frame
    timestep = 0.002
    arm = "builtin"                # or "iiwa14", "panda": MuJoCo Menagerie models, read from
                                   # the local copy named by the variable MENAGERIE_ROOT

    [controller]                   # inkarm.control.loop.LoopConfig fields, e.g.
    force_n = 1.0
    [controller.gains]             # joint PID, 7 values each or one for all joints
    kp = [...]                     # [N m/rad]; also ki, kd, torque_limit, integral_limit

    [ink]
    model = "marker"               # "marker", "brush" or "pencil"
    px_per_mm = 10.0               # raster resolution; other keys go to the ink model

The page frame has its origin at the lower-left corner of the sheet, x to the right, y up.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InkarmError, InputError, ScenarioError, SimulationError
from inkarm.io.toml import TomlReader, load_toml

SOURCE_KINDS = ("plan", "trajectory", "text", "tag", "trace")
TOP_KEYS = ("title", "seed", "source", "placement", "cell", "controller", "ink")
SOURCE_KEYS = {
    "plan": ("kind", "file", "plan", "sample", "spacing_mm"),
    "trajectory": ("kind", "file"),
    "text": ("kind", "text", "style", "height_mm"),
    "tag": ("kind", "style"),
    "trace": ("kind", "file", "style", "compression"),
}
PLACEMENT_KEYS = ("centre_mm", "height_mm", "scale", "rotation_deg", "time_scale")
MAX_PX_PER_MM = 40.0  # an A4 raster of 8400 x 11880 float32 pixels, 400 MB
DEFAULT_SCENARIO = Path(__file__).parents[1] / "data" / "default.toml"


@dataclass(frozen=True)
class Placement:
    """Where and how large the drawing lands on the page. Lengths [mm], angles [deg]."""

    centre_mm: tuple[float, float] | None = None
    height_mm: float | None = None
    scale: float = 1.0
    rotation_deg: float = 0.0
    time_scale: float = 1.0


@dataclass(frozen=True)
class Scenario:
    """A checked scenario. ``source`` keeps the raw source table (checked), with ``base_dir``
    to resolve its files; the other sections are ready-made keyword dictionaries."""

    path: str
    base_dir: Path
    title: str
    seed: int
    source: dict
    placement: Placement
    cell: dict = field(default_factory=dict)
    controller: dict = field(default_factory=dict)
    gains: dict = field(default_factory=dict)
    ink: dict = field(default_factory=dict)
    ink_model: str = "marker"
    px_per_mm: float = 10.0


# -- reading -------------------------------------------------------------------------------------


def load_scenario(path: str | Path | None = None) -> Scenario:
    """Read and check the scenario at ``path``; the embedded default when None."""
    path = Path(path) if path is not None else DEFAULT_SCENARIO
    data = load_toml(path, "scenario file")
    return parse_scenario(data, source=str(path), base_dir=path.parent)


def _dataclass_table(rd: TomlReader, table: dict, key: str, cls) -> dict:
    """Check ``table`` against the fields of dataclass ``cls`` (numbers, booleans, strings and
    arrays of numbers, as the field's default suggests) and return constructor kwargs."""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    rd.keys(table, tuple(fields), key)
    out = {}
    for name, value in table.items():
        where = f"{key}.{name}"
        default = fields[name].default
        if default is dataclasses.MISSING and fields[name].default_factory is not dataclasses.MISSING:
            default = fields[name].default_factory()
        if isinstance(default, bool):
            out[name] = rd.boolean(value, where)
        elif isinstance(default, str):
            out[name] = rd.text(value, where)
        elif isinstance(default, tuple | list | np.ndarray):
            arr = rd.array(value, where, 1)
            if len(arr) != len(default):
                raise rd.error(where, f"expected {len(default)} numbers, got {len(arr)}")
            out[name] = tuple(float(v) for v in arr)
        elif isinstance(value, list):
            out[name] = tuple(float(v) for v in rd.array(value, where, 1))
        else:
            out[name] = rd.number(value, where)
    try:
        cls(**out)
    except InputError as e:
        field_name, _, message = str(e).partition(": ")
        name = field_name.removeprefix(f"{cls.__name__}.")
        raise rd.error(f"{key}.{name}" if name in fields else key, message or str(e)) from None
    return out


def _gain(rd: TomlReader, value, key: str) -> float | np.ndarray:
    """A PID gain: one number >= 0 for every joint, or a list of 7."""
    if not isinstance(value, list):
        return rd.number(value, key, 0.0)
    arr = rd.array(value, key, 1)
    if arr.shape != (7,):
        raise rd.error(key, f"expected one number or a list of 7 (one per joint), got {len(arr)}")
    if np.any(arr < 0):
        raise rd.error(key, f"expected numbers >= 0, got {arr.tolist()}")
    return arr


def _source(rd: TomlReader, raw, base_dir: Path) -> dict:
    table = rd.table(raw, "source")
    if "kind" not in table:
        raise rd.error("source.kind", f"required; one of {', '.join(map(repr, SOURCE_KINDS))}")
    kind = rd.choice(table["kind"], "source.kind", SOURCE_KINDS)
    rd.keys(table, SOURCE_KEYS[kind], "source")
    out = {"kind": kind}
    if kind in ("plan", "trajectory", "trace"):
        if kind == "plan" and ("file" in table) == ("plan" in table):
            raise rd.error("source", "give one of file (a plan file) and plan (an inline plan)")
        if "file" in table:
            file = base_dir / rd.text(table["file"], "source.file")
            if not file.is_file():
                raise rd.error("source.file", f"no such file: {file}")
            out["file"] = file
        elif kind != "plan":
            raise rd.error("source.file", "required")
    if "plan" in table:
        out["plan"] = rd.table(table["plan"], "source.plan")
    if "sample" in table:
        raw_samples = table["sample"] if isinstance(table["sample"], list) else [table["sample"]]
        if not raw_samples:
            raise rd.error("source.sample", "expected a sample index or a non-empty list of them")
        out["sample"] = [rd.integer(v, f"source.sample[{i}]" if isinstance(table["sample"], list)
                                    else "source.sample", 0) for i, v in enumerate(raw_samples)]
    if "spacing_mm" in table:
        if len(out.get("sample", [])) < 2:
            raise rd.error("source.spacing_mm", "only with a list of several samples")
        out["spacing_mm"] = rd.number(table["spacing_mm"], "source.spacing_mm", 0.0)
    if kind == "text":
        if "text" not in table:
            raise rd.error("source.text", "required")
        out["text"] = rd.text(table["text"], "source.text")
        if not out["text"].strip():
            raise rd.error("source.text", "empty text")
    if "style" in table:
        if kind == "trace":
            from inkarm.plans.restyle import STYLES

            out["style"] = rd.choice(table["style"], "source.style", STYLES)
        else:
            from inkarm.plans.handstyles import PRESETS

            out["style"] = rd.choice(table["style"], "source.style", tuple(PRESETS))
    if "height_mm" in table:
        out["height_mm"] = rd.number(table["height_mm"], "source.height_mm", 0.0, strict=True)
    if "compression" in table:
        rho = rd.number(table["compression"], "source.compression")
        if not 0.0 < rho < 1.0:
            raise rd.error("source.compression", f"expected a number in (0, 1), got {rho}")
        out["compression"] = rho
    return out


def _placement(rd: TomlReader, raw) -> Placement:
    table = rd.table(raw, "placement")
    rd.keys(table, PLACEMENT_KEYS, "placement")
    if "height_mm" in table and "scale" in table:
        raise rd.error("placement", "give one of height_mm and scale, not both")
    kw = {}
    if "centre_mm" in table:
        c = rd.array(table["centre_mm"], "placement.centre_mm", 1)
        if c.shape != (2,):
            raise rd.error("placement.centre_mm", f"expected [x, y], got {len(c)} numbers")
        kw["centre_mm"] = (float(c[0]), float(c[1]))
    for name in ("height_mm", "scale", "time_scale"):
        if name in table:
            kw[name] = rd.number(table[name], f"placement.{name}", 0.0, strict=True)
    if "rotation_deg" in table:
        kw["rotation_deg"] = rd.number(table["rotation_deg"], "placement.rotation_deg")
    return Placement(**kw)


def parse_scenario(data: dict, source: str = "scenario", base_dir: str | Path = ".") -> Scenario:
    """Check parsed TOML ``data`` (see the module docstring); errors name ``source`` and the key."""
    from inkarm.control.loop import LoopConfig
    from inkarm.control.pid import PIDGains
    from inkarm.ink.canvas import INK_MODELS
    from inkarm.sim.cell import CellConfig

    rd = TomlReader(source)
    rd.keys(data, TOP_KEYS, "")
    if "source" not in data:
        raise rd.error("source", "required: a [source] table saying what to draw")
    base_dir = Path(base_dir)
    controller = dict(rd.table(data.get("controller", {}), "controller"))
    gains = rd.table(controller.pop("gains", {}), "controller.gains")
    gain_names = tuple(f.name for f in dataclasses.fields(PIDGains))
    rd.keys(gains, gain_names, "controller.gains")
    gains = {k: _gain(rd, v, f"controller.gains.{k}") for k, v in gains.items()}
    ink = dict(rd.table(data.get("ink", {}), "ink"))
    ink_model = rd.choice(ink.pop("model", "marker"), "ink.model", tuple(INK_MODELS))
    px_per_mm = rd.number(ink.pop("px_per_mm", 10.0), "ink.px_per_mm", 0.0, strict=True)
    if px_per_mm > MAX_PX_PER_MM:
        raise rd.error("ink.px_per_mm", f"expected at most {MAX_PX_PER_MM:g} (a finer raster of a "
                       f"sheet does not fit in memory), got {px_per_mm:g}")
    ink = _dataclass_table(rd, ink, "ink", INK_MODELS[ink_model])
    return Scenario(
        path=source,
        base_dir=base_dir,
        title=rd.text(data.get("title", Path(source).stem), "title"),
        seed=rd.integer(data.get("seed", 0), "seed", 0),
        source=_source(rd, data["source"], base_dir),
        placement=_placement(rd, data.get("placement", {})),
        cell=_dataclass_table(rd, rd.table(data.get("cell", {}), "cell"), "cell", CellConfig),
        controller=_dataclass_table(rd, controller, "controller", LoopConfig),
        gains=gains,
        ink=ink,
        ink_model=ink_model,
        px_per_mm=px_per_mm,
    )


# -- the drawing -----------------------------------------------------------------------------------


def source_drawing(scenario: Scenario) -> Drawing:
    """The drawing the source describes, in its own coordinates [mm] and times [s]."""
    src = scenario.source
    kind = src["kind"]
    where = f"{scenario.path}: source"
    try:
        if kind == "plan":
            from inkarm.io.planfile import load_plan, parse_plan, realise_plan

            if "file" in src:
                plan = load_plan(src["file"], seed=scenario.seed)
            else:
                plan = parse_plan(src["plan"], source=f"{scenario.path}: source.plan", seed=scenario.seed)
            if "sample" not in src:
                return realise_plan(plan, samples=0).drawing
            result = realise_plan(plan, samples=max(src["sample"]) + 1)
            strokes = []
            for copy, k in enumerate(src["sample"]):
                shift = np.zeros(plan.dim)
                shift[0] = copy * src.get("spacing_mm", 0.0)
                strokes += [Trajectory(t=r.mean.t, pos=r.samples[k] + shift) for r in result.strokes]
            return Drawing(strokes).sequential(pause=plan.pause)
        if kind == "trajectory":
            return Drawing.from_csv(src["file"])
        if kind == "text":
            from inkarm.plans.text import write_text

            kwargs = {"height": src["height_mm"]} if "height_mm" in src else {}
            return write_text(src["text"], src.get("style", "faithful"), seed=scenario.seed, **kwargs).drawing
        if kind == "tag":
            from inkarm.plans.glyphs import make_tag

            return make_tag(src.get("style", "graffiti"), seed=scenario.seed).realise()
        from inkarm.io.trace import load_trace
        from inkarm.plans.restyle import RestyleConfig, restyle

        cfg = RestyleConfig(**{k: src[k] for k in ("compression", "style") if k in src})
        return restyle(load_trace(src["file"]), cfg).drawing
    except ScenarioError:
        raise
    except InkarmError as e:
        raise type(e)(f"{where}: {e}") from None


def place(drawing: Drawing, placement: Placement, page_size_mm: tuple[float, float]) -> Drawing:
    """Scale, rotate and translate a 2-D ``drawing`` onto a page of ``page_size_mm``, and stretch
    its times by ``placement.time_scale``."""
    if drawing.dim != 2:
        # The pen's height is the force loop's to decide; a planned z would fight it.
        raise InputError(f"source: the drawing has {drawing.dim}-D positions; the arm draws "
                         "2-D (x, y) page paths, pen down along each stroke")
    lo, hi = drawing.bounds()
    centre = 0.5 * (lo + hi)
    height = float(hi[1] - lo[1])
    scale = placement.scale
    if placement.height_mm is not None:
        if height <= 0:
            raise InputError("placement.height_mm: the drawing has no height to scale")
        scale = placement.height_mm / height
    target = np.array(placement.centre_mm if placement.centre_mm is not None
                      else (0.5 * page_size_mm[0], 0.5 * page_size_mm[1]))
    a = np.deg2rad(placement.rotation_deg)
    rot = scale * np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    strokes = []
    for s in drawing.strokes:
        pos = (s.pos - centre) @ rot.T + target
        strokes.append(Trajectory(t=s.t * placement.time_scale, pos=pos, pressure=s.pressure))
    return Drawing(strokes, page_size=page_size_mm)


# -- running -------------------------------------------------------------------------------------


@dataclass
class RunResult:
    """What a run produced: its metrics, the files written (file name -> path), the placed
    drawing (page [mm]), the log of every control period and the cell it ran in."""

    metrics: dict
    files: dict[str, Path]
    drawing: Drawing
    log: object = None
    cell: object = None


def run(
    scenario: Scenario,
    out_dir: str | Path,
    progress=None,
    video: str | Path | None = None,
    fps: float = 30.0,
    camera: str = "drawing",
    report: bool = True,
) -> RunResult:
    """Draw ``scenario`` with the simulated arm; write its pictures and logs into ``out_dir``.

    ``progress(fraction, phase)`` is called during the simulation; ``report=False`` skips
    report.png. On divergence the partial trace and canvas are written before
    :class:`SimulationError` propagates; errors of the scenario's settings found while building
    the cell name the scenario file and key.
    """

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    try:
        return _run(scenario, out, progress, video, fps, camera, report)
    except (ScenarioError, SimulationError):
        raise
    except InputError as e:
        raise ScenarioError(f"{scenario.path}: {_table_key(str(e))}") from None


_CONFIG_TABLES = {"CellConfig.": "cell.", "LoopConfig.": "controller.", "PIDGains.": "controller.gains."}


def _table_key(message: str) -> str:
    """A configuration class's field in ``message`` renamed to the scenario key it comes from."""
    for prefix, table in _CONFIG_TABLES.items():
        if message.startswith(prefix):
            return table + message.removeprefix(prefix)
    return message


def _run(scenario, out, progress, video, fps, camera, report) -> RunResult:
    from inkarm.analysis.metrics import compute_metrics
    from inkarm.control.loop import LoopConfig, run_drawing
    from inkarm.core.frames import PagePlacement
    from inkarm.ink.canvas import Canvas, make_ink
    from inkarm.plots.report import report_figure
    from inkarm.sim.cell import CellConfig, build_model, default_gains, joint_ranges
    from inkarm.sim.plant import MujocoPlant

    cell = CellConfig(**scenario.cell)
    drawing = place(source_drawing(scenario), scenario.placement, cell.paper_size_mm)
    kin_model = build_model(cell)  # the controller's own model; the plant gets a twin
    placement = PagePlacement.from_model(kin_model)
    try:
        gains = dataclasses.replace(default_gains(cell.arm), **scenario.gains)
    except InputError as e:
        raise ScenarioError(f"{scenario.path}: controller.gains: {e}") from None
    canvas = Canvas(size_mm=cell.paper_size_mm, px_per_mm=scenario.px_per_mm,
                    ink=make_ink(scenario.ink_model, **scenario.ink))
    plant = MujocoPlant(build_model(cell), canvas=canvas)
    files = {name: out / name for name in ("reference.csv", "trace.npz", "canvas.png", "metrics.json")}
    drawing.to_csv(files["reference.csv"])
    loop = LoopConfig(**scenario.controller)
    try:
        log = run_drawing(drawing, plant, kin_model, gains, placement, loop, progress=progress)
    except SimulationError as e:
        partial = getattr(e, "log", None)
        if partial is not None:
            partial.to_npz(files["trace.npz"])
        canvas.to_png(files["canvas.png"])
        raise SimulationError(f"{e} (partial trace and canvas kept in {out})") from None
    finally:
        plant.close()
    log.to_npz(files["trace.npz"])
    canvas.to_png(files["canvas.png"])
    plan_strokes = [s.pos[:, :2] for s in drawing.strokes]
    metrics = compute_metrics(
        times_s=log.time, reference_mm=log.reference, tip_mm=log.tip, force_n=log.force,
        drawing=log.drawing, q=log.q, joint_range=joint_ranges(kin_model), wall_time_s=log.wall_s,
        canvas=canvas, plan_strokes=plan_strokes,
    )
    files["metrics.json"].write_text(json.dumps(metrics, indent=2, sort_keys=True) + "\n")
    if report:
        files["report.png"] = out / "report.png"
        report_figure(files["report.png"], canvas=canvas, times_s=log.time,
                      reference_mm=log.reference, tip_mm=log.tip, force_n=log.force,
                      drawing=log.drawing, plan_strokes=plan_strokes, metrics=metrics,
                      title=scenario.title)
    if video is not None:
        from inkarm.sim.render import render_log_video

        files["video"] = render_log_video(
            log, video, cell, px_per_mm=scenario.px_per_mm,
            ink=make_ink(scenario.ink_model, **scenario.ink), fps=fps, camera=camera,
            contact_threshold_n=loop.contact_threshold_n, progress=progress)
    return RunResult(metrics=metrics, files=files, drawing=drawing, log=log, cell=cell)
