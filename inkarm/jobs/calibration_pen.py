"""``inkarm calibrate pen`` as a library call: the pen's tool-centre point from dot marks made
with the pen spun and tilted (:mod:`inkarm.control.calibration.pen`).

1. The pattern (:func:`~inkarm.control.calibration.pen.pen_pattern`: thirteen dots near the
   sheet's centre, the pen upright at five spins, then tilted 25 deg toward eight directions) is
   drawn as the scenario's drawing through the one assembly
   (:func:`inkarm.jobs.backends.run_backend`), the controller believing the scenario's
   calibration, tip offset included: the fit finds what is left of the tip's error, and the
   offset to believe is the old one plus it.
2. The dots are pressed lightly, below the pen's preload (``PRELOAD_SHARE`` of it): the pen
   then does not give in its holder, so its compression is 0 whatever its spring and weight,
   and a tilted tip comes down along its own axis without sliding (the marks' model holds to a
   few microns; at the drawing's 1 N the spring's real compression differs from (F - P) / k by
   the pen's weight, which would bias the length by tenths of a millimetre).
3. Per dot, the joint readings (median over the last half of its pressed rows) and, through the
   controller's own forward kinematics, the believed tip's pose; the marks on the run's canvas
   in simulation, or on a scanned or photographed sheet (``image`` with its ``corners_px``).
4. The fit (:func:`~inkarm.control.calibration.pen.fit_tip_offset`, with a free page offset;
   marks only: the contact heights would bring in the sheet's height and relief under each
   dot, which the marks of a tilted pen do without), then, with ``redraw``, the scenario's own
   drawing drawn believing the old and the new tip.
   A backend that senses no pen force (the Dynamixel arm) presses each dot to its planned
   depth, so a pen of another length gives in its holder by an amount nothing measures: there
   the length is not fitted (the believed one is kept) and the offset across the pen comes from
   the upright dots alone (their marks do not depend on the compression).

Only the joint readings, the sensed force, the marks and the controller's own model are used:
never the simulated plant's truth (nor ``log.tip``, the true tip that hardware does not sense).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inkarm.control.calibration.dots import settled_rows
from inkarm.control.calibration.pen import AZIMUTHS_DEG, SPINS_DEG
from inkarm.control.laws import DEFAULT_LAW, LawSpec
from inkarm.core.log import DrawLog
from inkarm.errors import InputError
from inkarm.jobs.calibration import (
    Progress,
    believed_model,
    drawing_scenario,
    scenario_calibration,
    with_calibration,
)
from inkarm.jobs.scenario import Scenario, load_scenario
from inkarm.robots.calibration import CellCalibration
from inkarm.robots.geometry import GeometryErrors
from inkarm.sim.cell_config import Cell

PRELOAD_SHARE = 0.8  # the dots' force as a share of the pen's preload (when it has one)
POSE_TOLERANCE_DEG = 2.0  # how far a dot's measured pen tilt may be from its plan [deg]


@dataclass(frozen=True)
class PenOptions:
    """How to calibrate.

    Attributes:
        centre_mm: Where the dots lie (x, y) [mm]; None: the sheet's centre.
        spacing_mm: The dots' spacing [mm].
        tilt_deg: The tilted dots' tilt from the normal [deg].
        spins_deg: The upright dots' spins, from the natural one [deg].
        azimuths_deg: The tilted dots' directions on the page [deg] (none are drawn on a
            backend that senses no pen force: they would not tell the length there).
        force_n: The dots' force [N]; None: 0.8 x the believed pen preload (the scenario's
            force for a pen without one).
        dwell_s: How long the pen rests on each dot [s].
        image: A scanned or photographed sheet of the drawn pattern (a real arm); None: the
            run's canvas.
        corners_px: The sheet's corners in ``image`` [px], lower-left, lower-right,
            upper-right, upper-left (:mod:`inkarm.control.calibration.marks`).
        redraw: Draw the scenario's drawing before and after, for the report.
        law: The control law the dots are drawn with (the stiff default ``position``: a law
            that holds the pen upright online, ``sensorimotor``, cannot tilt it, and a compliant
            one lets it slide); None: the scenario's own.
        tracking_limit_mm: The tracking watchdog's limit during the pattern run [mm] (at least
            the scenario's): a pen and an arm not yet calibrated put the tip several mm from
            where the controller believes it (the tilted dots' length error alone shows as
            L sin(theta) sideways; links 1 mm and joints 0.2 deg off, up to 4 mm), which a
            pattern of dots, drawn slowly and read only where each rests, can afford.
        max_shift_mm: How far all marks together may lie from their dots [mm]: each is matched
            to its dot moved by the marks' common shift
            (:func:`~inkarm.control.calibration.marks.common_shift`), within 0.45 of the
            spacing of it; 0: to the dot itself (the same arm put marks 5.6 mm off, more than
            0.45 x 12 mm, on AROUND_REAL_MIX seed 33).
    """

    centre_mm: tuple[float, float] | None = None
    spacing_mm: float = 12.0
    tilt_deg: float = 25.0
    spins_deg: tuple[float, ...] = SPINS_DEG
    azimuths_deg: tuple[float, ...] = AZIMUTHS_DEG
    force_n: float | None = None
    dwell_s: float = 0.3
    image: str | Path | None = None
    corners_px: tuple[tuple[float, float], ...] | None = None
    redraw: bool = False
    law: str | None = DEFAULT_LAW
    tracking_limit_mm: float = 20.0
    max_shift_mm: float = 10.0


@dataclass(frozen=True, eq=False)
class PenCalibration:
    """What :func:`calibrate_pen_run` found: the fit, the new geometry (tip offset only), the
    pattern's run, and the redraws before and after (None without ``redraw``); and what was
    measured, for :meth:`refit`: per dot the joint readings ``q`` (k, n) [rad], the sensed
    force ``force_n`` (k,) [N] (NaN where not sensed), the mark ``marks_mm`` (k, 2) [mm], and
    ``used`` (k,) which dots the fit took (all, or the upright ones without a sensed force)."""

    fit: object  # inkarm.control.calibration.pen.PenFit
    geometry: GeometryErrors
    pattern_run: object
    before: object | None = None
    after: object | None = None
    q: np.ndarray | None = None
    force_n: np.ndarray | None = None
    marks_mm: np.ndarray | None = None
    used: np.ndarray | None = None

    def refit(self, model):
        """The fit again, from the same measurements, through another belief of the arm:
        ``model`` (a :class:`~inkarm.robots.kinematic.KinematicModel`, e.g. with the arm's
        fitted links and joints, :mod:`inkarm.jobs.calibration_cell`). Its tip offset is the
        fit's tip offset plus the one ``model`` believes. No dot is drawn again."""
        from inkarm.control.calibration.pen import fit_tip_offset, tip_poses

        if self.q is None:
            raise InputError("this pen calibration kept no measurements to refit",
                             key="refit")
        rotations, tips = tip_poses(model, self.q[self.used])
        marks = self.marks_mm[self.used]
        force = self.force_n[self.used]
        if np.isfinite(force).all():
            return fit_tip_offset(rotations, tips, marks,
                                  compression_mm(force, rotations, model))
        return fit_tip_offset(rotations, tips, marks, length=False)

    def report(self) -> str:
        """The fit, and the redraw before/after, in words."""
        t = self.geometry.tip_offset_mm
        lines = [self.fit.summary(),
                 f"tip offset to believe: ({t[0]:+.3f}, {t[1]:+.3f}, {t[2]:+.3f}) mm"]
        if self.before is not None and self.after is not None:
            lines.append("redraw of the scenario's drawing      before     after")
            for label, key in (("tracking RMS [mm]", "tracking_rms_mm"),
                               ("ink chamfer [mm]", "ink_chamfer_mm")):
                b, a = (getattr(r.metrics, key, None) for r in (self.before, self.after))
                lines.append(f"  {label:<34} {_fmt(b)}  {_fmt(a)}")
            lines.append(f"  {'status':<34} {self.before.status:>8}  {self.after.status:>8}")
        return "\n".join(lines)


