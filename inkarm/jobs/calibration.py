"""Calibration in jobs: which calibration a scenario's controller believes, and ``inkarm
calibrate paper`` as a library call.

A scenario's top-level ``calibration`` (:mod:`inkarm.jobs.scenario`) names a calibration file,
``"auto"`` (:func:`inkarm.robots.calibration.calibration_path` of its robot, when that file
exists) or, in memory, a :class:`~inkarm.robots.calibration.CellCalibration`. Every backend
builds the controller's model with :func:`believed_model`, which applies it
(:func:`inkarm.sim.cell.kinematic_model`) and says in a run note which one it used.

:func:`calibrate_paper` probes the sheet at dots along the scenario's own drawing, through the
one assembly (:func:`inkarm.jobs.backends.run_backend`, any backend whose arm senses the pen
force), and fits the sheet's height map (:mod:`inkarm.control.calibration.paper`).
:func:`update_calibration` merges a result into the robot's calibration file.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from inkarm.core.trajectory import Drawing
from inkarm.errors import InputError
from inkarm.jobs.scenario import Placement, Scenario, load_scenario, place, source_drawing
from inkarm.robots.calibration import (
    CellCalibration,
    HeightMap,
    calibration_path,
    read_calibration,
    write_calibration,
)
from inkarm.sim.cell_config import Cell

if TYPE_CHECKING:  # (MuJoCo's types: a plotter's job reads a scenario without MuJoCo)
    from inkarm.robots.geometry import GeometryErrors
    from inkarm.robots.kinematic import KinematicModel

Progress = Callable[[float, str], None] | None
DWELL_S = 0.1  # how long a paper probe holds each dot once settled [s]: its last half is read
PARTS = ("paper", "pen", "kinematics")
# The dashes' thin-plate spline lambda: their samples scatter by 0.1-0.25 mm (the servos' ticks,
# backlash), so a stiffer spline than the settled touches' 1e-3, whose wiggles between samples
# put the wx250s's pen 0.02 N out of its force band in the simulation (10: inside it).
DASH_SMOOTHING = 10.0


def scenario_calibration(scenario: Scenario) -> tuple[CellCalibration | None, str | None]:
    """The calibration ``scenario`` asks for and the run note that says so: (None, None) when
    it asks for none; ``"auto"`` without a file: (None, a note saying where none was found).
    A calibration of another robot is refused (InputError naming ``calibration``)."""
    spec = scenario.calibration
    if spec is None:
        return None, None
    robot = scenario.robot.name
    if isinstance(spec, CellCalibration):
        cal, where = spec, "in memory"
    else:
        path = calibration_path(robot) if spec == "auto" else Path(spec)
        if spec == "auto" and not path.is_file():
            return None, f"calibration: none (auto: no file {path}); the nominal cell"
        cal, where = read_calibration(path), str(path)
    if cal.robot != robot:
        raise InputError(f"the calibration ({where}) was measured on robot {cal.robot!r}, "
                         f"the scenario's robot is {robot!r}", key="calibration",
                         value=str(spec) if isinstance(spec, str) else cal.robot)
    n = len(scenario.robot.joint_names)
    for name in ("link_length_mm", "joint_offset_deg"):
        values = getattr(cal.geometry, name)
        if len(values) not in (0, n):
            raise InputError(f"expected {n} numbers (one per joint of {robot}), got "
                             f"{len(values)}", key=f"geometry.{name}", value=list(values),
                             file=where)
    return cal, f"calibration: {where}: {cal.describe()}"


def believed_model(scenario: Scenario, cell: Cell) -> tuple[KinematicModel, tuple[str, ...]]:
    """The controller's model of ``cell`` with the scenario's calibration applied, and the
    run notes naming it (none without a calibration: the nominal cell, as before)."""
    from inkarm.sim.cell import kinematic_model

    cal, note = scenario_calibration(scenario)
    model = kinematic_model(cell) if cal is None else kinematic_model(cell, cal)
    return model, (() if note is None else (note,))


def with_calibration(scenario: Scenario,
                     calibration: CellCalibration | str | Path | None) -> Scenario:
    """``scenario`` believing ``calibration``: one in memory, a file (read and checked now),
    ``"auto"``, or None (the nominal cell)."""
    if isinstance(calibration, Path) or (isinstance(calibration, str) and calibration != "auto"):
        path = Path(calibration).expanduser().resolve()
        read_calibration(path)
        calibration = str(path)
    elif calibration is not None and not isinstance(calibration, (CellCalibration, str)):
        raise InputError(f"expected a CellCalibration, a file, 'auto' or None, got "
                         f"{type(calibration).__name__}", key="calibration")
    return dataclasses.replace(scenario, calibration=calibration)


def without(cal: CellCalibration, part: str) -> CellCalibration:
    """``cal`` without the ``part`` a calibration routine measures: ``paper`` (the map),
    ``pen`` (the tip offset) or ``kinematics`` (link lengths and joint offsets), so that the
    routine's probe believes the rest and finds that part against the nominal model."""
    g = cal.geometry
    if part == "paper":
        return dataclasses.replace(cal, paper=None)
    if part == "pen":
        return dataclasses.replace(cal, geometry=dataclasses.replace(g, tip_offset_mm=(0.0,) * 3))
    if part == "kinematics":
        return dataclasses.replace(cal, geometry=dataclasses.replace(
            g, link_length_mm=(), joint_offset_deg=()))
    raise InputError(f"unknown part {part!r}; expected one of {', '.join(PARTS)}", key="part",
                     value=part, choices=PARTS)


