"""Scenarios: a drawing job in TOML, checked key by key once, into a typed :class:`Scenario`.

:func:`inkarm.jobs.run.run` draws one in memory; :func:`inkarm.jobs.outputs.write_run` writes
its files. The same scenario and seed give the same canvas and metrics, run after run (the
wall-clock real-time factor aside). :meth:`Scenario.with_overrides` changes dotted keys and
checks them exactly as the TOML would be.

Schema (lengths [mm], times [s], forces [N], angles [deg]; every key optional unless marked)::

    title = "Letter N"
    seed  = 0                      # seeds every random choice of the source
    calibration = "auto"           # what the controller believes of the cell instead of the
                                   # nominal (inkarm.robots.calibration): a file written by
                                   # `inkarm calibrate`, relative to the scenario file, or
                                   # "auto": the robot's file in the user's configuration
                                   # folder when there is one; default none

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
    # or laid out as vpype's layout (inkarm.plans.page), instead of centre_mm:
    page_size = "a4"               # a0-a6, letter, legal, executive, tabloid, "WxH" with a
                                   # unit ("210x297mm", "8.5x11in") or [w, h] mm: the plotter's
                                   # sheet (the simulated cell's paper stays [sim]'s)
    landscape = false              # the page's orientation (portrait unless true, as vpype);
                                   # page_size and landscape set the plotter's sheet
    fit_to_margins_mm = 10.0       # scale the drawing (aspect kept) to the page less this
                                   # margin (not with height_mm or scale)
    align = "center"               # "left", "center", "right" within the margins
    valign = "center"              # "top", "center", "bottom"

    [controller]                   # inkarm.control.config.LoopConfig fields, e.g.
    force_n = 1.0
    law = "position"               # the control law: "position", "joint_pid", "impedance",
                                   # "sensorimotor", a plug-in's, or "package.module:Class"
    watchdogs = []                 # watchdogs added to the built-ins, named the same ways
    [controller.position]          # the law's own settings (its class's keyword arguments)
    friction_adaptation = 2e4      # (a watchdog's in [controller."<its name>"])

    [ink]
    model = "marker"               # "marker", "brush", "pencil", a plug-in's ink.<name> or
                                   # "package.module:Class" (inkarm.ink.inks)
    px_per_mm = 10.0               # raster resolution; other keys go to the ink model

    [judge]                        # the bounds of an "ok" run (inkarm.core.run.Bounds); a
                                   # finished run that misses one is "degraded", naming it
    tracking_rms_mm = 0.3          # pen to reference while drawing, RMS ...
    tracking_max_mm = 1.0          # ... and at worst
    ink_chamfer_mm = 0.3           # ink centreline to plan (chamfer distance)
    gap_mm = 0.0                   # total length of the strokes drawn without contact
    force_band_n = 0.1             # the force's 1st..99th percentile while drawing within
                                   # force_n +- this
    force_error_n = 0.05           # mean contact force within force_n +- this
                                   # (a bound on what the backend cannot sense, such as a
                                   # Dynamixel arm's pen force, is listed as not judged)

One table per backend says how the job reaches that device; the tables above are the job, the
same for every backend::

    [sim]                          # the simulated cell: inkarm.sim.cell_config.CellConfig
    paper_size_mm = [210.0, 297.0] # fields (0.2 called this table [cell])
    paper_centre_mm = [600.0, 0.0] # robot base frame
    timestep = 0.002
    [sim.plant]                    # how the simulated plant differs from the controller's
    paper_height_mm = 1.5          # model (inkarm.sim.imperfections.PlantTruth; 0.2: [plant])
    [sim.plant.random]             # ranges drawn from sim.plant.seed, for ensembles
    mass_scale = [0.8, 1.2]

    [dynamixel]                    # keys of the robot profile's [backends.dynamixel] to change
    latency_ms = 24                # (inkarm.hardware.dynamixel.config), and
    calibration = "arm_cal.toml"   # the arm's joint zeros (default: `inkarm calibrate joints`'s
                                   # <config>/calibration/<robot>.joints.toml)

    [plotter]
    profile = "servo"              # the pen profile: "servo", "z" or a file
    page_origin = "lower-left"     # where the sheet goes, and whether to home: replace the
    homing = "auto"                # pen profile's (inkarm.hardware.plotter.workspace)

    [axidraw]
    profile = "v3_a3"              # the AxiDraw profile: "v3" (default), "v3_a3" or a file
    page_origin = [0.0, 0.0]       # the sheet's upper-left corner in machine mm (the profile's)

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
from inkarm.control.laws import DEFAULT_LAW, LawSpec
from inkarm.control.watchdogs import WatchdogSpec
from inkarm.core.run import Bounds
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InkarmError, InputError, ScenarioError
from inkarm.ink.canvas import Canvas
from inkarm.ink.inks import INKS, ink_class
from inkarm.io.toml import TomlReader, load_toml
from inkarm.jobs.scenario_tables import (
    OLD_SIM_TABLES,
    controller_table,
    dataclass_table,
    plant_table,
    read_backend_tables,
    read_calibration_key,
    read_controller,
    read_dynamixel,
    read_sim,
    table_of,
    thawed,
)
from inkarm.jobs.sources import Source, parse_source, source_table
from inkarm.plans.page import LAYOUT_KEYS, Layout, lay_out, oriented, read_layout_keys
from inkarm.robots.profile import GAIN_KEYS, RobotProfile, gain_vector
from inkarm.robots.registry import DEFAULT_ROBOT, load_robot, robot_names
from inkarm.sim.cell_config import CellConfig
from inkarm.sim.imperfections import PlantTruth

TOP_KEYS = ("title", "seed", "calibration", "source", "placement", "robot", "controller", "judge", "ink",
            "sim", "dynamixel", "plotter", "axidraw", "cell", "plant")
PLACEMENT_KEYS = ("centre_mm", "height_mm", "scale", "rotation_deg", "time_scale", *LAYOUT_KEYS)
ROBOT_KEYS = ("name", "file", "gains")
# Upper bounds of the placement's scalings: a sheet is at most 2 m, a drawing at most 1000x its
# source, at most 100x slower.
PLACEMENT_MAXIMA = {"height_mm": 2000.0, "scale": 1000.0, "time_scale": 100.0}
MAX_PX_PER_MM = 40.0  # finer than any pen; the raster's memory has its own budget (ink.canvas)
DEFAULT_SCENARIO = Path(__file__).parents[1] / "data" / "default.toml"


@dataclass(frozen=True)
class Placement:
    """Where and how large the drawing lands on the page. Lengths [mm], angles [deg]; the
    layout keys (``page_size`` [mm] before orientation, ``landscape``, ``fit_to_margins_mm``,
    ``align``, ``valign``) lay it out as vpype's ``layout`` (:mod:`inkarm.plans.page`)."""

    centre_mm: tuple[float, float] | None = None
    height_mm: float | None = None
    scale: float = 1.0
    rotation_deg: float = 0.0
    time_scale: float = 1.0
    page_size: tuple[float, float] | None = None
    landscape: bool = False
    fit_to_margins_mm: float | None = None
    align: str | None = None
    valign: str | None = None

    @property
    def lays_out(self) -> bool:
        """Whether the drawing is laid out as vpype's ``layout`` (a page, a fit or an
        alignment given), not centred on ``centre_mm``."""
        return any(getattr(self, k) not in (None, False) for k in LAYOUT_KEYS)

    def sheet_mm(self, paper_mm: tuple[float, float]) -> tuple[float, float]:
        """The page [mm] the layout names, oriented (``paper_mm`` when it names none)."""
        if self.page_size is None and not self.landscape:
            return (float(paper_mm[0]), float(paper_mm[1]))
        return oriented(self.page_size or paper_mm, self.landscape)


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
            ink_class(self.model)()

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
        calibration: None, ``"auto"``, a calibration file (absolute), or a
            :class:`~inkarm.robots.calibration.CellCalibration` in memory (library use; kept
            by :meth:`with_overrides`, not written by :meth:`to_dict`).
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
    law: LawSpec = field(default_factory=LawSpec)
    watchdogs: tuple[WatchdogSpec, ...] = ()
    judge: Bounds = field(default_factory=Bounds)
    dynamixel: tuple[tuple[str, Any], ...] = ()
    plotter_profile: str | None = None
    plotter_placement: tuple[tuple[str, Any], ...] = ()  # [plotter] page_origin, homing
    axidraw: tuple[tuple[str, Any], ...] = ()  # [axidraw] profile, page_origin
    calibration: Any = None

    def to_dict(self) -> dict:
        """The TOML tables that parse back to this scenario (file names absolute)."""
        robot: dict[str, Any] = ({"file": self.robot_ref} if self.robot_ref.endswith(".toml")
                                 else {"name": self.robot_ref})
        if self.gain_overrides:
            robot["gains"] = {k: list(v) if len(v) > 1 else v[0] for k, v in self.gain_overrides}
        calibration = ({"calibration": self.calibration}
                       if isinstance(self.calibration, str) else {})
        return {
            "title": self.title,
            "seed": self.seed,
            **calibration,
            "source": source_table(self.source),
            "placement": table_of(self.placement),
            "robot": robot,
            "sim": {**table_of(self.cell), "plant": plant_table(self.plant)},
            "controller": controller_table(self.controller, self.law, self.watchdogs),
            "ink": {"model": self.ink.model, "px_per_mm": self.ink.px_per_mm,
                    **table_of(self.ink.params)},
            "judge": table_of(self.judge),
            "dynamixel": {k: thawed(v) for k, v in self.dynamixel},
            "plotter": ({} if self.plotter_profile is None else {"profile": self.plotter_profile})
            | {k: thawed(v) for k, v in self.plotter_placement},
            "axidraw": {k: thawed(v) for k, v in self.axidraw},
        }

    def with_overrides(self, overrides: dict[str, Any]) -> Scenario:
        """This scenario with dotted keys replaced (``{"controller.force_n": 1.5,
        "robot.gains.kp": [...]}``), checked by the same rules as the TOML: an unknown key is
        refused with the closest valid one, a bad value with the message the file would get."""
        data = copy.deepcopy(self.to_dict())  # the tables may be this scenario's own
        own = set(data["controller"]) - set(table_of(self.controller))  # law, watchdog tables
        touched = set()
        for dotted, value in overrides.items():
            parts = _split_dotted(dotted)
            if parts[0] in OLD_SIM_TABLES and len(parts) > 1:  # the 0.2 spelling of [sim] keys
                parts = [*OLD_SIM_TABLES[parts[0]].split("."), *parts[1:]]
            if parts[0] == "controller" and len(parts) > 1:
                touched.add(parts[1])
            _set_dotted(data, parts, value, dotted)
        # A law or watchdog replaced by the overrides takes its settings table with it.
        controller = data.get("controller")
        if isinstance(controller, dict):
            names = controller.get("watchdogs", [])
            used = {controller.get("law", DEFAULT_LAW), *(names if isinstance(names, list) else ())}
            for name in own - {"law", "watchdogs"} - used - touched:
                controller.pop(name, None)
        changed = parse_scenario(data, source=f"{self.path} (with overrides)",
                                 base_dir=self.base_dir, overridden=True)
        if isinstance(self.calibration, str) or "calibration" in overrides:
            return changed
        return dataclasses.replace(changed, calibration=self.calibration)  # (one in memory)