def _fmt(v) -> str:
    return f"{v:8.3f}" if v is not None else "       -"


def dot_readings(log: DrawLog, dots: int, force_n: float) -> tuple[np.ndarray, np.ndarray]:
    """Per dot (stroke 0..dots-1): the median joint readings (dots, n) [rad] and sensed force
    (dots,) [N] over the last half of its pressed rows (phase draw; with a sensed force, above
    half ``force_n``; NaN force where the backend senses none). Raises InputError naming a dot
    that was never pressed."""
    sensed = bool(len(log)) and bool(np.isfinite(log.force).any())
    q = np.zeros((dots, log.q.shape[1]))
    force = np.full(dots, np.nan)
    for k in range(dots):
        mine = settled_rows(log, k, force_n if sensed else None)
        if len(mine) == 0:
            raise InputError(f"dot {k} of the pen pattern was never pressed on the paper (no "
                             "logged contact): is the sheet where the model believes it?",
                             key="dots", value=k)
        q[k] = np.median(log.q[mine], axis=0)
        if sensed:
            force[k] = float(np.median(log.force[mine]))
    return q, force


def compression_mm(force_n: np.ndarray, rotations: np.ndarray, believed) -> np.ndarray:
    """The pen's compression c_i [mm] from the sensed normal force F_i [N] on a pen at
    orientation R_i (page frame): its share along the pen, F cos(theta), beyond the believed
    preload P over the spring rate k, ``clip((F cos(theta) - P) / k, 0, travel)`` (0 where no
    force is sensed)."""
    along = np.nan_to_num(force_n) * np.abs(rotations[:, 2, 2])
    c = (along - believed.pen_preload_n) / believed.pen_stiffness_n_per_mm
    return np.clip(c, 0.0, believed.pen_travel_mm)


