"""A scenario drawn on a GRBL pen plotter: the plotter backend of :mod:`inkarm.jobs.backends`.

The scenario's drawing is placed on its page (page frame = the plotter's work frame: G54's
offset puts the sheet's lower-left corner where the scenario's ``[plotter] page_origin``,
else the pen profile's, says, see
:mod:`inkarm.hardware.plotter.workspace`), the pen path sequenced as for the arms and streamed
through a :class:`~inkarm.hardware.plotter.plant.GrblPlant`; the result is the same
:class:`~inkarm.jobs.run.Run` as a simulated run, with the same metrics. A job that leaves the
machine's travel is refused before anything moves, naming the ``$13x`` setting.

``check`` with a port validates the job on the device in GRBL's check mode (``$C``): every line
parsed and soft-limit checked, nothing moved.

The ink: a real plotter's is on paper. The Run's canvas is the one given (an in-process
emulator's, or a scan); without one, the measured tip positions while the pen was down are
inked on a canvas (a polyline through the status reports: coarse at 5 Hz).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from inkarm.core.log import DrawLog
from inkarm.core.run import Senses
from inkarm.errors import InkarmError, InputError
from inkarm.hardware.plotter.plant import GrblPlant
from inkarm.hardware.plotter.profiles import PenProfile, load_profile, parse_placement
from inkarm.hardware.plotter.stream import GrblStreamer
from inkarm.hardware.plotter.workspace import xy_travel
from inkarm.ink.canvas import Canvas
from inkarm.io.toml import TomlReader
from inkarm.jobs.backends import BackendOptions, Progress, run_backend
from inkarm.jobs.backends.cartesian import (
    CartesianSession,
    page_size_mm,
    pen_senses,
    placed_on_sheet,
)
from inkarm.jobs.outcome import Run
from inkarm.jobs.scenario import Scenario
from inkarm.jobs.scenario_tables import thawed

PERIOD_S = 0.01  # the plotter run's control period: one G-code line per period of the pen path
NO_FORCE = "a plotter senses no pen force (its pen is up or down)"
STATUS_INK = "the ink is on the paper; this run's canvas inks the 5 Hz status reports"


def plotter_senses(ink: bool) -> Senses:
    """What a plotter senses for the judge: the tip (its status reports) and the pen's contact
    (up or down, which the reports say), never a force; the ink only where the run has it
    (an emulator's canvas, or a scan), not from the coarse status reports."""
    return pen_senses(ink, NO_FORCE, STATUS_INK)


def scenario_pen(scenario: Scenario, profile: str | None) -> PenProfile:
    """The pen profile (``profile``, else the scenario's), with the scenario's ``[plotter]``
    ``page_origin`` and ``homing`` in place of the profile's own (checked when the scenario
    was read)."""
    pen = load_profile(profile or scenario.plotter_profile)
    if not scenario.plotter_placement:
        return pen
    table = {k: thawed(v) for k, v in scenario.plotter_placement}
    rd = TomlReader(str(scenario.path))
    return replace(pen, placement=parse_placement(rd, table, "plotter.", base=pen.placement))


def prepared(scenario: Scenario, profile: str | None):
    """The pen profile (:func:`scenario_pen`), the sheet's size [mm] and the drawing placed on
    it; errors name the scenario file."""
    try:
        pen = scenario_pen(scenario, profile)
        size = page_size_mm(scenario)
        return pen, size, placed_on_sheet(scenario, size)
    except InkarmError as e:
        raise e.within(file=scenario.path) from None


class PlotterSession(CartesianSession):
    """A scenario on the GRBL plotter at ``options.port`` (module docstring)."""

    interrupted = ("interrupted by the user (Ctrl-C); the plotter was reset and its pen "
                   "lifted")
    label, device, speed_key = "plotter", "the plotter", "max_draw_speed_mm_s"
    planner = "the firmware's planner moves the pen"
    readings = "measured status positions (5 Hz)"

    def __init__(self, scenario: Scenario, options: BackendOptions, dt: float = PERIOD_S):
        self.profile, size, self.drawing = prepared(scenario, options.profile)
        self._open_canvas(scenario, options, size, plotter_senses)
        streamer = GrblStreamer(options.port, options.baudrate, time_scale=options.time_scale)
        try:
            streamer.wake()
            self.plant = GrblPlant(streamer, self.profile, dt=dt, time_scale=options.time_scale,
                                   pen_force_n=scenario.controller.force_n, page_mm=size,
                                   extent_mm=self.drawing.bounds())
        except InkarmError as e:
            streamer.close()
            raise e.within(file=scenario.path) from None
        except BaseException:
            streamer.close()
            raise

    def device_notes(self, log: DrawLog) -> tuple[str, ...]:
        plant, ws = self.plant, self.plant.workspace
        return ((f"plotter: {len(plant.lines)} G-code lines, pen profile "
                 f"{self.profile.name!r}, {len(log)} status reports (the log's rows)"),
                (f"plotter: page origin at machine ({ws.origin_mm[0]:g}, "
                 f"{ws.origin_mm[1]:g}) mm (G54), "
                 + ("homed ($22=1)" if ws.homed else "not homed ($22=0)")))

    def page_range(self) -> np.ndarray:
        return page_range(self.plant)


class PlotterBackend:
    name = "plotter"
    help = "a GRBL 1.1 pen plotter on a serial port"
    needs_port = True

    def check(self, scenario: Scenario, options: BackendOptions) -> str:
        if options.port:
            return check_on_device(scenario, options, options.profile)
        return check_plotter_scenario(scenario, options.profile)

    def open(self, scenario: Scenario, options: BackendOptions) -> PlotterSession:
        return PlotterSession(scenario, options)


def run_plotter_scenario(scenario: Scenario, port: str | None, *, profile: str | None = None,
                         baudrate: int = 115200, time_scale: float = 1.0,
                         progress: Progress = None, canvas: Canvas | None = None) -> Run:
    """Draw ``scenario`` on the GRBL plotter at ``port`` (the ``plotter`` backend); a failed
    job (``error:N``, ``ALARM:N``, a disconnect) returns a Run with status "failed", the
    reason naming the G-code line, the log so far and the pen lifted."""
    return run_backend("plotter", scenario, BackendOptions(
        port=port, profile=profile, baudrate=baudrate, time_scale=time_scale, canvas=canvas),
        progress)


def run_lines(scenario: Scenario, pen: PenProfile, drawing, dt: float = PERIOD_S) -> list[str]:
    """The G-code lines a plotter run of ``drawing`` streams (the arms' pen sequencing on the
    control grid of ``dt`` [s], :func:`~inkarm.control.plotter.plotter_commands`, each
    command's lines as :class:`GrblPlant` writes them): what the run sends, which is not the
    ``inkarm gcode`` file of the same drawing (that one follows the drawing's own samples)."""
    from inkarm.control.plotter import plotter_commands
    from inkarm.control.sequencing import sequence_pen
    from inkarm.hardware.plotter.plant import streamed_lines

    path = sequence_pen(drawing, scenario.controller, 0.0, dt)
    return streamed_lines(pen, plotter_commands(path, dt)[0])


def check_plotter_scenario(scenario: Scenario, profile: str | None = None) -> str:
    """Everything a plotter run checks before it opens the port (profile, source, placement on
    the sheet), and the G-code lines the run would stream with their time on GRBL's planner
    with its default settings; a one-line summary. Nothing is sent."""
    from inkarm.hardware.plotter.timing import estimate_seconds

    pen, _, drawing = prepared(scenario, profile)
    lines = run_lines(scenario, pen, drawing)
    return (f"ok: {scenario.title!r}, {len(drawing.strokes)} strokes on the sheet; a run "
            f"streams {len(lines)} G-code lines (one per {PERIOD_S * 1000:g} ms of the pen "
            f"path) for pen profile {pen.name!r}, about {estimate_seconds(lines):.1f} s on "
            "GRBL's planner (default settings); nothing sent")


def page_range(plant: GrblPlant) -> np.ndarray:
    """Per axis (x, y), the page coordinates [mm] the machine reaches: its homed travel
    [-$13x, 0] less the page origin, or [0, $13x] on a machine that does not home."""
    ws = plant.workspace
    travel = xy_travel(ws.settings)
    if not ws.homed:
        return np.column_stack([np.zeros(2), travel])
    origin = np.asarray(ws.origin_mm)
    return np.column_stack([-travel - origin, -origin])


def check_on_device(scenario: Scenario, options: BackendOptions, profile: str | None) -> str:
    """The lines a run streams (:func:`run_lines`) validated by the device in check mode
    (``$C``): set up as for drawing (page origin, travel check; ``$X`` instead of homing),
    streamed, every line answered ``ok``; nothing moves. A refused line raises an error naming
    it and the device's answer."""
    from inkarm.hardware.plotter.workspace import leave_check_mode, set_up

    pen, size, drawing = prepared(scenario, profile)
    lines = run_lines(scenario, pen, drawing)
    streamer = GrblStreamer(options.port, options.baudrate, time_scale=options.time_scale)
    try:
        streamer.wake()
        try:
            ws = set_up(streamer, pen.placement, size, drawing.bounds(), check_mode=True)
        except InkarmError as e:
            raise e.within(file=scenario.path) from None
        state = streamer.stream(lines)
        if state.failure:
            line = lines[state.failed_line - 1] if state.failed_line else ""
            streamer.wake()  # out of check mode (or an alarm's lock: home before drawing)
            raise InputError(f"the device refused the job in check mode: {state.failure} "
                             f"({line!r})", key="--port", value=options.port)
        leave_check_mode(streamer)
    finally:
        streamer.close()
    return (f"ok: {scenario.title!r}, the {len(lines)} G-code lines a run streams for pen "
            f"profile {pen.name!r} accepted by the device in check mode ($C) on {options.port}, "
            f"page origin at machine "
            f"({ws.origin_mm[0]:g}, {ws.origin_mm[1]:g}) mm; nothing moved")


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