def believing(scenario: Scenario, path: str | Path, part: str) -> Scenario:
    """The scenario a calibration routine for ``part`` probes with: believing the calibration
    file ``path`` it will merge into when that exists (else the scenario's own calibration),
    :func:`without` ``part``. A file of another robot is refused before anything moves."""
    path = Path(path)
    if path.is_file():
        cal = read_calibration(path)
        if cal.robot != scenario.robot.name:
            raise InputError(f"{path} is the calibration of robot {cal.robot!r}, not "
                             f"{scenario.robot.name!r} (give another --out)", key="--out",
                             value=str(path))
    else:
        cal, _ = scenario_calibration(scenario)
    return with_calibration(scenario, None if cal is None else without(cal, part))


@dataclass(frozen=True, eq=False)
class PageSource:
    """A source that is a drawing already on the page [mm] (:func:`drawing_scenario`); not a
    TOML kind, so a scenario with it takes no :meth:`~Scenario.with_overrides` (apply them
    first)."""

    page: Drawing
    kind: ClassVar[str] = "page"

    def drawing(self, seed: int, where: str) -> Drawing:
        return self.page


def drawing_scenario(scenario: Scenario, drawing: Drawing, title: str | None = None) -> Scenario:
    """``scenario`` drawing exactly ``drawing``, page coordinates [mm] and times [s] as given
    (the placement only centres its bounding box where it is), with everything else its own."""
    lo, hi = drawing.bounds()
    centre = 0.5 * (lo[:2] + hi[:2])
    return dataclasses.replace(
        scenario, source=PageSource(drawing), title=title or scenario.title,
        placement=Placement(centre_mm=(float(centre[0]), float(centre[1]))))


@dataclass(frozen=True, eq=False)
class PaperProbe:
    """What :func:`probe_paper` found.

    Attributes:
        map: The fitted height map (page frame [mm]).
        points_mm: (k, 3) settled touches: page x, y, height [mm].
        missed: Dots that never settled.
        dots: How many dots were probed.
        residual_rms_mm: RMS of the map at the touches minus the touches [mm].
        run: The probe run (status, log, notes).
    """

    map: HeightMap
    points_mm: np.ndarray
    missed: tuple[int, ...]
    dots: int
    residual_rms_mm: float
    run: Any

    def summary(self) -> str:
        """Samples, range of heights and residual in words."""
        lo, hi = self.map.range_mm
        z = self.points_mm[:, 2]
        missed = f", {len(self.missed)} did not settle" if self.missed else ""
        return (f"{len(self.points_mm)} of {self.dots} touches{missed}; heights "
                f"{z.min():+.3f}..{z.max():+.3f} mm at the touches, map {lo:+.3f}..{hi:+.3f} mm "
                f"on {self.map.shape[1]}x{self.map.shape[0]} points; RMS residual "
                f"{self.residual_rms_mm:.4f} mm")


