"""The whole cell calibrated in one call: the pen, then the arm's kinematics, then the paper,
each believing what the earlier found (``inkarm calibrate all``).

The order matters. A pen held perpendicular to the sheet shows its tip's offset in marks made at
several tilts and spins (:mod:`inkarm.jobs.calibration_pen`); link and joint errors move those
marks only by their small differences between the poses, so the pen's fit comes out close
(0.11 mm across the pen with links 1 mm and joints 0.2 deg off). The kinematics' marks
(:mod:`inkarm.jobs.calibration_kinematics`) cannot tell a tip offset from the joints, and fold it
into them. Pen first, kinematics believing that tip, then the paper through both: on the default
letter with the pen 2 mm long and 1 mm off-axis and links 1 mm and joints 0.2 deg off, one round
draws at 0.052 mm tracking RMS; a second round changes the tip by 0.16 mm across the pen and the
drawing by 0.003 mm, so one round is the default. The tip's length along the pen is not
separable from the shoulder's height (both move the tip along the pen): what is found there is
the pen and shoulder together, which is what a drawing needs (the force loop takes the rest).

Those differences are not always small: on the plants of ``AROUND_REAL_MIX`` (the links and
joints as above, friction, delays, a tilted base, a wavy sheet) the pen's spun and tilted dots
are 0.5-0.75 mm from where the fit puts them and its tip across the pen 0.2-0.3 mm off. So,
after the kinematics, the measurements are fitted again, alternately, without drawing a dot
more (:func:`refit`): the tip from the pen's marks through the arm just fitted, then the arm
from its marks believing that tip; a block-coordinate descent on the two least-squares
problems together. One pass settles it (AROUND_REAL_MIX seed 2: the pen's residual 0.75 ->
0.09 mm, its tip across the pen 0.22 -> 0.01 mm from the truth; a second pass moves the tip
by 0.02 mm) at about the CPU of one kinematics fit (~1.5 s), paid for by drawing no
before/after letter for the kinematics' report here.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

from inkarm.errors import InputError
from inkarm.jobs.calibration import (
    calibrate_paper,
    probe_paper_marks,
    scenario_calibration,
    with_calibration,
    without,
)
from inkarm.jobs.scenario import Scenario, load_scenario
from inkarm.robots.calibration import CellCalibration

Progress = Callable[[float, str], None] | None
ORDER = ("pen", "kinematics", "paper")


def calibrate_cell(scenario: Scenario | str | Path | None = None, backend: str = "sim",
                   options=None, progress: Progress = None, spacing_mm: float = 5.0,
                   rounds: int = 1, pattern: str = "path", refits: int = 1) -> CellCalibration:
    """The calibration of ``scenario``'s cell on ``backend``: :data:`ORDER`, the pen and the
    kinematics ``rounds`` times in turn, then the paper probed every ``spacing_mm`` along the
    drawing (``pattern="grid"``: on a grid over it; on a backend that senses no force, ramped
    dashes read from their ink, :func:`~inkarm.jobs.calibration.probe_paper_marks`, in rows
    at least 10 mm apart). After each round's kinematics, ``refits`` times: the pen fitted
    again from its own marks through the arm just fitted
    (:meth:`~inkarm.jobs.calibration_pen.PenCalibration.refit`), then the arm from its marks
    believing that tip (:func:`~inkarm.jobs.calibration_kinematics.fit_pattern`): no dot is
    drawn again (module docstring). Starts from the scenario's own calibration (or none);
    returns a new one in memory (write it with
    :func:`inkarm.robots.calibration.write_calibration`)."""
    from inkarm.jobs.backends import get_backend
    from inkarm.jobs.calibration_kinematics import KinematicsOptions, calibrate_kinematics_run
    from inkarm.jobs.calibration_pen import calibrate_pen_run

    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    if not (isinstance(refits, int) and refits >= 0):
        raise InputError(f"calibrate_cell: expected refits >= 0 (an int), got {refits!r}",
                         key="refits", value=refits)
    cal, _ = scenario_calibration(scenario)
    cal = cal or CellCalibration(scenario.robot.name)
    senses_force = getattr(get_backend(backend), "senses_force", True)
    steps = 2 * rounds + 1
    done = 0

    def part(name: str) -> Progress:
        if progress is None:
            return None
        first = done

        def report(fraction: float, phase: str) -> None:
            progress((first + fraction) / steps, f"{name}: {phase}")

        return report

    for _ in range(rounds):
        pen = calibrate_pen_run(with_calibration(scenario, without(cal, "pen")), backend,
                                options, progress=part("pen"))
        cal = _with_geometry(cal, tip_offset_mm=pen.geometry.tip_offset_mm)
        done += 1
        # (the kinematics' before/after redraws are for its own report: not drawn here)
        arm = calibrate_kinematics_run(with_calibration(scenario, without(cal, "kinematics")),
                                       backend, options, KinematicsOptions(redraw=False),
                                       part("kinematics"))
        cal = _with_arm(cal, arm.geometry)
        for _ in range(refits):
            cal = refit(scenario, cal, pen, arm.pattern)
        done += 1
    believing = with_calibration(scenario, without(cal, "paper"))
    if senses_force:
        paper = calibrate_paper(believing, backend, options, spacing_mm, part("paper"),
                                pattern=pattern)
    else:
        paper = probe_paper_marks(believing, backend, options, max(spacing_mm, 10.0),
                                  part("paper")).map
    return dataclasses.replace(cal, paper=paper)


def refit(scenario: Scenario, cal: CellCalibration, pen, drawn) -> CellCalibration:
    """One pass of the alternating fit on what was measured (module docstring): the tip from
    the pen's marks (``pen``, a :class:`~inkarm.jobs.calibration_pen.PenCalibration`) through
    the arm ``cal`` believes, then the arm from the kinematics' marks (``drawn``, a
    :class:`~inkarm.jobs.calibration_kinematics.DrawnPattern`) believing that tip."""
    from inkarm.jobs.calibration_kinematics import fit_pattern
    from inkarm.sim.cell import kinematic_model
    from inkarm.sim.cell_config import Cell

    arm_only = without(cal, "pen")  # (the pen's marks were drawn believing no tip offset)
    model = kinematic_model(Cell(scenario.cell, scenario.robot), arm_only)
    tip = tuple(float(v) for v in pen.refit(model).tip_offset_mm)
    base = dataclasses.replace(drawn.base, tip_offset_mm=tip)
    fitted = fit_pattern(dataclasses.replace(drawn, base=base)).geometry
    return _with_arm(_with_geometry(cal, tip_offset_mm=tip), fitted)


def _with_geometry(cal: CellCalibration, **changes) -> CellCalibration:
    return dataclasses.replace(cal, geometry=dataclasses.replace(cal.geometry, **changes))


def _with_arm(cal: CellCalibration, geometry) -> CellCalibration:
    return _with_geometry(cal, link_length_mm=geometry.link_length_mm,
                          joint_offset_deg=geometry.joint_offset_deg)


__all__ = ["ORDER", "calibrate_cell", "refit"]