def check_poses(rotations: np.ndarray, poses) -> None:
    """Refuse a pattern run whose pens were not tilted as planned (a backend that dropped the
    drawing's ``meta["pen_poses"]``): each dot's believed tilt from the normal within
    :data:`POSE_TOLERANCE_DEG` of its pose's."""
    for k, (R, pose) in enumerate(zip(rotations, poses, strict=True)):
        tilt = math.degrees(math.acos(min(1.0, abs(float(R[2, 2])))))
        planned = 0.0 if pose is None else pose.tilt_deg
        if abs(tilt - planned) > POSE_TOLERANCE_DEG:
            raise InputError(f"dot {k} of the pen pattern was drawn with the pen tilted "
                             f"{tilt:.1f} deg, planned {planned:.1f} deg: the backend or the "
                             "law did not hold the pattern's pen poses (drawing "
                             "meta['pen_poses'])", key="pen_poses", value=k)


@dataclass(frozen=True, eq=False)
class DrawnPen:
    """The pen pattern as drawn (:func:`draw_pen`): per dot its plan ``points_mm`` (k, 2)
    [mm], whether it was ``upright`` (k,), the joint readings ``q`` (k, n) [rad] and the sensed
    force ``force_n`` (k,) [N] (NaN: not sensed); the dots' ``spacing_mm``; the controller's
    model while it drew (``believed``), the ``calibration`` it believed (or None), and the
    ``run`` (a :class:`~inkarm.jobs.calibration_files.SavedRun` when read from a file)."""

    points_mm: np.ndarray
    upright: np.ndarray
    q: np.ndarray
    force_n: np.ndarray
    spacing_mm: float
    believed: object
    calibration: CellCalibration | None
    run: object