def probe_paper(scenario: Scenario | str | Path | None = None, backend: str = "sim",
                options=None, spacing_mm: float = 10.0, progress: Progress = None,
                smoothing: float = 1e-3, pattern: str = "path",
                dwell_s: float = DWELL_S) -> PaperProbe:
    """Probe the sheet at dots every ``spacing_mm`` along ``scenario``'s placed drawing
    (``pattern="path"``; ``"grid"``: on a grid over it, :func:`inkarm.control.probe.
    probe_drawing`, each dot :func:`held` ``dwell_s``) on ``backend`` and fit its height map
    (:mod:`inkarm.control.calibration.paper`); ``smoothing``: the spline's lambda. The probe
    believes the scenario's calibration without its paper map (the map found is relative to the
    model's flat sheet, through the calibrated geometry). Raises InputError when the run fails
    or too few dots settle."""
    from inkarm.control.calibration.paper import contact_heights, fit_height_map, residual_rms_mm
    from inkarm.control.probe import probe_drawing
    from inkarm.jobs.backends import get_backend, run_backend

    if not getattr(get_backend(backend), "senses_force", True):
        raise InputError(f"the {backend} backend senses no pen force: probing the paper needs "
                         "a force sensor (the simulated arm has one; without one, "
                         "probe_paper_marks reads the sheet from ramped dashes' ink)",
                         key="--backend", value=backend)
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    cell = Cell(scenario.cell, scenario.robot)
    cal, _ = scenario_calibration(scenario)
    if cal is not None:
        scenario = with_calibration(scenario, dataclasses.replace(cal, paper=None))
    # (the probe run checks its own budgets; jobs.preflight imports this module)
    drawing = place(source_drawing(scenario), scenario.placement, cell.paper_size_mm)
    dots = held(probe_drawing(drawing, spacing_mm, pattern), dwell_s)
    probe = drawing_scenario(scenario, dots, title=f"paper probe of {scenario.title}")
    result = run_backend(backend, probe, options, progress=progress)
    if not result.finished:
        raise InputError(f"the probe run failed: {result.reason}", key="calibrate paper")
    believed, _ = believed_model(probe, cell)
    c = scenario.controller
    count = len(dots.strokes)
    touches = contact_heights(result.log, believed, count, c.force_n, c.settle_tol_n)
    try:
        fitted = fit_height_map(touches.points_mm, spacing_mm, smoothing)
    except InputError as e:
        raise InputError(f"{len(touches.points_mm)} of {count} dots settled: {e.message}",
                         key="calibrate paper") from None
    return PaperProbe(fitted, touches.points_mm, touches.missed, count,
                      residual_rms_mm(fitted, touches.points_mm), result)


@dataclass(frozen=True, eq=False)
class DrawnDashes:
    """A :func:`draw_dashes` probe as drawn: ``dashes`` (their layout and ramp), the ``run``
    (log, canvas), the controller's model it believed (``believed``: its geometry, without a
    map), the ink's ``canvas`` model, the dashes' row ``spacing_mm`` and the ``range_mm``."""

    dashes: Any
    run: Any
    believed: Any
    canvas: Any
    spacing_mm: float
    range_mm: tuple[float, float]


