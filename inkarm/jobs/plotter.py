"""A scenario drawn on a GRBL pen plotter: the plotter backend of :mod:`inkarm.jobs.backends`.

The scenario's drawing is placed on its page (page frame = the plotter's machine frame,
origin at the sheet's lower-left corner), the pen path sequenced as for the arms and streamed
through a :class:`~inkarm.hardware.plotter.plant.GrblPlant`; the result is the same
:class:`~inkarm.jobs.run.Run` as a simulated run, with the same metrics.

The ink: a real plotter's is on paper. The Run's canvas is the one given (an in-process
emulator's, or a scan); without one, the measured tip positions while the pen was down are
inked on a canvas (a polyline through the status reports: coarse at 5 Hz).
"""

from __future__ import annotations

import numpy as np

from inkarm.analysis.metrics import compute_metrics
from inkarm.control.plotter import run_plotter
from inkarm.core.log import DrawLog
from inkarm.errors import InkarmError, InputError
from inkarm.hardware.plotter.plant import GrblPlant
from inkarm.hardware.plotter.profiles import load_profile
from inkarm.hardware.plotter.stream import GrblStreamer
from inkarm.ink.canvas import Canvas
from inkarm.jobs.run import DEGRADED, FAILED, INTERRUPTED, OK, Run, RunInterrupted, judge
from inkarm.jobs.scenario import Scenario, place, source_drawing
from inkarm.sim.cell import Cell


def page_size_mm(scenario: Scenario) -> tuple[float, float]:
    return Cell(scenario.cell, scenario.robot).paper_size_mm


def placed_on_sheet(scenario: Scenario, size: tuple[float, float]):
    """The scenario's drawing placed on the sheet; refused when any of it lies off the sheet
    (the machine's space starts at the sheet's lower-left corner)."""
    drawing = place(source_drawing(scenario), scenario.placement, size)
    lo, hi = drawing.bounds()
    if np.any(lo < 0) or hi[0] > size[0] or hi[1] > size[1]:
        raise InputError(f"the drawing spans ({lo[0]:.1f}, {lo[1]:.1f}) to ({hi[0]:.1f}, "
                         f"{hi[1]:.1f}) mm, beyond the {size[0]:g} x {size[1]:g} mm sheet "
                         "(the plotter's origin is the sheet's lower-left corner)",
                         key="placement")
    return drawing


def prepared(scenario: Scenario, profile: str | None):
    """The pen profile, the sheet's size [mm] and the drawing placed on it; errors name the
    scenario file."""
    try:
        pen = load_profile(profile)
        size = page_size_mm(scenario)
        return pen, size, placed_on_sheet(scenario, size)
    except InkarmError as e:
        raise e.within(file=scenario.path) from None


