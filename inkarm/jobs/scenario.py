"""Scenarios: a drawing job in TOML, checked key by key once, into a typed :class:`Scenario`.

:func:`inkarm.jobs.run.run` draws one in memory; :func:`inkarm.jobs.outputs.write_run` writes
its files. The same scenario and seed give the same canvas and metrics, run after run (the
wall-clock real-time factor aside). :meth:`Scenario.with_overrides` changes dotted keys and
checks them exactly as the TOML would be.

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

import copy
import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from inkarm.control.config import LoopConfig
from inkarm.core.equality import same
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InkarmError, InputError, ScenarioError
from inkarm.ink.canvas import INK_MODELS, Canvas
from inkarm.io.toml import TomlReader, load_toml
from inkarm.jobs.sources import Source, parse_source, source_table
from inkarm.robots.profile import GAIN_KEYS, RobotProfile, gain_vector
from inkarm.robots.registry import DEFAULT_ROBOT, load_robot, robot_names
from inkarm.sim.cell import CellConfig
from inkarm.sim.imperfections import PlantTruth

TOP_KEYS = ("title", "seed", "source", "placement", "robot", "cell", "controller", "ink",
            "plant")
PLACEMENT_KEYS = ("centre_mm", "height_mm", "scale", "rotation_deg", "time_scale")
ROBOT_KEYS = ("name", "file", "gains")
# Upper bounds of the placement's scalings: a sheet is at most 2 m, a drawing at most 1000x its
# source, at most 100x slower.
PLACEMENT_MAXIMA = {"height_mm": 2000.0, "scale": 1000.0, "time_scale": 100.0}
MAX_PX_PER_MM = 40.0  # finer than any pen; the raster's memory has its own budget (ink.canvas)
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
class InkSpec:
    """The ink model's name, its parameters (an instance of the model class) and the raster
    resolution [px/mm]."""

    model: str = "marker"
    params: Any = None
    px_per_mm: float = 10.0

    def make(self):
        """A fresh ink model."""
        return dataclasses.replace(self.params) if self.params is not None else \
            INK_MODELS[self.model]()

    def canvas(self, size_mm: tuple[float, float]) -> Canvas:
        """A blank page of ``size_mm`` [mm] in this ink, at this resolution."""
        return Canvas(size_mm=size_mm, px_per_mm=self.px_per_mm, ink=self.make())


@dataclass(frozen=True, eq=False)
class Scenario:
    """A checked scenario: every section typed, nothing left to parse.

    Attributes:
        path: Where it came from (a file, or a description), named in every error.
        base_dir: Folder its relative file names are resolved against.
        robot: The robot profile, with the scenario's gain overrides applied.
        robot_ref: The robot as the scenario names it (a built-in name or a file path).
        gain_overrides: The ``[robot.gains]`` table as given (name -> tuple of numbers).
    """

    path: str
    base_dir: Path
    title: str
    seed: int
    source: Source
    placement: Placement
    robot: RobotProfile
    robot_ref: str
    gain_overrides: tuple[tuple[str, tuple[float, ...]], ...]
    cell: CellConfig
    controller: LoopConfig
    ink: InkSpec
    plant: PlantTruth = field(default_factory=PlantTruth)

    def to_dict(self) -> dict:
        """The TOML tables that parse back to this scenario (file names absolute)."""
        robot: dict[str, Any] = ({"file": self.robot_ref} if self.robot_ref.endswith(".toml")
                                 else {"name": self.robot_ref})
        if self.gain_overrides:
            robot["gains"] = {k: list(v) if len(v) > 1 else v[0] for k, v in self.gain_overrides}
        return {
            "title": self.title,
            "seed": self.seed,
            "source": source_table(self.source),
            "placement": _table_of(self.placement),
            "robot": robot,
            "cell": _table_of(self.cell),
            "controller": _table_of(self.controller),
            "ink": {"model": self.ink.model, "px_per_mm": self.ink.px_per_mm,
                    **_table_of(self.ink.params)},
            "plant": _plant_table(self.plant),
        }

    def with_overrides(self, overrides: dict[str, Any]) -> Scenario:
        """This scenario with dotted keys replaced (``{"controller.force_n": 1.5,
        "robot.gains.kp": [...]}``), checked by the same rules as the TOML: an unknown key is
        refused with the closest valid one, a bad value with the message the file would get."""
        data = copy.deepcopy(self.to_dict())  # the tables may be this scenario's own
        for dotted, value in overrides.items():
            _set_dotted(data, dotted, value)
        return parse_scenario(data, source=f"{self.path} (with overrides)",
                              base_dir=self.base_dir)


def _table_of(obj) -> dict:
    """A dataclass as a TOML table: the fields that differ from their defaults, tuples as
    lists."""
    if obj is None:
        return {}
    out = {}
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if value is None or (f.default is not dataclasses.MISSING and same(value, f.default)):
            continue
        out[f.name] = list(value) if isinstance(value, tuple | np.ndarray) else value
    return out


def _plant_table(truth: PlantTruth) -> dict:
    table = _table_of(dataclasses.replace(truth, random={}))
    table.pop("random", None)
    if truth.random:
        table["random"] = {k: list(v) for k, v in truth.random.items()}
    return table


def _plant(rd: TomlReader, raw) -> PlantTruth:
    """The ``[plant]`` table: :class:`PlantTruth` fields, and ``[plant.random]`` ranges."""
    table = dict(rd.table(raw, "plant"))
    random = rd.table(table.pop("random", {}), "plant.random")
    ranges = {}
    for name, bounds in random.items():
        pair = rd.array(bounds, f"plant.random.{name}", 1)
        if len(pair) != 2:
            raise rd.error(f"plant.random.{name}", f"expected [low, high], got {bounds!r}",
                           value=bounds)
        ranges[name] = (float(pair[0]), float(pair[1]))
    truth = _dataclass_table(rd, table, "plant", PlantTruth)
    if not ranges:
        return truth
    try:
        return dataclasses.replace(truth, random=ranges)
    except InkarmError as e:
        raise ScenarioError(e.message, key=e.key, value=e.value,
                            choices=e.choices).within(file=rd.source, key="plant") from None


def _set_dotted(data: dict, dotted: str, value) -> None:
    """``data[a][b][c] = value`` for ``dotted = "a.b.c"``, creating tables on the way; a key
    that cannot exist is refused by the parse that follows, with its closest valid key."""
    parts = dotted.split(".")
    if not all(parts):
        raise ScenarioError("expected a dotted key like controller.force_n", file="overrides",
                            key=dotted, value=dotted)
    table = data
    for part in parts[:-1]:
        if part not in table:
            table[part] = {}
        elif not isinstance(table[part], dict):
            raise ScenarioError(f"{part!r} is a value, not a table", file="overrides",
                                key=dotted, value=value)
        table = table[part]
    table[parts[-1]] = copy.deepcopy(value)


def load_scenario(path: str | Path | None = None) -> Scenario:
    """Read and check the scenario at ``path``; the embedded default when None."""
    path = Path(path) if path is not None else DEFAULT_SCENARIO
    data = load_toml(path, "scenario file")
    return parse_scenario(data, source=str(path), base_dir=path.parent)


def _dataclass_table(rd: TomlReader, table: dict, key: str, cls):
    """An instance of dataclass ``cls`` from ``table``, each value checked as its field's
    default suggests (numbers, booleans, strings, arrays of numbers); the class's own checks
    name ``key`` and the field."""
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
                raise rd.error(where, f"expected {len(default)} numbers, got {len(arr)}",
                               value=value)
            out[name] = tuple(float(v) for v in arr)
        elif isinstance(value, list):
            out[name] = tuple(float(v) for v in rd.array(value, where, 1))
        else:
            out[name] = rd.number(value, where)
    try:
        return cls(**out)
    except InkarmError as e:
        if e.key is None or e.key.split(".")[0] not in fields:
            e.key = None
        raise ScenarioError(e.message, key=e.key, value=e.value,
                            choices=e.choices).within(file=rd.source, key=key) from None


def _placement(rd: TomlReader, raw) -> Placement:
    table = rd.table(raw, "placement")
    rd.keys(table, PLACEMENT_KEYS, "placement")
    if "height_mm" in table and "scale" in table:
        raise rd.error("placement", "give one of height_mm and scale, not both")
    kw: dict[str, Any] = {}
    if "centre_mm" in table:
        c = rd.array(table["centre_mm"], "placement.centre_mm", 1)
        if np.any(np.abs(c) > 1e4):
            raise rd.error("placement.centre_mm", f"expected numbers in [-1e4, 1e4] mm, got "
                           f"{c.tolist()}", value=table["centre_mm"])
        if c.shape != (2,):
            raise rd.error("placement.centre_mm", f"expected [x, y], got {len(c)} numbers",
                           value=table["centre_mm"])
        kw["centre_mm"] = (float(c[0]), float(c[1]))
    for name, maximum in PLACEMENT_MAXIMA.items():
        if name in table:
            kw[name] = rd.number(table[name], f"placement.{name}", 0.0, strict=True,
                                 maximum=maximum)
    if "rotation_deg" in table:
        kw["rotation_deg"] = rd.number(table["rotation_deg"], "placement.rotation_deg", -3600.0,
                                       maximum=3600.0)
    return Placement(**kw)


def _robot(rd: TomlReader, raw, base_dir: Path):
    table = rd.table(raw, "robot")
    rd.keys(table, ROBOT_KEYS, "robot")
    if "name" in table and "file" in table:
        raise rd.error("robot", "give one of name (a built-in robot) and file (a profile)")
    if "file" in table:
        file = base_dir / rd.text(table["file"], "robot.file")
        if not file.is_file():
            raise rd.error("robot.file", f"no such file: {file}", value=table["file"])
        ref = str(file.resolve())
    else:
        ref = rd.choice(table.get("name", DEFAULT_ROBOT), "robot.name", robot_names())
    profile = load_robot(ref)
    gains = rd.table(table.get("gains", {}), "robot.gains")
    rd.keys(gains, GAIN_KEYS, "robot.gains")
    vectors = {k: gain_vector(rd, v, f"robot.gains.{k}", profile.n) for k, v in gains.items()}
    if vectors:
        try:
            profile = profile.with_gains(**vectors)
        except InkarmError as e:
            raise e.within(file=rd.source, key="robot") from None
    overrides = tuple((k, tuple(float(x) for x in np.atleast_1d(gains[k]))) for k in gains)
    return profile, ref, overrides


def parse_scenario(data: dict, source: str = "scenario", base_dir: str | Path = ".") -> Scenario:
    """Check parsed TOML ``data`` (see the module docstring); errors name ``source`` and the key."""
    rd = TomlReader(source)
    rd.keys(data, TOP_KEYS, "")
    if "source" not in data:
        raise rd.error("source", "required: a [source] table saying what to draw")
    base_dir = Path(base_dir)
    ink = dict(rd.table(data.get("ink", {}), "ink"))
    ink_model = rd.choice(ink.pop("model", "marker"), "ink.model", tuple(INK_MODELS))
    px_per_mm = rd.number(ink.pop("px_per_mm", 10.0), "ink.px_per_mm", 0.0, strict=True)
    if px_per_mm > MAX_PX_PER_MM:
        raise rd.error("ink.px_per_mm", f"expected at most {MAX_PX_PER_MM:g} (a finer raster of a "
                       f"sheet does not fit in memory), got {px_per_mm:g}", value=px_per_mm)
    robot, robot_ref, gain_overrides = _robot(rd, data.get("robot", {}), base_dir)
    return Scenario(
        path=source,
        base_dir=base_dir,
        title=rd.text(data.get("title", Path(source).stem), "title"),
        seed=rd.integer(data.get("seed", 0), "seed", 0, 2**63 - 1),
        source=parse_source(rd, data["source"], base_dir),
        placement=_placement(rd, data.get("placement", {})),
        robot=robot,
        robot_ref=robot_ref,
        gain_overrides=gain_overrides,
        cell=_dataclass_table(rd, rd.table(data.get("cell", {}), "cell"), "cell", CellConfig),
        controller=_dataclass_table(rd, rd.table(data.get("controller", {}), "controller"),
                                    "controller", LoopConfig),
        ink=InkSpec(ink_model, _dataclass_table(rd, ink, "ink", INK_MODELS[ink_model]), px_per_mm),
        plant=_plant(rd, data.get("plant", {})),
    )


def source_drawing(scenario: Scenario) -> Drawing:
    """The drawing the source describes, in its own coordinates [mm] and times [s]."""
    try:
        return scenario.source.drawing(scenario.seed, scenario.path)
    except ScenarioError:
        raise
    except InkarmError as e:
        raise e.within(file=scenario.path, key="source") from None


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


__all__ = ["InkSpec", "Placement", "Scenario", "load_scenario", "parse_scenario", "place"]
