"""A scenario drawn on an AxiDraw (EiBotBoard firmware): the ``axidraw`` backend of
:mod:`inkarm.jobs.backends`.

The scenario's drawing is placed on its sheet as for the GRBL plotter, the sheet on the
machine with its upper-left corner at the profile's ``page_origin`` (the AxiDraw convention:
at home, :mod:`inkarm.hardware.axidraw.placement`), and every point is checked against the
machine's travel before the port is opened. The pen path is the arms' and the GRBL plotter's
(:func:`inkarm.control.plotter.run_plotter`), planned into acceleration-limited ``SM`` moves
and streamed by :class:`~inkarm.hardware.axidraw.plant.AxiDrawPlant`; the result is the same
:class:`~inkarm.jobs.run.Run` with the same metrics and the same judge. A fault (a reply lost,
an ``!`` error, a disconnect, steps lost) ends the run failed with the pen up and the log kept.

What an AxiDraw senses: its step counters and its pen's commanded state; no force, and no ink
unless the run is given a canvas (an emulator's, or a scan); without one, the readings while
the pen is down are inked (a polyline through them).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from inkarm.core.log import DrawLog
from inkarm.core.run import Senses
from inkarm.errors import InkarmError
from inkarm.hardware.axidraw.bus import EbbBus, version_text
from inkarm.hardware.axidraw.placement import SheetPlacement
from inkarm.hardware.axidraw.plant import AxiDrawPlant
from inkarm.hardware.axidraw.profiles import AxiDrawProfile, load_profile
from inkarm.ink.canvas import Canvas
from inkarm.jobs.backends import BackendOptions, Progress, run_backend
from inkarm.jobs.backends.cartesian import (
    CartesianSession,
    page_size_mm,
    pen_senses,
    placed_on_sheet,
)
from inkarm.jobs.outcome import Run
from inkarm.jobs.scenario import Scenario

PERIOD_S = 0.01  # the pen path's control period [s]
NO_FORCE = "an AxiDraw senses no pen force (its pen is up or down)"
READINGS_INK = "the ink is on the paper; this run's canvas inks the step-counter readings"


def axidraw_senses(ink: bool) -> Senses:
    """What an AxiDraw senses for the judge: the tip (its step counters) and the pen's contact
    (its commanded state), never a force; the ink only where the run has a canvas."""
    return pen_senses(ink, NO_FORCE, READINGS_INK)


def prepared(scenario: Scenario, profile: str | None):
    """The AxiDraw profile (``profile``, else the scenario's ``[axidraw] profile``, else ``v3``;
    the scenario's ``[axidraw] page_origin`` over the profile's), the sheet's size [mm], the
    drawing on it and the sheet on the machine; every point of the drawing within the
    machine's travel. Errors name the scenario file."""
    table = dict(scenario.axidraw)
    try:
        axidraw = load_profile(profile or table.get("profile"))
        if "page_origin" in table:
            axidraw = replace(axidraw, page_origin=tuple(table["page_origin"]))
        size = page_size_mm(scenario)
        drawing = placed_on_sheet(scenario, size)
        placement = SheetPlacement(size, axidraw.page_origin, axidraw.travel_mm, axidraw.model)
        placement.check_strokes([s.pos[:, :2] for s in drawing.strokes])
        return axidraw, size, drawing, placement
    except InkarmError as e:
        raise e.within(file=scenario.path) from None