def _split_dotted(dotted: str) -> list[str]:
    """The keys of a dotted key, TOML's way: ``controller."mylab.laws:Law".gain`` is
    ``["controller", "mylab.laws:Law", "gain"]``; refused when a key is empty or a quote is not
    closed."""
    parts, part, quoted, was_quoted = [], "", False, False
    for ch in dotted:
        if ch == '"':
            quoted, was_quoted = not quoted, True
        elif ch == "." and not quoted:
            parts.append((part, was_quoted))
            part, was_quoted = "", False
        else:
            part += ch
    parts.append((part, was_quoted))
    if quoted or not all(p or q for p, q in parts):
        raise ScenarioError('expected a dotted key like controller.force_n (a key with dots in '
                            'double quotes: controller."mylab.laws:Law".gain)', file="overrides",
                            key=dotted, value=dotted)
    return [p for p, _ in parts]


def _set_dotted(data: dict, parts: list[str], value, dotted: str) -> None:
    """``data[a][b][c] = value`` for the keys ``parts`` of ``dotted``, creating tables on the
    way; a key that cannot exist is refused by the parse that follows, with its closest valid
    key."""
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
    kw.update(read_layout_keys(rd, table, "placement"))
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


def parse_scenario(data: dict, source: str = "scenario", base_dir: str | Path = ".",
                   overridden: bool = False) -> Scenario:
    """Check parsed TOML ``data`` (see the module docstring); errors name ``source`` and the key.
    ``overridden``: the data are a scenario's own tables with overrides (old table names are
    then taken without a warning)."""
    rd = TomlReader(source)
    rd.keys(data, TOP_KEYS, "")
    if "source" not in data:
        raise rd.error("source", "required: a [source] table saying what to draw")
    base_dir = Path(base_dir)
    ink = dict(rd.table(data.get("ink", {}), "ink"))
    ink_model = ink.pop("model", "marker")  # a name, "package.module:Class" or a plug-in's
    try:
        if not (isinstance(ink_model, str) and ":" in ink_model):
            ink_model = rd.choice(ink_model, "ink.model", INKS.names())
        ink_cls = ink_class(ink_model)
    except InkarmError as e:
        raise e.within(file=rd.source) from None
    px_per_mm = rd.number(ink.pop("px_per_mm", 10.0), "ink.px_per_mm", 0.0, strict=True)
    if px_per_mm > MAX_PX_PER_MM:
        raise rd.error("ink.px_per_mm", f"expected at most {MAX_PX_PER_MM:g} (a finer raster of a "
                       f"sheet does not fit in memory), got {px_per_mm:g}", value=px_per_mm)
    robot, robot_ref, gain_overrides = _robot(rd, data.get("robot", {}), base_dir)
    dynamixel = dict(rd.table(data.get("dynamixel", {}), "dynamixel"))
    if dynamixel:
        robot = read_dynamixel(rd, robot, dynamixel, base_dir)
    return Scenario(
        path=source,
        base_dir=base_dir,
        title=rd.text(data.get("title", Path(source).stem), "title"),
        seed=rd.integer(data.get("seed", 0), "seed", 0, 2**63 - 1),
        calibration=read_calibration_key(rd, data, base_dir),
        source=parse_source(rd, data["source"], base_dir),
        placement=_placement(rd, data.get("placement", {})),
        robot=robot,
        robot_ref=robot_ref,
        gain_overrides=gain_overrides,
        **read_sim(rd, data, warn=not overridden, base_dir=base_dir),
        **read_controller(rd, data.get("controller", {})),
        ink=InkSpec(ink_model, dataclass_table(rd, ink, "ink", ink_cls), px_per_mm),
        judge=dataclass_table(rd, rd.table(data.get("judge", {}), "judge"), "judge", Bounds),
        **read_backend_tables(rd, data, robot, base_dir),
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
    its times by ``placement.time_scale``: centred on ``centre_mm`` (the page's centre by
    default), or laid out as vpype's ``layout`` when the placement names a page, a fit or an
    alignment (:func:`inkarm.plans.page.lay_out`, on ``page_size_mm`` as it is)."""
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
    if placement.lays_out:
        w, h = (float(v) for v in page_size_mm)
        layout = Layout(page_size=(w, h), landscape=w > h,
                        fit_to_margins_mm=placement.fit_to_margins_mm,
                        scale=None if placement.fit_to_margins_mm is not None else scale,
                        align=placement.align or "center", valign=placement.valign or "center",
                        rotation_deg=placement.rotation_deg)
        try:
            laid = lay_out(drawing, layout)
        except InputError as e:
            if e.key == "fit_to_margins":  # (the Layout's name of the key)
                e.key = "fit_to_margins_mm"
            raise e.within(key="placement") from None
        strokes = [Trajectory(t=s.t * placement.time_scale, pos=s.pos, pressure=s.pressure)
                   for s in laid.strokes]
        return Drawing(strokes, page_size=(w, h), meta=dict(drawing.meta))
    target = np.array(placement.centre_mm if placement.centre_mm is not None
                      else (0.5 * page_size_mm[0], 0.5 * page_size_mm[1]))
    a = np.deg2rad(placement.rotation_deg)
    rot = scale * np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    strokes = []
    for s in drawing.strokes:
        pos = (s.pos - centre) @ rot.T + target
        strokes.append(Trajectory(t=s.t * placement.time_scale, pos=pos, pressure=s.pressure))
    return Drawing(strokes, page_size=page_size_mm, meta=dict(drawing.meta))  # (per stroke)


__all__ = ["InkSpec", "Placement", "Scenario", "load_scenario", "parse_scenario", "place"]
