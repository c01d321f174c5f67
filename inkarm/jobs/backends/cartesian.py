"""What the two pen plotters' backends share (the GRBL plotter's, :mod:`.plotter`, and the
AxiDraw's, :mod:`.axidraw`): the sheet, the drawing placed on it, what a plotter senses, and
the steps of a session that are the same on both.

A plotter's session draws the arms' pen path (:func:`inkarm.control.plotter.run_plotter`) on a
plant that plans its own moves (the firmware's planner, or the AxiDraw plant's); Ctrl-C marks
the plant failed, so that its ``close`` stops the machine at once, and keeps the readings so
far as the partial log. Its metrics are the arms'
(:func:`~inkarm.analysis.metrics.compute_metrics`) on the log, with the force undefined (a
plotter senses none). Without a canvas given (an emulator's, a scan), the readings while the
pen is down are inked on the run's own canvas (a polyline through them).
"""

from __future__ import annotations

import numpy as np

from inkarm.analysis.metrics import compute_metrics
from inkarm.control.plotter import run_plotter
from inkarm.core.log import DrawLog
from inkarm.core.run import Metrics, Senses
from inkarm.errors import InputError, RunFault
from inkarm.ink.canvas import Canvas
from inkarm.jobs.backends import BackendOptions, Progress
from inkarm.jobs.outcome import undefined_unsensed, with_plan_measures
from inkarm.jobs.scenario import Scenario, place, source_drawing
from inkarm.sim.cell_config import Cell


def pen_senses(ink: bool, no_force: str, no_ink: str) -> Senses:
    """What a pen plotter senses for the judge: the tip and the pen's contact, never a force
    (``no_force`` says why); the ink only where the run has it (``no_ink`` says why not)."""
    lacking = {"force": no_force}
    if not ink:
        lacking["ink"] = no_ink
    return Senses.without(**lacking)


def page_size_mm(scenario: Scenario) -> tuple[float, float]:
    """The sheet [mm]: the page the scenario's ``[placement]`` names (``page_size``,
    ``landscape``), else the simulated cell's paper (``[sim] paper_size_mm``)."""
    return scenario.placement.sheet_mm(Cell(scenario.cell, scenario.robot).paper_size_mm)


def placed_on_sheet(scenario: Scenario, size: tuple[float, float]):
    """The scenario's drawing placed on the sheet; refused when any of it lies off the sheet
    (the page frame starts at the sheet's lower-left corner), naming the first point off it."""
    from inkarm.plans.page import outside

    drawing = place(source_drawing(scenario), scenario.placement, size)
    first = outside(drawing, (0.0, 0.0), size)
    if first is not None:
        s, i = first
        x, y = drawing.strokes[s].pos[i, :2]
        lo, hi = drawing.bounds()
        raise InputError(f"stroke {s + 1} point {i + 1} at ({x:.2f}, {y:.2f}) mm lies off the "
                         f"sheet: the drawing spans ({lo[0]:.1f}, {lo[1]:.1f}) to ({hi[0]:.1f}, "
                         f"{hi[1]:.1f}) mm, beyond the {size[0]:g} x {size[1]:g} mm sheet (the "
                         "page's origin is the sheet's lower-left corner); lay it out with "
                         "[placement] fit_to_margins_mm = 10, or move or scale it",
                         key="placement", value=(float(x), float(y)))
    return drawing


def ink_measured(canvas: Canvas, log: DrawLog) -> None:
    """Ink the measured tip positions of the rows with the pen down."""
    for t, tip, force in zip(log.time, log.tip, log.force, strict=True):
        if force > 0:
            canvas.touch(tip[:2], float(force), float(t))
        elif canvas.in_contact:
            canvas.lift()
    canvas.lift()