class AxiDrawSession(CartesianSession):
    """A scenario on the AxiDraw at ``options.port`` (module docstring)."""

    interrupted = ("interrupted by the user (Ctrl-C); the AxiDraw's moves were stopped (ES), "
                   "its pen lifted and its motors turned off")
    label, device, speed_key = "axidraw", "the AxiDraw", "speed_pendown_mm_s"
    planner, readings = "the plant plans the moves", "step-counter readings"

    def __init__(self, scenario: Scenario, options: BackendOptions, dt: float = PERIOD_S):
        self.profile, size, self.drawing, self.placement = prepared(scenario, options.profile)
        self._open_canvas(scenario, options, size, axidraw_senses)
        bus = EbbBus(options.port, options.baudrate)
        try:
            bus.hello()
            self.plant = AxiDrawPlant(bus, self.profile, self.placement, dt=dt,
                                      time_scale=options.time_scale,
                                      pen_force_n=scenario.controller.force_n)
        except BaseException:
            bus.close()
            raise

    def device_notes(self, log: DrawLog) -> tuple[str, ...]:
        plant, p, o = self.plant, self.profile, self.placement.origin_mm
        return ((f"axidraw: {len(plant.motions)} EBB motion commands (SM, SP), profile "
                 f"{p.name!r} (AxiDraw {p.model}), firmware "
                 f"{version_text(plant.bus.version)}, {len(log)} readings (QS, QP: the "
                 "log's rows)"),
                (f"axidraw: the sheet's upper-left corner at machine ({o[0]:g}, {o[1]:g}) "
                 "mm from home (the carriage parked at the upper-left stops at the start)"))

    def page_range(self) -> np.ndarray:
        return page_range(self.placement)


class AxiDrawBackend:
    name = "axidraw"
    help = "an AxiDraw (EiBotBoard firmware) on a USB serial port"
    needs_port = True

    def check(self, scenario: Scenario, options: BackendOptions) -> str:
        return check_axidraw_scenario(scenario, options.profile, options)

    def open(self, scenario: Scenario, options: BackendOptions) -> AxiDrawSession:
        return AxiDrawSession(scenario, options)


def page_range(placement: SheetPlacement) -> np.ndarray:
    """Per page axis (x, y), the page coordinates [mm] the carriage reaches."""
    (ox, oy), (tx, ty), h = placement.origin_mm, placement.travel_mm, placement.size_mm[1]
    return np.array([[-ox, tx - ox], [h + oy - ty, h + oy]])


def planned_motions(scenario: Scenario, profile: AxiDrawProfile, placement: SheetPlacement,
                    drawing, dt: float = PERIOD_S) -> AxiDrawPlant:
    """The plant's plan of a run, nothing sent: its ``motions`` (EBB commands) and timeline."""
    from inkarm.control.plotter import plotter_commands
    from inkarm.control.sequencing import sequence_pen

    plant = AxiDrawPlant(None, profile, placement, dt=dt)
    for command in plotter_commands(sequence_pen(drawing, scenario.controller, 0.0, dt), dt)[0]:
        plant.command(command)
    plant.finish()
    return plant


def check_axidraw_scenario(scenario: Scenario, profile: str | None = None,
                           options: BackendOptions | None = None) -> str:
    """Everything an AxiDraw run checks before it opens the port (profile, source, placement,
    travel), the motion it would send and its time; with a port, the EBB's firmware too
    (``V``). Nothing moves."""
    axidraw, _, drawing, placement = prepared(scenario, profile)
    plant = planned_motions(scenario, axidraw, placement, drawing)
    seconds = plant.motions[-1].end if plant.motions else 0.0
    where = "nothing sent"
    if options is not None and options.port:
        bus = EbbBus(options.port, options.baudrate)
        try:
            version = bus.hello()
        finally:
            bus.close()
        where = (f"the EBB on {options.port} has firmware {version_text(version)}; "
                 "nothing moved")
    return (f"ok: {scenario.title!r}, {len(drawing.strokes)} strokes within the AxiDraw "
            f"{axidraw.model}'s travel; a run sends {len(plant.motions)} EBB motion commands "
            f"(SM, SP) for profile {axidraw.name!r}, about {seconds:.1f} s of motion; {where}")


def run_axidraw_scenario(scenario: Scenario, port: str | None, *, profile: str | None = None,
                         time_scale: float = 1.0, progress: Progress = None,
                         canvas: Canvas | None = None) -> Run:
    """Draw ``scenario`` on the AxiDraw at ``port`` (the ``axidraw`` backend); a fault
    returns a Run with status "failed", the reason, the log so far and the pen up."""
    return run_backend("axidraw", scenario, BackendOptions(
        port=port, profile=profile, time_scale=time_scale, canvas=canvas), progress)


__all__ = ["AxiDrawBackend", "AxiDrawSession", "axidraw_senses", "check_axidraw_scenario",
           "page_range", "planned_motions", "prepared", "run_axidraw_scenario"]