def draw_pen(scenario: Scenario | str | Path | None = None, backend: str = "sim",
             options=None, settings: PenOptions | None = None,
             progress: Progress = None) -> DrawnPen:
    """Draw the pen pattern (module docstring, steps 1 to 3, without the marks) and read the
    joints at each dot. Raises InputError when the run fails, a dot was never pressed or its
    pen was not posed as planned."""
    from inkarm.control.calibration.pen import pen_pattern, tip_poses
    from inkarm.jobs.backends import get_backend, run_backend

    settings = settings or PenOptions()
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    cell = Cell(scenario.cell, scenario.robot)
    old, _ = scenario_calibration(scenario)
    believed, _ = believed_model(scenario, cell)
    force = settings.force_n
    if force is None:
        preload = believed.pen_preload_n
        force = PRELOAD_SHARE * preload if preload > 0 else scenario.controller.force_n
    senses_force = getattr(get_backend(backend), "senses_force", True)
    pattern = pen_pattern(believed, settings.centre_mm, settings.spacing_mm, settings.tilt_deg,
                          settings.spins_deg, settings.azimuths_deg if senses_force else (),
                          settings.dwell_s)
    # (no paper probe: its dots would come first and take the poses' places)
    limit = max(settings.tracking_limit_mm, scenario.controller.tracking_limit_mm)
    controller = dataclasses.replace(scenario.controller, force_n=float(force),
                                     probe_paper=False, tracking_limit_mm=limit)
    law = scenario.law if settings.law in (None, scenario.law.name) else LawSpec(settings.law)
    probe = drawing_scenario(dataclasses.replace(scenario, controller=controller, law=law),
                             pattern, title=f"pen calibration of {scenario.title}")
    run = run_backend(backend, probe, options, progress=progress)
    if not run.finished:
        raise InputError(f"the pen pattern's run failed: {run.reason}", key="calibrate pen")
    points = np.array([s.pos[0, :2] for s in pattern.strokes])
    poses = pattern.meta["pen_poses"]
    q, sensed = dot_readings(run.log, len(points), float(force))
    rotations, _ = tip_poses(believed, q)
    check_poses(rotations, poses)
    upright = np.array([p is None or p.tilt_deg == 0.0 for p in poses])
    return DrawnPen(points, upright, q, sensed, float(settings.spacing_mm), believed, old, run)


def fit_pen(drawn: DrawnPen, image=None, corners_px=None,
            max_shift_mm: float = 10.0) -> PenCalibration:
    """The tip offset from a :func:`draw_pen` (module docstring, step 4, without the redraw):
    the marks on its run's canvas, or on ``image`` (a file or a darkness raster) with its
    ``corners_px``, each matched to its dot within 0.45 of the spacing after the marks' common
    shift (at most ``max_shift_mm``). Raises InputError when a dot has no mark or two, the
    marks cannot tell the offset, an image comes without its corners or there is neither an
    image nor a canvas."""
    from inkarm.control.calibration.marks import canvas_marks, image_marks, match_marks
    from inkarm.control.calibration.pen import fit_tip_offset, tip_poses

    if image is not None and corners_px is None:
        raise InputError("an image of the sheet needs its four corners in pixels (lower-left, "
                         "lower-right, upper-right, upper-left)", key="corners_px")
    believed, points, q, sensed = drawn.believed, drawn.points_mm, drawn.q, drawn.force_n
    rotations, tips = tip_poses(believed, q)
    if image is not None:
        marks = image_marks(image, corners_px, believed.placement.size_mm)
    elif getattr(drawn.run, "canvas", None) is not None:
        marks = canvas_marks(drawn.run.canvas)
    else:
        raise InputError("this pen pattern was drawn on a real sheet (no canvas): give a scan "
                         "of it", key="image")
    marked = match_marks(points, marks, 0.45 * drawn.spacing_mm, max_shift_mm)
    used = np.ones(len(points), dtype=bool)
    if np.isfinite(sensed).all():
        fit = fit_tip_offset(rotations, tips, marked, compression_mm(sensed, rotations, believed))
    else:  # no force sensed: the pen's compression is not known, only the upright dots tell
        used = np.asarray(drawn.upright, dtype=bool)
        fit = fit_tip_offset(rotations[used], tips[used], marked[used], length=False)
    old = drawn.calibration
    base = old.geometry.tip_offset_mm if old is not None else (0.0, 0.0, 0.0)
    tip = tuple(float(a + b) for a, b in zip(base, fit.tip_offset_mm, strict=True))
    return PenCalibration(fit, GeometryErrors(tip_offset_mm=tip), drawn.run, None, None, q,
                          sensed, marked, used)