class CartesianSession:
    """The steps a pen plotter's session shares (module docstring). A backend's session sets
    ``drawing``, ``profile`` and ``plant`` when it opens, and says:

    * ``label``: what its notes start with (``plotter``, ``axidraw``);
    * ``device``: the machine in the reason of a fault (``the plotter``);
    * ``planner``: who plans the moves, said when the scenario asks for an arm's law;
    * ``speed_key``: the profile's pen-down speed limit, said when moves were slowed to it;
    * ``readings``: what its own canvas inks;
    * :meth:`device_notes`: its first notes; :meth:`page_range`: the page it reaches.
    """

    believed = None  # (no arm: the plotter plans the moves)
    label = device = planner = speed_key = readings = ""

    def _open_canvas(self, scenario: Scenario, options: BackendOptions,
                     size: tuple[float, float], senses) -> None:
        """The scenario, the canvas (``options.canvas``, else a fresh sheet of ``size`` [mm]
        inked from the readings), what is sensed (``senses(ink)``), no notes yet."""
        self.scenario = scenario
        self.own_canvas = options.canvas is None
        self.canvas = scenario.ink.canvas(size) if self.own_canvas else options.canvas
        self.senses = senses(ink=not self.own_canvas)
        self.notes: tuple[str, ...] = ()

    def device_notes(self, log: DrawLog) -> tuple[str, ...]:
        raise NotImplementedError

    def page_range(self) -> np.ndarray:
        """Per axis (x, y), the page coordinates [mm] the machine reaches."""
        raise NotImplementedError

    def execute(self, progress: Progress) -> DrawLog:
        plant = self.plant
        try:
            log = run_plotter(self.drawing, plant, self.scenario.controller, progress=progress)
        except KeyboardInterrupt as stop:  # a failed plant stops the machine when it closes
            plant.failure = plant.failure or "interrupted by the user"
            stop.log = self.partial_log()  # kept as the sim backend keeps its own
            raise
        self.notes = self.device_notes(log)
        s, name = self.scenario, self.label
        if s.law.name != "position" or s.law.settings or s.watchdogs:
            self.notes += ((f"{name}: {self.planner}; the scenario's law {s.law.name!r} and "
                            "watchdogs are an arm's, not used here"),)
        if plant.clipped:
            limit = getattr(self.profile, self.speed_key)
            self.notes += ((f"{name}: {plant.clipped} pen-down moves slowed to the profile's "
                            f"{self.speed_key} = {limit:g} mm/s"),)
        if self.own_canvas:
            self.notes += (f"{name}: the canvas inks the {self.readings}, not paper",)
        if plant.failure:
            fault = RunFault(f"{self.device} stopped: {plant.failure}", watchdog="device")
            fault.log = log
            raise fault
        return log

    def partial_log(self) -> DrawLog | None:
        """The log of the readings so far (a run stopped by Ctrl-C), against the same pen path
        and schedule a finished run logs; None when nothing was measured."""
        from inkarm.control.plotter import plotter_commands, plotter_log
        from inkarm.control.sequencing import sequence_pen

        plant = self.plant
        readings = plant.readings()
        if not readings:
            return None
        path = sequence_pen(self.drawing, self.scenario.controller, 0.0, plant.dt)
        _, rows, phases = plotter_commands(path, plant.dt)
        ends, plan = plant.schedule()  # (one end per command given so far)
        n = len(ends)
        return plotter_log(path, rows[:n], phases[:n], readings, (ends, plan),
                           self.scenario.controller)

    def measure(self, log: DrawLog | None, finished: bool) -> Metrics:
        if log is not None and self.own_canvas:
            ink_measured(self.canvas, log)
        if not finished or log is None:
            return Metrics()
        metrics = compute_metrics(
            times_s=log.time, reference_mm=log.reference, tip_mm=log.tip, force_n=log.force,
            drawing=log.drawing, q=log.q, joint_range=self.page_range() / 1000.0,
            wall_time_s=max(log.wall_s, 1e-9), canvas=self.canvas,
            plan_strokes=[s.pos[:, :2] for s in self.drawing.strokes],
            contact_threshold_n=self.scenario.controller.contact_threshold_n)
        # The arms' judge; a plotter's tracking error is its distance from its plant's own
        # plan at the readings' times (see inkarm.control.plotter), its force the nominal one
        # while the pen is down (undefined here: not sensed).
        return with_plan_measures(undefined_unsensed(metrics, self.senses), self.drawing)

    def close(self) -> None:
        self.plant.close()


__all__ = ["CartesianSession", "ink_measured", "page_size_mm", "pen_senses", "placed_on_sheet"]
