"""How every run ends: the :class:`Run` it produced, and the one verdict of every backend.

:func:`finished_run` judges a drawing that finished (:func:`inkarm.core.run.judge` against the
scenario's ``[judge]`` bounds, on what the backend senses); :func:`failed_run` keeps what a
fault left (the log to the safe stop, its metrics). The assembly of every backend
(:func:`inkarm.jobs.backends.run_backend`) ends in one of them, so a drawing is judged by the
same rules whichever robot drew it. Nothing here imports the simulator: a plotter's run is
judged without MuJoCo.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from inkarm.analysis.content_cache import ContentCache
from inkarm.analysis.metrics import compute_metrics
from inkarm.core.log import DrawLog
from inkarm.core.run import Metrics, Senses, Shortfall, Status, judge
from inkarm.core.trajectory import Drawing
from inkarm.errors import InputError
from inkarm.ink.canvas import Canvas
from inkarm.jobs.scenario import Scenario
from inkarm.sim.cell_config import Cell

# The plan measures of the drawings last measured (with_plan_measures), by content.
_PLAN_MEASURES = ContentCache(4)
OK, DEGRADED, FAILED, INTERRUPTED = Status.OK, Status.DEGRADED, Status.FAILED, Status.INTERRUPTED
# What the simulation senses: everything (the pen's tip, the ink, contact and force are the
# plant's own truth).
SIM_SENSES = Senses()


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
        status: A :class:`~inkarm.core.run.Status` (a str): "ok" when it finished and every
            bound of the scenario's ``[judge]`` held; "degraded" when it finished but missed
            one (``shortfalls``; ``reason`` names each with its number); "failed" when a
            watchdog or the device stopped it (``reason`` names the watchdog and the fault;
            the pen was lifted, the arm braked, and the log and canvas hold what happened until
            then); "interrupted" (Ctrl-C).
        reason: Why it failed or is degraded; empty when ok.
        drawing: The placed drawing, page [mm] and [s].
        log: One row per control period (:class:`inkarm.core.log.DrawLog`).
        canvas: The ink on the page.
        metrics: Tracking, ink, force, joint and timing figures
            (:class:`~inkarm.core.run.Metrics`, a read-only mapping), of the partial log when
            failed (empty when nothing was logged).
        notes: What the planner changed (e.g. slowed to the robot's speed limits).
        shortfalls: The bounds a finished run missed (:class:`~inkarm.core.run.Shortfall`).
        unjudged: The bounds it was not judged on because the backend cannot sense their
            quantity, each with why (``"force_band_n not judged: ..."``).
    """

    scenario: Scenario
    status: Status
    drawing: Drawing
    log: DrawLog
    canvas: Canvas
    metrics: Metrics = field(default_factory=Metrics)
    reason: str = ""
    notes: tuple[str, ...] = ()
    shortfalls: tuple[Shortfall, ...] = ()
    unjudged: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        self.status = Status(self.status)
        self.metrics = Metrics.of(self.metrics)
        self.shortfalls, self.unjudged = tuple(self.shortfalls), tuple(self.unjudged)

    @property
    def ok(self) -> bool:
        return self.status == OK

    @property
    def finished(self) -> bool:
        """The drawing was completed (ok or degraded): its metrics describe all of it."""
        return self.status.finished

    @property
    def cell(self) -> Cell:
        return Cell(self.scenario.cell, self.scenario.robot)


def finished_run(scenario: Scenario, drawing: Drawing, log: DrawLog, canvas: Canvas,
                 believed, *, senses: Senses = SIM_SENSES, metrics=None,
                 notes: tuple[str, ...] | None = None) -> Run:
    """The Run of a drawing that finished, on any backend: ok, or degraded naming each bound of
    the scenario's ``[judge]`` it missed (:func:`inkarm.core.run.judge`); the bounds on what
    the backend does not ``senses`` are listed as unjudged, with why. ``metrics``: the
    backend's own (default: :func:`measured` of the log, what is not sensed undefined);
    ``notes``: default the log's."""
    if metrics is None:
        metrics = measured(log, drawing, believed, canvas, senses=senses)
    metrics = Metrics.of(metrics)
    shortfalls, unjudged = judge(metrics, scenario.judge, scenario.controller.force_n, senses)
    return Run(scenario, DEGRADED if shortfalls else OK, drawing, log, canvas, metrics,
               reason="; ".join(str(s) for s in shortfalls),
               notes=tuple(log.notes) if notes is None else tuple(notes),
               shortfalls=tuple(shortfalls), unjudged=tuple(unjudged))


