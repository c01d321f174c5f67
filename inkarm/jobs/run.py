"""``run(scenario) -> Run``: draw a scenario in memory, as a pure function.

Nothing is written: :func:`inkarm.jobs.outputs.write_run` writes the files. A Run pickles, so
regression suites and sweeps can map :func:`run` over processes or machines.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from inkarm.analysis.metrics import compute_metrics
from inkarm.control.loop import run_drawing
from inkarm.core.budget import SIM_S, require, require_memory
from inkarm.core.log import DrawLog
from inkarm.core.trajectory import Drawing
from inkarm.errors import InkarmError, RunFault
from inkarm.ink.canvas import Canvas, require_raster_memory
from inkarm.jobs.scenario import Scenario, place, source_drawing
from inkarm.sim.cell import Cell, joint_ranges, kinematic_model
from inkarm.sim.perturb import plant_model
from inkarm.sim.plant import MujocoPlant

OK, DEGRADED, FAILED, INTERRUPTED = "ok", "degraded", "failed", "interrupted"
# A run that finished is "degraded" when its drawing falls short of these (page [mm], [N]):
QUALITY = {
    "tracking_rms_mm": 1.0,  # pen RMS distance from its reference while drawing
    "gap_mm": 0.0,  # total length of the strokes drawn without contact
    "force_error_n": 0.25,  # |mean force - F*| while drawing
}


class RunInterrupted(KeyboardInterrupt):
    """Ctrl-C during a run; ``run`` is the partial :class:`Run` (status "interrupted", its log
    so far), for the caller to keep."""

    def __init__(self, run: Run):
        super().__init__("interrupted")
        self.run = run


@dataclass(eq=False)
class Run:
    """What a run produced, in memory.

    Attributes:
        scenario: The scenario that was run.
        status: "ok"; "degraded" when it finished but missed a quality bound (:data:`QUALITY`;
            ``reason`` lists them); "failed" when a watchdog stopped it (``reason`` names the
            watchdog and the fault; the pen was lifted, the arm braked, and the log and canvas
            hold what happened until then); "interrupted" (Ctrl-C).
        reason: Why it failed or is degraded; empty when ok.
        drawing: The placed drawing, page [mm] and [s].
        log: One row per control period (:class:`inkarm.core.log.DrawLog`).
        canvas: The ink on the page.
        metrics: Tracking, ink, force, joint and timing figures (:mod:`inkarm.analysis.metrics`),
            of the partial log when failed (empty when nothing was logged).
        notes: What the planner changed (e.g. slowed to the robot's speed limits).
    """

    scenario: Scenario
    status: str
    drawing: Drawing
    log: DrawLog
    canvas: Canvas
    metrics: dict = field(default_factory=dict)
    reason: str = ""
    notes: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        return self.status == OK

    @property
    def finished(self) -> bool:
        """The drawing was completed (ok or degraded): its metrics describe all of it."""
        return self.status in (OK, DEGRADED)

    @property
    def cell(self) -> Cell:
        return Cell(self.scenario.cell, self.scenario.robot)


def run(scenario: Scenario, progress: Callable[[float, str], None] | None = None) -> Run:
    """Draw ``scenario`` with the simulated robot; return the :class:`Run`, writing nothing.

    Bad settings and unreachable drawings raise before anything moves (their errors name the
    scenario file and key); a simulation that diverges returns a Run with status "failed", its
    reason, and the partial log and canvas; Ctrl-C raises :class:`RunInterrupted` carrying the
    partial run. ``progress(fraction, phase)`` is called during the simulation.
    """
    cell = Cell(scenario.cell, scenario.robot)
    try:
        drawing = placed_within_budget(scenario, cell)
        believed = kinematic_model(cell)  # the controller's own model, of the nominal cell
        canvas = scenario.ink.canvas(cell.paper_size_mm)
        truth = scenario.plant.realised()
        servos = (_servo_firmware(scenario.robot, scenario.cell.timestep)
                  if scenario.controller.command == "position" else None)
        plant = MujocoPlant(plant_model(cell, truth), cell=cell, canvas=canvas,
                            substeps=_substeps(scenario.robot.control_period_s,
                                               scenario.cell.timestep),
                            truth=truth, firmware=servos,
                            # the servos' own loop holds the goals, not the profile's drives
                            drive_gains=scenario.robot.drive if servos is None else None)
        if servos is not None:
            from inkarm.jobs.dynamixel import ServoGoals

            plant = ServoGoals(plant, scenario.robot)
    except InkarmError as e:
        raise e.within(file=scenario.path) from None
    try:
        log = run_drawing(drawing, plant, believed, scenario.robot.gains, scenario.controller,
                          progress=progress, speed_limits=scenario.robot.speed_limits)
    except RunFault as e:
        return failed_run(scenario, drawing, e, canvas, believed)
    except KeyboardInterrupt as e:
        partial = getattr(e, "log", None)
        raise RunInterrupted(Run(scenario, INTERRUPTED, drawing, partial, canvas,
                                 reason="interrupted by the user (Ctrl-C)")) from None
    except InkarmError as e:  # a LoopConfig field's error names it as the scenario does
        controller = e.key in {f.name for f in dataclasses.fields(scenario.controller)}
        raise e.within(file=scenario.path, key="controller" if controller else None) from None
    finally:
        plant.close()
    return finished_run(scenario, drawing, log, canvas, believed)


def finished_run(scenario: Scenario, drawing: Drawing, log: DrawLog, canvas: Canvas,
                 believed) -> Run:
    """The Run of a drawing that finished: ok, or degraded naming the bounds it missed."""
    metrics = _metrics(log, drawing, believed, canvas)
    shortfalls = judge(metrics, scenario.controller.force_n)
    return Run(scenario, DEGRADED if shortfalls else OK, drawing, log, canvas, metrics,
               reason="; ".join(shortfalls), notes=log.notes)


def failed_run(scenario: Scenario, drawing: Drawing, fault: RunFault, canvas: Canvas,
               believed) -> Run:
    """The Run a watchdog stopped: the fault as its reason, the log to the safe stop (the
    fault's ``log``) and the metrics of that partial log."""
    log = getattr(fault, "log", None)
    return Run(scenario, FAILED, drawing, log, canvas, _metrics(log, drawing, believed, canvas),
               reason=str(fault), notes=log.notes if log is not None else ())


def _servo_firmware(robot, step_s: float):
    """The servo firmware of a robot whose joints are Dynamixel servos with position-loop
    registers in its profile (``[backends.dynamixel] position_p``), in joint units: with
    position commands its simulated plant runs as it would on its servos (goals shaped as
    :class:`inkarm.hardware.dynamixel.plant.DynamixelPlant` sends them). With torque commands
    the servos are in current mode and the host's loop drives them. None for other robots."""
    if not robot.servo_firmware:
        return None
    from inkarm.jobs.dynamixel import joint_firmware

    return joint_firmware(robot, step_s)


def judge(metrics: dict, force_n: float) -> list[str]:
    """The quality bounds (:data:`QUALITY`) a finished run missed, each as a sentence."""
    out = []
    if metrics.get("tracking_rms_mm", 0.0) > QUALITY["tracking_rms_mm"]:
        out.append(f"tracking RMS {metrics['tracking_rms_mm']:.2f} mm above "
                   f"{QUALITY['tracking_rms_mm']:g} mm")
    if metrics.get("gap_mm", 0.0) > QUALITY["gap_mm"]:
        out.append(f"{metrics['gap_mm']:.1f} mm of the strokes drawn without contact")
    mean = metrics.get("contact_force_mean_n", force_n)
    if np.isfinite(mean) and abs(mean - force_n) > QUALITY["force_error_n"]:
        out.append(f"mean force {mean:.2f} N, more than {QUALITY['force_error_n']:g} N from "
                   f"the {force_n:g} N set point")
    return out


def _metrics(log: DrawLog | None, drawing: Drawing, believed, canvas,
             force_sensed: bool = True) -> dict:
    """The metrics of a (possibly partial) log; empty when nothing was logged or drawn. Unless
    ``force_sensed`` (servo arms sense no pen force), the force counts as 0, so the force
    metrics and the gaps, found from the force, are NaN."""
    if log is None or len(log) == 0 or not log.drawing.any():
        return {}
    metrics = compute_metrics(
        times_s=log.time, reference_mm=log.reference, tip_mm=log.tip,
        force_n=log.force if force_sensed else np.nan_to_num(log.force),
        drawing=log.drawing, q=log.q,
        joint_range=joint_ranges(believed.model, believed.joint_names), wall_time_s=log.wall_s,
        canvas=canvas, plan_strokes=[s.pos[:, :2] for s in drawing.strokes],
    )
    if not force_sensed:
        metrics["gap_mm"] = float("nan")
    return metrics


def check(scenario: Scenario) -> Drawing:
    """Everything :func:`run` checks before it simulates, without simulating: the source builds,
    the placed drawing fits the budgets and lies on the sheet within the robot's reach. Returns
    the placed drawing; raises as :func:`run` would."""
    from inkarm.control.reference import check_reachable

    cell = Cell(scenario.cell, scenario.robot)
    try:
        drawing = placed_within_budget(scenario, cell)
        require_raster_memory(cell.paper_size_mm, scenario.ink.px_per_mm)
        check_reachable(drawing, kinematic_model(cell), scenario.controller)
    except InkarmError as e:
        raise e.within(file=scenario.path) from None
    return drawing


def placed_within_budget(scenario: Scenario, cell: Cell) -> Drawing:
    """The scenario's drawing placed on the cell's page, its run checked against the
    simulated-time and plan-memory budgets (:func:`check_budget`)."""
    drawing = place(source_drawing(scenario), scenario.placement, cell.paper_size_mm)
    check_budget(drawing, scenario, cell)
    return drawing


def simulated_seconds(drawing: Drawing, scenario: Scenario, cell: Cell) -> float:
    """An upper estimate of the simulated time [s] of drawing ``drawing``: its strokes, and per
    stroke a descent, the longest settling wait, a lift and a travel across the page, plus the
    joint-space approach and return of up to half a turn at the configured joint speed."""
    c = scenario.controller
    strokes = sum(float(s.t[-1] - s.t[0]) for s in drawing.strokes)
    diagonal = float(np.hypot(*cell.paper_size_mm))
    per_stroke = c.descend_s + c.settle_timeout_s + c.lift_s + 1.875 * diagonal / c.travel_speed_mm_s
    joint_moves = 2 * 1.875 * np.pi / c.joint_speed_rad_s
    return strokes + len(drawing.strokes) * per_stroke + joint_moves


def check_budget(drawing: Drawing, scenario: Scenario, cell: Cell) -> None:
    """Refuse, before building anything, a run longer than the simulated-time budget or whose
    per-period arrays (plan and log: about (12 n + n^2 + 20) doubles per period for n joints)
    exceed the memory budget."""
    seconds = simulated_seconds(drawing, scenario, cell)
    require(seconds, SIM_S, f"simulating {len(drawing.strokes)} strokes", key="source")
    periods = seconds / scenario.robot.control_period_s
    n = scenario.robot.n
    require_memory(periods * (12 * n + n * n + 20) * 8.0,
                   f"the plan and log of {periods:.3g} control periods", key="source")


def _substeps(period_s: float, timestep_s: float) -> int:
    """Physics steps per control period (at least one)."""
    return max(1, int(np.rint(period_s / timestep_s)))
