"""``inkarm calibrate kinematics`` as a library call: draw a pattern of dots, find where they
landed, fit the arm's link lengths and joint offsets, and redraw with the corrected model.

1. :func:`draw_pattern`: the pattern (:func:`~inkarm.control.calibration.kinematics.
   dot_pattern`, a grid of dots over the sheet) is drawn as the scenario's drawing through the
   one assembly (:func:`inkarm.jobs.backends.run_backend`), once from the arm's home and, for a
   7-joint arm, once from each of two homes swivelled along its null space
   (:func:`~inkarm.control.calibration.kinematics.swivel_postures`), each grid moved by a third
   of its spacing so that one sheet takes all three. The controller believes the scenario's
   calibration (its geometry is the fit's starting point; its paper map is kept). Per dot: the
   joint readings where the pen rested, the pen's compression and the mark's expected offset
   from that point (:func:`~inkarm.control.calibration.kinematics.dot_readings`).
2. :func:`fit_pattern`: the marks, on the runs' canvases in simulation
   (:func:`~inkarm.control.calibration.marks.canvas_marks`), or, for a real arm, on a scanned or
   photographed sheet with its corners given in pixels
   (:func:`~inkarm.control.calibration.marks.image_marks`), each matched to its planned dot;
   then the fit (:func:`~inkarm.control.calibration.kinematics.fit_kinematics`).
3. :func:`calibrate_kinematics_run`: both, then the scenario's own drawing drawn twice,
   believing the old and the corrected calibration, for the report.

Only the joint readings, the sensed force, the marks and the controller's own model are used:
never the simulated plant's truth (nor ``log.tip``, the true tip that hardware does not sense).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from inkarm.errors import InputError
from inkarm.jobs.calibration import (
    Progress,
    drawing_scenario,
    scenario_calibration,
    with_calibration,
)
from inkarm.jobs.scenario import Scenario, load_scenario
from inkarm.robots.calibration import CellCalibration
from inkarm.robots.geometry import GeometryErrors
from inkarm.sim.cell_config import Cell

Runner = Callable[[Scenario, Progress], Any]  # a scenario's run on some device -> its Run


@dataclass(frozen=True)
class KinematicsOptions:
    """How to calibrate.

    Attributes:
        columns, rows: The dot grid over the sheet.
        margin_mm: The grid's distance from the sheet's edges [mm] (the swivelled postures'
            grids are moved by a third of the grid's spacing into it, at most this far).
        dwell_s: How long the pen rests on each dot [s].
        swivel_deg: Draw the pattern also from homes turned by +- this along the arm's null
            space (a 7-joint arm's elbow): three runs instead of one, and more of the
            parameters identifiable; 0: one run.
        mark_noise_mm: The marks' expected noise [mm]: directions of the parameters that it
            would move by more than a tenth of their scale are not identifiable (the simulated
            canvas at 10 px/mm: about 0.02; a sheet scanned at 600 dpi: about 0.05).
        tracking_limit_mm: The tracking watchdog's limit during the pattern runs [mm] (at
            least the scenario's): an arm not yet calibrated may draw several mm from where it
            believes its pen is.
        redraw: Draw the scenario's drawing before and after, for the report.
        max_shift_mm: How far all marks of a run together may lie from their dots [mm]
            (:func:`fit_pattern`).
    """

    columns: int = 5
    rows: int = 6
    margin_mm: float = 20.0
    dwell_s: float = 0.15
    swivel_deg: float = 45.0
    mark_noise_mm: float = 0.02
    tracking_limit_mm: float = 20.0
    redraw: bool = True
    max_shift_mm: float = 10.0


@dataclass(frozen=True, eq=False)
class DrawnPattern:
    """The pattern as drawn (:func:`draw_pattern`), one entry per home posture.

    Attributes:
        points_mm: The planned dots (k_j, 2) [mm] of each run.
        readings: What each run's log says of its dots
            (:class:`~inkarm.control.calibration.kinematics.DotReadings`).
        runs: The pattern runs (:class:`~inkarm.jobs.outcome.Run`: log, canvas, notes).
        model: The controller's nominal model (:class:`~inkarm.robots.kinematic.
            KinematicModel`) and ``base`` the geometry it believed: the fit starts there.
        calibration: The scenario's calibration when the pattern was drawn (or None).
    """

    points_mm: tuple[np.ndarray, ...]
    readings: tuple[Any, ...]
    runs: tuple[Any, ...]
    model: Any
    base: GeometryErrors
    calibration: CellCalibration | None

    @property
    def match_radius_mm(self) -> float:
        """How far from its planned dot a mark may be [mm]: 0.45 of the closest two planned
        dots of all runs (at most 10 mm)."""
        points = np.vstack(self.points_mm)
        d = np.linalg.norm(points[:, None] - points[None], axis=2)
        return min(0.45 * float(np.min(d[np.triu_indices(len(points), 1)])), 10.0)


def draw_pattern(scenario: Scenario | str | Path | None = None, backend: str = "sim",
                 options=None, settings: KinematicsOptions | None = None,
                 progress: Progress = None, runner: Runner | None = None) -> DrawnPattern:
    """Draw the calibration pattern with the arm of ``scenario`` on ``backend`` (module
    docstring, step 1); ``options`` are the backend's (:class:`inkarm.jobs.backends.
    BackendOptions`). ``runner(scenario, progress) -> Run`` replaces the backend when given
    (a hardware-in-the-loop run whose ink comes back from the emulator's twin:
    ``functools.partial(inkarm.jobs.backends.dynamixel.hil_run, truth=True)``). Raises
    InputError when a pattern run fails or a dot was never pressed."""
    from inkarm.control.calibration.kinematics import (
        TipModel,
        dot_pattern,
        dot_points,
        dot_readings,
        swivel_postures,
    )
    from inkarm.jobs.backends import run_backend
    from inkarm.sim.cell import kinematic_model

    settings = settings or KinematicsOptions()
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    cell = Cell(scenario.cell, scenario.robot)
    old, _ = scenario_calibration(scenario)
    base = old.geometry if old is not None else GeometryErrors()
    nominal = kinematic_model(cell)
    homes = (nominal.home_q, *(swivel_postures(nominal, settings.swivel_deg)
                               if settings.swivel_deg > 0 else ()))
    tip = TipModel(nominal, base)
    limit = max(settings.tracking_limit_mm, scenario.controller.tracking_limit_mm)
    patient = dataclasses.replace(scenario, controller=dataclasses.replace(
        scenario.controller, tracking_limit_mm=limit))
    spacing = (cell.paper_size_mm[0] - 2.0 * settings.margin_mm) / (settings.columns - 1)
    points, readings, runs = [], [], []
    for j, home in enumerate(homes):
        shift = float(np.clip((j - 0.5 * (len(homes) - 1)) * spacing / len(homes),
                              -settings.margin_mm, settings.margin_mm))
        pattern = dot_pattern(cell.paper_size_mm, settings.columns, settings.rows,
                              settings.margin_mm, settings.dwell_s, shift_mm=(shift, 0.0))
        probe = drawing_scenario(_with_home(patient, home), pattern,
                                 title=f"kinematic pattern {j + 1} of {scenario.title}")
        part = _part(progress, j / len(homes), (j + 1) / len(homes))
        run = (run_backend(backend, probe, options, progress=part) if runner is None
               else runner(probe, part))
        if not run.finished:
            raise InputError(f"the pattern run from home {j + 1} failed: {run.reason}",
                             key="calibrate kinematics")
        dots = dot_points(pattern)
        points.append(dots)
        readings.append(dot_readings(run.log, len(dots), scenario.controller.force_n, tip,
                                     probe.ink.make(), probe.ink.px_per_mm))
        runs.append(run)
    return DrawnPattern(tuple(points), tuple(readings), tuple(runs), nominal, base, old)


def fit_pattern(pattern: DrawnPattern, image: str | Path | np.ndarray | None = None,
                corners_px=None, mark_noise_mm: float = 0.02, max_shift_mm: float = 10.0):
    """Fit the arm's geometry to the marks of a :func:`draw_pattern` (module docstring, step 2):
    on its runs' canvases, or on ``image``, one scan or photograph of the sheet with all of its
    dots, its corners ``corners_px`` (4, 2) [px] in the order lower-left, lower-right,
    upper-right, upper-left. Each run's marks are matched to its dots moved by their common
    shift (:func:`~inkarm.control.calibration.marks.common_shift`; at most ``max_shift_mm``,
    on one sheet of every run at most the match radius, so that a run's dots are not matched
    to its neighbours' marks), within :attr:`DrawnPattern.match_radius_mm`. Returns the :class:`~inkarm.control.calibration.kinematics.
    KinematicFit` (its geometry: the scenario's, corrected). Raises InputError when a dot has no
    mark or two, or an image comes without its corners."""
    from inkarm.control.calibration.kinematics import fit_kinematics
    from inkarm.control.calibration.marks import canvas_marks, image_marks, match_marks

    if image is not None and corners_px is None:
        raise InputError("an image of the sheet needs its four corners in pixels (lower-left, "
                         "lower-right, upper-right, upper-left)", key="corners_px")
    radius = pattern.match_radius_mm
    sheet = (image_marks(image, corners_px, pattern.model.placement.size_mm)
             if image is not None else None)
    shift = min(max_shift_mm, radius) if sheet is not None else max_shift_mm
    marked = []
    runs = pattern.runs or (None,) * len(pattern.points_mm)  # (read from a drawn file)
    for points, readings, run in zip(pattern.points_mm, pattern.readings, runs, strict=True):
        if sheet is None and (run is None or run.canvas is None):
            raise InputError("this pattern was drawn on a real sheet (no canvas): give a scan "
                             "of it", key="image")
        marks = sheet if sheet is not None else canvas_marks(run.canvas)
        marked.append(match_marks(points, marks, radius, shift) - readings.offset_mm)
    q = np.vstack([r.q for r in pattern.readings])
    compression = np.concatenate([r.compression_mm for r in pattern.readings])
    # p on top of the old geometry, applied once to the nominal model (the changes add up).
    return fit_kinematics(pattern.model, q, np.vstack(marked), compression, base=pattern.base,
                          mark_noise_mm=mark_noise_mm)


@dataclass(frozen=True, eq=False)
class KinematicsCalibration:
    """What :func:`calibrate_kinematics_run` found: the fit, the drawn pattern, the corrected
    calibration, and the redraws before and after (None without ``redraw``)."""

    fit: Any  # inkarm.control.calibration.kinematics.KinematicFit
    pattern: DrawnPattern
    calibration: CellCalibration
    before: Any = None
    after: Any = None

    @property
    def geometry(self) -> GeometryErrors:
        return self.fit.geometry

    def summary(self) -> str:
        """One line: the marks' residual and, with the redraw, tracking and chamfer before and
        after."""
        fit = self.fit
        line = (f"{len(fit.marks_mm)} dots in {len(self.pattern.runs)} posture(s): marks "
                f"residual {fit.residual_before_mm:.3f} -> {fit.residual_after_mm:.3f} mm, "
                f"{fit.identification.rank} of {len(fit.params)} directions identifiable")
        if self.before is not None and self.after is not None:
            b, a = self.before.metrics, self.after.metrics
            line += (f"; redraw: tracking RMS {_fmt(b.tracking_rms_mm).strip()} -> "
                     f"{_fmt(a.tracking_rms_mm).strip()} mm, chamfer "
                     f"{_fmt(b.ink_chamfer_mm).strip()} -> {_fmt(a.ink_chamfer_mm).strip()} mm "
                     f"({self.before.status} -> {self.after.status})")
        return line

    def report(self) -> str:
        """:meth:`summary`, then the fit and the before/after redraw in words."""
        lines = [self.summary(), self.fit.report()]
        if self.before is not None and self.after is not None:
            lines.append(f"redraw of the scenario's drawing {'before':>10} {'after':>9}")
            for label, key in (("tracking RMS [mm]", "tracking_rms_mm"),
                               ("tracking max [mm]", "tracking_max_mm"),
                               ("ink chamfer [mm]", "ink_chamfer_mm")):
                b, a = (getattr(r.metrics, key) for r in (self.before, self.after))
                lines.append(f"  {label:<30} {_fmt(b)}  {_fmt(a)}")
            lines.append(f"  {'status':<30} {self.before.status:>8}  {self.after.status:>8}")
        return "\n".join(lines)


def _fmt(v) -> str:
    return f"{v:8.3f}" if v is not None else "       -"


def calibrate_kinematics_run(scenario: Scenario | str | Path | None = None,
                             backend: str = "sim", options=None,
                             settings: KinematicsOptions | None = None,
                             progress: Progress = None, image=None,
                             corners_px=None, runner: Runner | None = None
                             ) -> KinematicsCalibration:
    """Calibrate the arm of ``scenario`` on ``backend`` (module docstring): draw the pattern,
    fit (the marks on the canvases, or on ``image`` with its ``corners_px``), and with
    ``settings.redraw`` draw the scenario's drawing believing the old and the corrected
    calibration (``runner``: as :func:`draw_pattern`'s, for the redraws too). Raises
    InputError as :func:`draw_pattern` and :func:`fit_pattern` do."""
    settings = settings or KinematicsOptions()
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    if image is not None and corners_px is None:  # (before anything moves)
        raise InputError("an image of the sheet needs its four corners in pixels (lower-left, "
                         "lower-right, upper-right, upper-left)", key="corners_px")
    share = 0.4 if settings.redraw else 1.0
    pattern = draw_pattern(scenario, backend, options, settings, _part(progress, 0.0, share),
                           runner)
    fit = fit_pattern(pattern, image, corners_px, settings.mark_noise_mm, settings.max_shift_mm)
    old = pattern.calibration
    corrected = CellCalibration(
        robot=scenario.robot.name, paper=old.paper if old is not None else None,
        geometry=fit.geometry,
        notes=(*(old.notes if old is not None else ()),
               (f"kinematics: {len(fit.marks_mm)} dots, residual RMS "
                f"{fit.residual_before_mm:.3f} -> {fit.residual_after_mm:.3f} mm")))
    before = after = None
    if settings.redraw:
        from inkarm.jobs.backends import run_backend

        if runner is None:
            def runner(s: Scenario, p: Progress):
                return run_backend(backend, s, options, progress=p)
        before = runner(scenario, _part(progress, 0.4, 0.7))
        after = runner(with_calibration(scenario, corrected), _part(progress, 0.7, 1.0))
    return KinematicsCalibration(fit, pattern, corrected, before, after)


def calibrate_kinematics(scenario: Scenario | str | Path | None = None, backend: str = "sim",
                         options=None, progress: Progress = None,
                         settings: KinematicsOptions | None = None
                         ) -> tuple[GeometryErrors, str]:
    """The arm's corrected geometry (link lengths and joint offsets fitted; the tip offset of
    the scenario's calibration kept) and a before/after report
    (:func:`calibrate_kinematics_run`)."""
    result = calibrate_kinematics_run(scenario, backend, options, settings, progress)
    return result.geometry, result.report()


def save_pattern(pattern: DrawnPattern, scenario: Scenario, path: str | Path) -> Path:
    """Write ``pattern`` (drawn by :func:`draw_pattern` from ``scenario``) to a drawn file
    (:mod:`inkarm.jobs.calibration_files`): per run j its dots ``points{j}`` (k, 2) [mm],
    joint readings ``q{j}`` (k, n) [rad], compression ``compression{j}`` (k,) [mm] and mark
    offsets ``offset{j}`` (k, 2) [mm]; the calibration it was drawn with. Returns the path."""
    from inkarm.jobs.calibration_files import save_drawn

    arrays: dict[str, np.ndarray] = {"runs": np.array(len(pattern.points_mm))}
    for j, (points, r) in enumerate(zip(pattern.points_mm, pattern.readings, strict=True)):
        arrays |= {f"points{j}": points, f"q{j}": r.q, f"compression{j}": r.compression_mm,
                   f"offset{j}": r.offset_mm}
    return save_drawn(path, "kinematics", scenario, pattern.calibration, arrays)


def load_pattern(path: str | Path, robot: str | None = None) -> tuple[DrawnPattern, Scenario]:
    """The :class:`DrawnPattern` of a file by :func:`save_pattern` (no runs: its marks come
    from a scan, ``fit_pattern(pattern, image, corners_px)``) and its scenario. Raises
    InputError as :func:`~inkarm.jobs.calibration_files.load_drawn` does."""
    from inkarm.control.calibration.kinematics import DotReadings
    from inkarm.jobs.calibration_files import load_drawn
    from inkarm.sim.cell import kinematic_model

    drawn = load_drawn(path, "kinematics", robot)
    a = drawn.arrays
    runs = range(int(a["runs"]))
    points = tuple(a[f"points{j}"] for j in runs)
    readings = tuple(DotReadings(a[f"q{j}"], a[f"compression{j}"], a[f"offset{j}"])
                     for j in runs)
    scenario = drawn.scenario
    old = drawn.calibration
    model = kinematic_model(Cell(scenario.cell, scenario.robot))
    base = old.geometry if old is not None else GeometryErrors()
    return DrawnPattern(points, readings, (), model, base, old), scenario


def _part(progress: Progress, start: float, stop: float) -> Progress:
    if progress is None:
        return None
    return lambda fraction, phase: progress(start + (stop - start) * fraction, phase)


def _with_home(scenario: Scenario, home: np.ndarray) -> Scenario:
    """``scenario`` with its robot's home posture ``home`` [rad] (where the arm starts and
    what its inverse kinematics pulls towards)."""
    robot = scenario.robot
    joints = tuple(dataclasses.replace(j, home=float(h))
                   for j, h in zip(robot.joints, home, strict=True))
    return dataclasses.replace(scenario, robot=dataclasses.replace(robot, joints=joints))


__all__ = ["DrawnPattern", "KinematicsCalibration", "KinematicsOptions", "Runner",
           "calibrate_kinematics", "calibrate_kinematics_run", "draw_pattern", "fit_pattern",
           "load_pattern", "save_pattern"]