def draw_dashes(scenario: Scenario | str | Path | None = None, backend: str = "sim",
                options=None, spacing_mm: float = 10.0, progress: Progress = None,
                range_mm: tuple[float, float] = (-0.5, 5.0), length_mm: float = 12.0,
                speed_mm_s: float = 10.0, runner=None) -> DrawnDashes:
    """Draw the paper probe of an arm that senses no pen force (a Dynamixel arm, or any arm):
    dashes over ``scenario``'s placed drawing while the pen's aimed height ramps down through
    ``range_mm`` (low, high: where the sheet may be relative to the model's sheet [mm], pen
    length errors included; :class:`~inkarm.control.calibration.paper.RampDashes`), rows
    ``spacing_mm`` apart, over the drawing's box widened by half a dash and half a spacing
    (each dash gives one sample, where it met the sheet: so that those reach the box's edges). The ramp is a height map the probe believes (the scenario's
    calibration without its own map); the force loop is off (nothing is sensed, or what is
    sensed is not used: the same probe on every arm). ``runner(scenario, progress) -> Run``
    draws it on some device (e.g. an emulator: ``hil_run(..., truth=True)``; default
    :func:`~inkarm.jobs.backends.run_backend` on ``backend``). Raises InputError when the run
    fails."""
    from inkarm.control.calibration.paper import RampDashes
    from inkarm.control.sequencing import pen_depth_mm
    from inkarm.jobs.backends import run_backend

    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    cell = Cell(scenario.cell, scenario.robot)
    cal, _ = scenario_calibration(scenario)
    base = dataclasses.replace(cal if cal is not None else CellCalibration(scenario.robot.name),
                               paper=None)
    drawing = place(source_drawing(scenario), scenario.placement, cell.paper_size_mm)
    lo, hi = drawing.bounds()
    margin = np.array([0.5 * length_mm, 0.5 * spacing_mm])  # (so that contacts reach its edges)
    dashes = RampDashes.over(lo[:2] - margin, hi[:2] + margin, spacing_mm, length_mm, range_mm,
                             speed_mm_s)
    believed, _ = believed_model(with_calibration(scenario, base), cell)
    c = dataclasses.replace(
        scenario.controller, force_gain_mm_per_ns=0.0, settle_timeout_s=0.0,
        search_speed_mm_s=1e-6, probe_paper=False, surface_lead_s=0.0, surface_cell_mm=0.0,
        map_lead_s=0.0)
    depth = pen_depth_mm(c, believed.pen_stiffness_n_per_mm, believed.pen_travel_mm,
                         believed.pen_preload_n, believed.paper_stiffness_n_per_mm)
    probe = drawing_scenario(dataclasses.replace(scenario, controller=c),
                             dashes.drawing(cell.paper_size_mm),
                             title=f"paper probe (ramped dashes) of {scenario.title}")
    probe = with_calibration(probe, dataclasses.replace(base, paper=dashes.aim_map(depth)))
    result = (runner(probe, progress) if runner is not None
              else run_backend(backend, probe, options, progress=progress))
    if not result.finished:
        raise InputError(f"the probe run failed: {result.reason}", key="calibrate paper")
    canvas = result.canvas if result.canvas is not None else scenario.ink.canvas(
        cell.paper_size_mm)
    return DrawnDashes(dashes, result, believed, canvas, float(spacing_mm),
                       tuple(float(v) for v in range_mm))


def save_dashes(drawn: DrawnDashes, scenario: Scenario, path: str | Path) -> Path:
    """Write a :func:`draw_dashes` of ``scenario`` to a drawn file
    (:mod:`inkarm.jobs.calibration_files`): the dashes (``starts_mm`` (k, 2) [mm], their
    length, ramp and speed), the run's log (joint readings, force, phases, strokes), the rows'
    ``spacing_mm`` and ``range_mm``; the calibration it believed (without a map). Returns the
    path."""
    from inkarm.jobs.calibration_files import log_arrays, save_drawn

    d = drawn.dashes
    base, _ = scenario_calibration(scenario)
    base = dataclasses.replace(base, paper=None) if base is not None else None
    arrays = {"starts_mm": d.starts_mm,
              "dash": np.array([d.length_mm, d.top_mm, d.bottom_mm, d.speed_mm_s]),
              "spacing_mm": np.array(drawn.spacing_mm), "range_mm": np.array(drawn.range_mm),
              **log_arrays(drawn.run.log)}
    return save_drawn(path, "paper", scenario, base, arrays)