def failed_run(scenario: Scenario, drawing: Drawing, fault, canvas: Canvas,
               believed, *, senses: Senses = SIM_SENSES, log: DrawLog | None = None,
               metrics=None, notes: tuple[str, ...] | None = None) -> Run:
    """The Run a watchdog or the device stopped, on any backend: the fault (a
    :class:`RunFault`, or a sentence) as its reason, the log to the safe stop (``log``, default
    the fault's ``log``) and the metrics of that partial log (``metrics``: default
    :func:`measured`; none without ``believed``). Not judged: it did not finish."""
    log = log if log is not None else getattr(fault, "log", None)
    if metrics is None:
        metrics = (measured(log, drawing, believed, canvas, senses=senses)
                   if believed is not None else {})
    if notes is None:
        notes = tuple(log.notes) if log is not None else ()
    return Run(scenario, FAILED, drawing, log, canvas, Metrics.of(metrics), reason=str(fault),
               notes=tuple(notes))


def measured(log: DrawLog | None, drawing: Drawing, believed, canvas,
             senses: Senses = SIM_SENSES) -> Metrics:
    """The metrics of a (possibly partial) log; empty when nothing was logged or drawn. What
    the backend does not sense (``senses``) is undefined (NaN), never a number made up:
    without force the force metrics, and without contact the gaps (found from the force)."""
    if log is None or len(log) == 0 or not log.drawing.any():
        return Metrics()
    metrics = compute_metrics(
        times_s=log.time, reference_mm=log.reference, tip_mm=log.tip,
        force_n=log.force if senses.senses("force") else np.nan_to_num(log.force),
        drawing=log.drawing, q=log.q,
        joint_range=_joint_ranges(believed), wall_time_s=log.wall_s,
        canvas=canvas, plan_strokes=[s.pos[:, :2] for s in drawing.strokes],
    )
    return with_plan_measures(undefined_unsensed(Metrics.of(metrics), senses), drawing)


def with_plan_measures(metrics: Metrics, drawing: Drawing) -> Metrics:
    """``metrics`` with the human-likeness of the planned ``drawing`` (``plan_beta``,
    ``plan_peaks_per_second``, ``plan_jerk_per_peak``), each left out where the drawing does
    not define it (no stroke long enough to measure, a straight line has no power law).
    Computed once per drawing's content (:data:`_PLAN_MEASURES`: an ensemble's members share
    one plan)."""
    arrays = [a for s in drawing.strokes for a in (s.t, s.pos, s.vel, s.pressure)]
    return metrics.replace(**_PLAN_MEASURES.get(arrays, lambda: _plan_measures(drawing)))


def _plan_measures(drawing: Drawing) -> dict[str, float]:
    from inkarm.analysis.humanlike import human_stats

    try:
        stats = human_stats(drawing, lognormal=False)
    except InputError:
        return {}
    values = {"plan_beta": stats.beta, "plan_peaks_per_second": stats.peaks_per_second,
              "plan_jerk_per_peak": stats.jerk_per_peak}
    return {k: float(v) for k, v in values.items() if np.isfinite(v)}


def undefined_unsensed(metrics, senses: Senses) -> Metrics:
    """``metrics`` (a mapping) with those of the quantities not ``senses`` made NaN
    (undefined)."""
    metrics = Metrics.of(metrics)
    nan = float("nan")
    unsensed = {}
    if not senses.senses("force"):
        unsensed.update(contact_force_mean_n=nan, contact_force_std_n=nan, force_p1_n=nan,
                        force_p99_n=nan)
    if not senses.senses("contact"):
        unsensed["gap_mm"] = nan
    if not senses.senses("ink"):
        unsensed["ink_chamfer_mm"] = nan
    if not senses.senses("tip"):
        unsensed.update(tracking_rms_mm=nan, tracking_max_mm=nan)
    return metrics.replace(**{k: v for k, v in unsensed.items() if k in metrics})


def _joint_ranges(believed) -> np.ndarray:
    from inkarm.sim.cell import joint_ranges  # (an arm's model: MuJoCo, only when one is there)

    return joint_ranges(believed.model, believed.joint_names)


__all__ = ["DEGRADED", "FAILED", "INTERRUPTED", "OK", "SIM_SENSES", "Run", "RunInterrupted",
           "failed_run", "finished_run", "measured", "undefined_unsensed"]