def run_plotter_scenario(scenario: Scenario, port: str | None, *, profile: str | None = None,
                         baudrate: int = 115200, time_scale: float = 1.0, progress=None,
                         canvas: Canvas | None = None, dt: float = 0.01) -> Run:
    """Draw ``scenario`` on the GRBL plotter at ``port``; a failed job (``error:N``,
    ``ALARM:N``, a disconnect) returns a Run with status "failed", the reason naming the
    G-code line, the log so far and the pen lifted."""
    pen, size, drawing = prepared(scenario, profile)
    streamer = GrblStreamer(port, baudrate, time_scale=time_scale)
    try:
        streamer.wake()
        streamer.unlock()  # GRBL starts locked when homing is on; $X is harmless otherwise
        plant = GrblPlant(streamer, pen, dt=dt, time_scale=time_scale,
                          pen_force_n=scenario.controller.force_n)
    except InkarmError:
        streamer.close()
        raise
    try:
        log = run_plotter(drawing, plant, scenario.controller, progress=progress)
        failure = plant.failure
    except KeyboardInterrupt:
        # Ctrl-C: stop the machine now (soft reset, unlock, pen up), keep what was measured.
        plant.streamer.state.failure = plant.streamer.state.failure or "interrupted by the user"
        plant.close()
        raise RunInterrupted(Run(scenario, INTERRUPTED, drawing, None, canvas or scenario.ink.canvas(size),
            reason="interrupted by the user (Ctrl-C); the plotter was reset and its pen "
            "lifted")) from None
    finally:
        plant.close()
    own_canvas = canvas is None
    if own_canvas:
        canvas = scenario.ink.canvas(size)
        ink_measured(canvas, log)
    notes = ((f"plotter: {len(plant.lines)} G-code lines, pen profile {pen.name!r}, "
             f"{len(log)} status reports (the log's rows)"),)
    if plant.clipped:
        notes += ((f"plotter: {plant.clipped} pen-down moves slowed to the profile's "
                  f"max_draw_speed_mm_s = {pen.max_draw_speed_mm_s:g} mm/s"),)
    if own_canvas:
        notes += ("plotter: the canvas inks the measured status positions (5 Hz), not paper",)
    log.notes = notes
    if failure:
        return Run(scenario, FAILED, drawing, log, canvas, reason=f"the plotter stopped: "
                   f"{failure}", notes=notes)
    travel = [plant.settings.get(130, 300.0), plant.settings.get(131, 300.0)]
    metrics = compute_metrics(
        times_s=log.time, reference_mm=log.reference, tip_mm=log.tip, force_n=log.force,
        drawing=log.drawing, q=log.q,
        joint_range=np.array([[0.0, travel[0] / 1000.0], [0.0, travel[1] / 1000.0]]),
        wall_time_s=max(log.wall_s, 1e-9), canvas=canvas,
        plan_strokes=[s.pos[:, :2] for s in drawing.strokes],
        contact_threshold_n=scenario.controller.contact_threshold_n)
    # The arm's quality bounds; a plotter's tracking error is its distance from the firmware's
    # own plan at the status reports' times (see inkarm.control.plotter).
    shortfalls = judge(metrics, scenario.controller.force_n)
    return Run(scenario, DEGRADED if shortfalls else OK, drawing, log, canvas, metrics,
               reason="; ".join(shortfalls), notes=notes)


def check_plotter_scenario(scenario: Scenario, profile: str | None = None) -> str:
    """Everything a plotter run checks before it opens the port (profile, source, placement on
    the sheet), and the job's G-code and time estimate on GRBL's planner with its default
    settings; a one-line summary. Nothing is sent."""
    from inkarm.hardware.plotter.gcode import drawing_to_gcode
    from inkarm.hardware.plotter.timing import estimate_seconds

    pen, _, drawing = prepared(scenario, profile)
    job = drawing_to_gcode(drawing, pen)
    return (f"ok: {scenario.title!r}, {len(drawing.strokes)} strokes on the sheet; "
            f"{len(job.lines)} G-code lines for pen profile {pen.name!r}, about "
            f"{estimate_seconds(job.lines):.1f} s on GRBL's planner (default settings); "
            "nothing sent")


def ink_measured(canvas: Canvas, log: DrawLog) -> None:
    """Ink the measured tip positions of the rows with the pen down."""
    for t, tip, force in zip(log.time, log.tip, log.force, strict=True):
        if force > 0:
            canvas.touch(tip[:2], float(force), float(t))
        elif canvas.in_contact:
            canvas.lift()
    canvas.lift()


def arm_and_plotter(scenario: Scenario, speedup: float = 2.0) -> tuple[Run, Run]:
    """``scenario`` drawn by the simulated arm and by the GRBL emulator (in this process, on a
    pseudo-terminal, at ``speedup``), both measured by the same metrics."""
    from inkarm.hardware.plotter.emulator import EmulatorConfig, GrblEmulator
    from inkarm.jobs.run import run

    arm = run(scenario)
    canvas = scenario.ink.canvas(page_size_mm(scenario))
    config = EmulatorConfig(speedup=speedup)
    with GrblEmulator(config, canvas=canvas) as emulator:
        plotter = run_plotter_scenario(scenario, emulator.port, time_scale=speedup,
                                       canvas=canvas)
    return arm, plotter