def load_dashes(path: str | Path, robot: str | None = None) -> tuple[DrawnDashes, Scenario]:
    """The :class:`DrawnDashes` of a file by :func:`save_dashes` (a blank canvas: its ink comes
    from a scan, ``read_dashes(drawn, image, corners_px)``) and its scenario."""
    from inkarm.control.calibration.paper import RampDashes
    from inkarm.jobs.calibration_files import SavedRun, load_drawn, saved_log

    drawn = load_drawn(path, "paper", robot)
    a, scenario = drawn.arrays, drawn.scenario
    cell = Cell(scenario.cell, scenario.robot)
    length, top, bottom, speed = (float(v) for v in a["dash"])
    dashes = RampDashes(a["starts_mm"], length, top, bottom, speed)
    believed, _ = believed_model(scenario, cell)
    lo, hi = (float(v) for v in a["range_mm"])
    return DrawnDashes(dashes, SavedRun(saved_log(a)), believed,
                       scenario.ink.canvas(cell.paper_size_mm), float(a["spacing_mm"]),
                       (lo, hi)), scenario


def read_dashes(drawn: DrawnDashes, image=None, corners_px=None,
                smoothing: float = DASH_SMOOTHING) -> PaperProbe:
    """The sheet's height map from drawn dashes (:func:`draw_dashes`): each dash read from where
    its ink starts (:func:`~inkarm.control.calibration.paper.dash_contacts`; the ink's
    threshold force from the scenario's ink model, the contact at it from the believed model's
    own touch), then fitted as :func:`probe_paper` does. The ink is the run's canvas (in
    simulation, or an emulator's twin) unless ``image`` (a scanned or photographed sheet: a
    file or a darkness raster) with its ``corners_px`` gives it
    (:func:`~inkarm.control.calibration.paper.image_ink_mm`): a real arm's. Raises InputError
    when too few dashes met the sheet within the range."""
    from inkarm.control.calibration.paper import (
        dash_contacts,
        fit_height_map,
        image_ink_mm,
        onset_depth_mm,
        residual_rms_mm,
    )
    from inkarm.core.log import DRAW

    if image is not None and corners_px is None:
        raise InputError("an image of the sheet needs its four corners in pixels (lower-left, "
                         "lower-right, upper-right, upper-left)", key="corners_px")
    log, canvas, believed = drawn.run.log, drawn.canvas, drawn.believed
    threshold = ink_threshold_n(canvas.ink)
    radius = 0.5 * canvas.ink.mark(threshold, 0.0)[0]
    middle = np.flatnonzero(log.phase == DRAW)
    onset = onset_depth_mm(believed, log.q[middle[len(middle) // 2]], max(threshold, 0.01))
    ink = (canvas.ink_points_mm() if image is None
           else image_ink_mm(image, corners_px, canvas.size_mm))
    touches = dash_contacts(ink, log, believed, drawn.dashes, radius, onset)
    count = len(drawn.dashes.starts_mm)
    try:
        # (no padding: the samples lie where the dashes met the sheet, inside the drawing's
        # box; a thin-plate spline's slope carried beyond them overshoots)
        fitted = fit_height_map(touches.points_mm, drawn.spacing_mm, smoothing, pad_mm=0.0)
    except InputError as e:
        raise InputError(f"{len(touches.points_mm)} of {count} dashes met the sheet within "
                         f"{drawn.range_mm} mm (widen range_mm): {e.message}",
                         key="calibrate paper") from None
    return PaperProbe(fitted, touches.points_mm, touches.missed, count,
                      residual_rms_mm(fitted, touches.points_mm), drawn.run)


def probe_paper_marks(scenario: Scenario | str | Path | None = None, backend: str = "sim",
                      options=None, spacing_mm: float = 10.0, progress: Progress = None,
                      smoothing: float = DASH_SMOOTHING,
                      range_mm: tuple[float, float] = (-0.5, 5.0),
                      length_mm: float = 12.0, speed_mm_s: float = 10.0,
                      runner=None) -> PaperProbe:
    """The sheet's height map for an arm that senses no pen force, its ink on the run's canvas
    (simulation, an emulator's twin): :func:`draw_dashes`, then :func:`read_dashes`. (A real
    arm's sheet: draw, scan, then ``read_dashes(drawn, image, corners_px)``.)"""
    drawn = draw_dashes(scenario, backend, options, spacing_mm, progress, range_mm, length_mm,
                        speed_mm_s, runner)
    return read_dashes(drawn, smoothing=smoothing)


def ink_threshold_n(ink) -> float:
    """The least force [N] at which ``ink`` (``mark(force_n, speed_mm_s) -> (width,
    opacity)``) lays any (bisection to 1 mN over 0..10 N; 0 for an ink that marks any touch)."""
    if ink.mark(0.0, 0.0)[1] > 0:
        return 0.0
    low, high = 0.0, 10.0
    if ink.mark(high, 0.0)[1] <= 0:
        raise InputError("the ink lays nothing at 10 N: cannot read a touch from its marks",
                         key="ink")
    while high - low > 1e-3:
        mid = 0.5 * (low + high)
        low, high = (low, mid) if ink.mark(mid, 0.0)[1] > 0 else (mid, high)
    return high


def held(dots: Drawing, dwell_s: float) -> Drawing:
    """The dots of ``dots`` (each stroke's first point), each held ``dwell_s`` [s]: long enough
    for the pen and the underlay to come to rest, so that a settled touch is the static one
    :func:`inkarm.control.calibration.paper.touch_curve` reads (a sheet 0.8 mm high reads
    0.84 with 0.05 s on the default cell, 0.80 +- 0.005 with 0.1 s, within 0.02 with 0.2 and
    0.4 s: the pen and the force loop still ring a little)."""
    from inkarm.core.trajectory import Trajectory

    if not (dwell_s > 0 and np.isfinite(dwell_s)):
        raise InputError(f"expected a dwell > 0 s, got {dwell_s}", key="dwell_s", value=dwell_s)
    strokes = [Trajectory(t=np.array([0.0, dwell_s]), pos=np.array([s.pos[0], s.pos[0]]))
               for s in dots.strokes]
    return Drawing(strokes, page_size=dots.page_size)


def calibrate_paper(scenario: Scenario | str | Path | None = None, backend: str = "sim",
                    options=None, spacing_mm: float = 10.0, progress: Progress = None,
                    pattern: str = "path") -> HeightMap:
    """The sheet's height map under ``scenario``'s drawing (:func:`probe_paper`)."""
    return probe_paper(scenario, backend, options, spacing_mm, progress, pattern=pattern).map


def update_calibration(robot: str, path: str | Path | None = None, *,
                       paper: HeightMap | None = None, geometry: GeometryErrors | None = None,
                       note: str | None = None) -> tuple[CellCalibration, Path]:
    """Merge a result into the calibration file ``path`` (default the robot's
    :func:`calibration_path`): read it when present, replace what is given (``paper``,
    ``geometry``), keep the rest, add ``note``; write it. A file of another robot is refused."""
    path = Path(path) if path is not None else calibration_path(robot)
    cal = read_calibration(path) if path.is_file() else CellCalibration(robot)
    if cal.robot != robot:
        raise InputError(f"{path} is the calibration of robot {cal.robot!r}, not {robot!r} "
                         "(give another --out)", key="--out", value=str(path))
    changes: dict[str, Any] = {}
    if paper is not None:
        changes["paper"] = paper
    if geometry is not None:
        changes["geometry"] = geometry
    if note:
        changes["notes"] = (*cal.notes, note)
    cal = dataclasses.replace(cal, **changes)
    return cal, write_calibration(cal, path)


__all__ = ["DASH_SMOOTHING", "DWELL_S", "PARTS", "DrawnDashes", "PageSource", "PaperProbe",
           "believed_model", "believing", "calibrate_paper", "draw_dashes", "drawing_scenario",
           "held", "ink_threshold_n", "load_dashes", "probe_paper", "probe_paper_marks",
           "read_dashes", "save_dashes", "scenario_calibration", "update_calibration",
           "with_calibration", "without"]
