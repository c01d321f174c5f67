"""What a run checks before anything moves: the drawing placed on the page within the budgets
of simulated time and memory, and (for the simulated arm) on the sheet within reach."""

from __future__ import annotations

import numpy as np

from inkarm.core.budget import SIM_S, require, require_memory
from inkarm.core.trajectory import Drawing
from inkarm.errors import InkarmError
from inkarm.ink.canvas import require_raster_memory
from inkarm.jobs.scenario import Scenario, place, source_drawing
from inkarm.sim.cell_config import Cell


def check(scenario: Scenario) -> Drawing:
    """Everything :func:`run` checks before it simulates, without simulating: the source builds,
    the placed drawing fits the budgets and lies on the sheet within the robot's reach. Returns
    the placed drawing; raises as :func:`run` would."""
    from inkarm.control.reference import check_reachable
    from inkarm.jobs.calibration import believed_model

    cell = Cell(scenario.cell, scenario.robot)
    try:
        drawing = placed_within_budget(scenario, cell)
        require_raster_memory(cell.paper_size_mm, scenario.ink.px_per_mm)
        check_reachable(drawing, believed_model(scenario, cell)[0], scenario.controller)
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


def substeps(period_s: float, timestep_s: float) -> int:
    """Physics steps per control period (at least one)."""
    return max(1, int(np.rint(period_s / timestep_s)))


__all__ = ["check", "check_budget", "placed_within_budget", "simulated_seconds", "substeps"]