def save_pen(drawn: DrawnPen, scenario: Scenario, path: str | Path) -> Path:
    """Write a :func:`draw_pen` of ``scenario`` to a drawn file
    (:mod:`inkarm.jobs.calibration_files`): ``points_mm``, ``upright``, ``q``, ``force_n``,
    ``spacing_mm``. Returns the path."""
    from inkarm.jobs.calibration_files import save_drawn

    return save_drawn(path, "pen", scenario, drawn.calibration,
                      {"points_mm": drawn.points_mm, "upright": drawn.upright, "q": drawn.q,
                       "force_n": drawn.force_n, "spacing_mm": np.array(drawn.spacing_mm)})


def load_pen(path: str | Path, robot: str | None = None) -> tuple[DrawnPen, Scenario]:
    """The :class:`DrawnPen` of a file by :func:`save_pen` (its model rebuilt believing the
    calibration it was drawn with; no canvas) and its scenario."""
    from inkarm.jobs.calibration_files import SavedRun, load_drawn

    drawn = load_drawn(path, "pen", robot)
    a, scenario = drawn.arrays, drawn.scenario
    believed, _ = believed_model(scenario, Cell(scenario.cell, scenario.robot))
    return DrawnPen(a["points_mm"], a["upright"].astype(bool), a["q"], a["force_n"],
                    float(a["spacing_mm"]), believed, drawn.calibration, SavedRun(None)), scenario


def calibrate_pen_run(scenario: Scenario | str | Path | None = None, backend: str = "sim",
                      options=None, settings: PenOptions | None = None,
                      progress: Progress = None) -> PenCalibration:
    """Calibrate the pen of ``scenario`` on ``backend`` (module docstring): :func:`draw_pen`,
    :func:`fit_pen`, and with ``settings.redraw`` the redraws; ``options`` are the backend's
    (:class:`inkarm.jobs.backends.BackendOptions`), ``settings`` the calibration's. Raises
    InputError as those do, or when the image's corners are missing (before anything
    moves)."""
    from inkarm.jobs.backends import run_backend

    settings = settings or PenOptions()
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    if settings.image is not None and settings.corners_px is None:
        raise InputError("an image of the sheet needs its four corners in pixels (lower-left, "
                         "lower-right, upper-right, upper-left)", key="corners_px")
    drawn = draw_pen(scenario, backend, options, settings, _part(progress, 0.0, 0.4))
    result = fit_pen(drawn, settings.image, settings.corners_px, settings.max_shift_mm)
    if not settings.redraw:
        return result
    old, tip = drawn.calibration, result.geometry.tip_offset_mm
    before = run_backend(backend, scenario, options, progress=_part(progress, 0.4, 0.7))
    corrected = CellCalibration(
        robot=scenario.robot.name, paper=old.paper if old is not None else None,
        geometry=dataclasses.replace(old.geometry if old is not None else GeometryErrors(),
                                     tip_offset_mm=tip),
        notes=(*(old.notes if old is not None else ()), f"pen: {result.fit.summary()}"))
    after = run_backend(backend, with_calibration(scenario, corrected), options,
                        progress=_part(progress, 0.7, 1.0))
    return dataclasses.replace(result, before=before, after=after)


def _part(progress: Progress, start: float, stop: float) -> Progress:
    if progress is None:
        return None
    return lambda fraction, phase: progress(start + (stop - start) * fraction, phase)


def calibrate_pen(scenario: Scenario | str | Path | None = None, backend: str = "sim",
                  options=None, progress: Progress = None,
                  settings: PenOptions | None = None) -> GeometryErrors:
    """The pen's tool-centre point as the tip offset to believe (the scenario calibration's
    plus the one found; link lengths and joint offsets zero): :func:`calibrate_pen_run`."""
    return calibrate_pen_run(scenario, backend, options, settings, progress).geometry


__all__ = ["DrawnPen", "PenCalibration", "PenOptions", "calibrate_pen", "calibrate_pen_run",
           "check_poses", "compression_mm", "dot_readings", "draw_pen", "fit_pen", "load_pen",
           "save_pen"]
