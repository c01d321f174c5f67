"""Control laws compared on one scenario: the ``sensorimotor`` law (seed 001, sec. 4-5) against
the LQT reference drawn by the joint-space laws (:mod:`inkarm.control.laws`).

Every law draws the same scenario (the same placed drawing, the same plan); the measures, all on
the drawing rows in page [mm]:

- path error: distance of each pen position to the reference path (the planned path of its
  stroke, as a curve, whatever the timing), RMS and maximum; and the time-based tracking RMS
  of the run's metrics (pen against the plan row of its own instant);
- speed profile: the pen's speed peaks per second (local maxima standing out by 10 % of the
  stroke's top speed) and its peak speed;
- ink: the chamfer distance of the ink's centreline to the plan (the run's ``ink_chamfer_mm``)
  and to the ink of the first law (the reference);
- overshoot against curvature (seed 001 Fig. 3): at every DPPLA target x_j inside a stroke (the
  sensorimotor law's own targets, :func:`inkarm.control.laws.sensorimotor.dppla_targets`), with
  u the reference path's direction into x_j (from its point ``arc_mm`` of arc before; DPPLA
  may put two targets a fraction of a millimetre apart where the path slows), how much farther along u the pen carries on past
  x_j (from half-way in from the previous target to the next target's time) than the reference
  path reaches (from the same start to the target after next, and at least as long again after
  the next target as from the previous one to it, wherever it is timed):

      overshoot_j = max(0, max_pen (pen - x_j) . u - max_reference (reference - x_j) . u);

  on a straight stretch the reference reaches two targets on, and nothing counts; at a corner it
  turns away, and the pen's momentum past the corner does. Against the reference path's
  curvature at x_j: the turn between the chords to the path ``arc_mm`` before and after x_j,
  over ``arc_mm`` [1/mm] (1 / radius).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from inkarm.analysis.metrics import (
    chamfer_mm,
    half_darkest,
    ink_centreline_mm,
    ink_within,
    resample_polyline,
)
from inkarm.analysis.peaks import find_peaks
from inkarm.control.laws.sensorimotor import Sensorimotor, Targets, dppla_targets, stroke_rows
from inkarm.control.reference import JointReference, plan_within_speed_limits
from inkarm.core.log import DRAW
from inkarm.errors import InputError
from inkarm.jobs.run import Run, run
from inkarm.jobs.scenario import Scenario
from inkarm.sim.cell import Cell, kinematic_model

DEFAULT_LAWS = (
    ("position", "LQT reference, position goals (default law)"),
    ("joint_pid", "LQT reference, joint PID"),
    ("sensorimotor", "sensorimotor: DPPLA targets, learnt (LWR) inverse, PID"),
    ("sensorimotor", "sensorimotor, analytic Jacobian inverse", {"inverse": "jacobian"}),
)
"""(law, label[, settings]): each law drawn with ``settings`` (the scenario's own law with its
``[controller.<law>]`` settings updated by them); the first is the reference the others' ink is
compared with."""
CURVATURE_BINS = (0.0, 0.05, 0.2, 0.5, math.inf)
"""Edges of the curvature bins [1/mm] (radius > 20 mm, 5-20 mm, 2-5 mm, < 2 mm)."""
ARC_MM = 1.5
PEAK_PROMINENCE = 0.1
PATH_SPACING_MM = 0.02


@dataclass(frozen=True, eq=False)
class LawResult:
    """One law's run of the scenario and its measures (module docstring).

    Attributes:
        law, label: The law's registered name and its label in tables and figures.
        settings: The law's settings changed from the scenario's.
        run: The :class:`Run`.
        time, tip, speed: Per stroke, the drawing rows' time [s], pen (x, y) [mm] and pen
            speed [mm/s].
        path_rms_mm, path_max_mm: Path error against the reference path.
        tracking_rms_mm: The run's time-based tracking RMS.
        peaks_per_s, peak_speed_mm_s: Speed profile.
        ink_vs_plan_mm, ink_vs_reference_mm: Ink chamfer distances.
        overshoot_mm: Per interior target (``Comparison.curvature``), the overshoot.
    """

    law: str
    label: str
    settings: tuple[tuple[str, object], ...]
    run: Run
    time: tuple[np.ndarray, ...]
    tip: tuple[np.ndarray, ...]
    speed: tuple[np.ndarray, ...]
    path_rms_mm: float
    path_max_mm: float
    tracking_rms_mm: float
    peaks_per_s: float
    peak_speed_mm_s: float
    ink_vs_plan_mm: float
    ink_vs_reference_mm: float
    overshoot_mm: np.ndarray

    @property
    def status(self) -> str:
        return str(self.run.status)

    @property
    def key(self) -> str:
        """The law's name, with its changed settings: ``sensorimotor(inverse=jacobian)``."""
        if not self.settings:
            return self.law
        return f"{self.law}({', '.join(f'{k}={v}' for k, v in self.settings)})"


@dataclass(frozen=True, eq=False)
class Comparison:
    """The laws compared on one scenario.

    Attributes:
        scenario: The scenario drawn.
        compression: The DPPLA compression rate of the targets.
        plan: The plan every law was given (its drawing rows are the reference path).
        targets: The DPPLA targets of the plan (the sensorimotor law's commands).
        reference: Per stroke, the reference path (x, y) [mm]; ``reference_time`` [s] from
            the stroke's start and ``reference_speed`` [mm/s].
        interior: Indices into ``targets`` of the targets inside strokes (not first, not last).
        curvature: The reference path's curvature at each interior target [1/mm].
        results: One :class:`LawResult` per law, the reference first.
    """

    scenario: Scenario
    compression: float
    plan: JointReference
    targets: Targets
    reference: tuple[np.ndarray, ...]
    reference_time: tuple[np.ndarray, ...]
    reference_speed: tuple[np.ndarray, ...]
    interior: np.ndarray
    curvature: np.ndarray
    results: tuple[LawResult, ...] = field(default=())

    def result(self, label: str) -> LawResult:
        """The result labelled or keyed (:attr:`LawResult.key`) ``label``, or the first of the
        law named ``label``."""
        for r in self.results:
            if label in (r.label, r.key):
                return r
        for r in self.results:
            if r.law == label:
                return r
        raise InputError(f"no law {label!r} in this comparison", key="law", value=label,
                         choices=[r.label for r in self.results])

    def table(self) -> str:
        """The markdown table of the measures, one row per law (and the plan's own speed)."""
        peaks, top = speed_profile(self.reference_speed, self.reference_time)
        rows = [("| law | status | path RMS / max [mm] | tracking RMS [mm] | speed peaks [1/s] | "
                 "peak speed [mm/s] | ink to plan / to reference [mm] | mean overshoot [mm] |"),
                "|---|---|---|---|---|---|---|---|",
                (f"| the plan (LQT through the DPPLA targets) | | 0 / 0 | 0 | {peaks:.1f} | "
                 f"{top:.0f} | | 0 |")]
        for r in self.results:
            rows.append(
                f"| {r.label} | {r.status} | {r.path_rms_mm:.2f} / {r.path_max_mm:.2f} | "
                f"{r.tracking_rms_mm:.2f} | {r.peaks_per_s:.1f} | {r.peak_speed_mm_s:.0f} | "
                f"{r.ink_vs_plan_mm:.2f} / {r.ink_vs_reference_mm:.2f} | "
                f"{float(np.mean(r.overshoot_mm)) if r.overshoot_mm.size else 0.0:.2f} |")
        return "\n".join(rows)

    def overshoot_table(self, edges=CURVATURE_BINS) -> str:
        """The markdown table of the mean (and largest) overshoot per curvature bin."""
        bins = curvature_bins(self.curvature, edges)
        head = "| curvature [1/mm] (radius) | targets | " + " | ".join(
            f"{r.key}: mean (max) [mm]" for r in self.results) + " |"
        rows = [head, "|" + "---|" * (2 + len(self.results))]
        for (lo, hi), members in zip(itertools.pairwise(edges), bins):
            radius = (f"> {1 / hi:g} mm" if lo == 0 else f"< {1 / lo:g} mm" if math.isinf(hi)
                      else f"{1 / hi:g}-{1 / lo:g} mm")
            label = f"{lo:g}-{hi:g} ({radius})" if not math.isinf(hi) else f"> {lo:g} ({radius})"
            cells = []
            for r in self.results:
                o = r.overshoot_mm[members]
                cells.append(f"{o.mean():.2f} ({o.max():.2f})" if o.size else "-")
            rows.append(f"| {label} | {int(members.size)} | " + " | ".join(cells) + " |")
        return "\n".join(rows)


def curvature_bins(curvature: np.ndarray, edges=CURVATURE_BINS) -> list[np.ndarray]:
    """Indices of ``curvature`` in each bin [edges[i], edges[i+1])."""
    curvature = np.asarray(curvature)
    return [np.flatnonzero((curvature >= lo) & (curvature < hi))
            for lo, hi in itertools.pairwise(edges)]


def path_curvature(path: np.ndarray, at: np.ndarray, arc_mm: float = ARC_MM) -> np.ndarray:
    """Curvature [1/mm] of the polyline ``path`` (K, 2) at its samples ``at``: the angle
    between the chords to the points ``arc_mm`` of arc length before and after, over
    ``arc_mm`` (1 / radius on a circle; clipped at the path's ends)."""
    path = np.asarray(path, dtype=float)
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))]

    def point(arc):
        arc = np.clip(arc, 0.0, s[-1])
        return np.column_stack([np.interp(arc, s, path[:, 0]), np.interp(arc, s, path[:, 1])])

    here = path[at]
    before, after = point(s[at] - arc_mm), point(s[at] + arc_mm)
    a, b = here - before, after - here
    cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    angle = np.abs(np.arctan2(cross, (a * b).sum(axis=1)))
    return angle / arc_mm


def speed_profile(speed: tuple[np.ndarray, ...], time: tuple[np.ndarray, ...],
                  prominence: float = PEAK_PROMINENCE) -> tuple[float, float]:
    """(speed peaks per second, peak speed [mm/s]) over the strokes: the local maxima that
    stand out by ``prominence`` x the stroke's top speed, over the strokes' total duration."""
    peaks, duration, top = 0, 0.0, 0.0
    for v, t in zip(speed, time):
        if len(v) < 3:
            continue
        found = find_peaks(v, prominence=prominence * float(v.max()))
        peaks += len(found)
        duration += float(t[-1] - t[0])
        top = max(top, float(v.max()))
    return (peaks / duration if duration > 0 else 0.0), top


def path_error(tip: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Distance [mm] of each point of ``tip`` (K, 2) to the polyline ``reference`` (M, 2)."""
    dense = resample_polyline(reference, PATH_SPACING_MM)[:, :2]
    distance, _ = cKDTree(dense).query(tip)
    return distance


def overshoots(tip: np.ndarray, tip_rows: np.ndarray, reference: np.ndarray,
               ref_rows: np.ndarray, targets: Targets, interior: np.ndarray,
               arc_mm: float = ARC_MM) -> np.ndarray:
    """Overshoot [mm] at each interior target of one stroke (module docstring). ``tip``
    (K, 2) are the pen's positions at the plan rows ``tip_rows`` (K,), ``reference`` (M, 2) the
    stroke's reference path at the plan rows ``ref_rows`` (M,)."""
    out = np.zeros(len(interior))
    last = len(targets) - 1
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(reference, axis=0), axis=1))]
    for n, j in enumerate(interior):
        x = targets.xy[j]
        here = arc[np.searchsorted(ref_rows, targets.row[j])]
        back = max(here - arc_mm, 0.0)
        u = x - np.array([np.interp(back, arc, reference[:, 0]),
                          np.interp(back, arc, reference[:, 1])])
        norm = float(np.hypot(u[0], u[1]))
        if norm == 0.0:
            continue
        u = u / norm
        lo = 0.5 * (targets.row[j - 1] + targets.row[j])
        pen = tip[(tip_rows >= lo) & (tip_rows <= targets.row[j + 1])]
        after = min(j + 2, last)
        ahead = targets.row[after] if targets.stroke[after] == targets.stroke[j] else ref_rows[-1]
        ahead = max(ahead, 2 * targets.row[j + 1] - targets.row[j - 1])
        ref = reference[(ref_rows >= lo) & (ref_rows <= ahead)]
        if len(pen) and len(ref):
            out[n] = max(0.0, float(((pen - x) @ u).max() - ((ref - x) @ u).max()))
    return out


def _plan_of(scenario: Scenario, first: Run) -> JointReference:
    """The plan the runs were given, made again as the executor made it."""
    model = kinematic_model(Cell(scenario.cell, scenario.robot))
    plan, _ = plan_within_speed_limits(first.drawing, model, scenario.controller,
                                       first.log.q[0].copy(), scenario.robot.control_period_s,
                                       speed_limits=scenario.robot.speed_limits)
    return plan


def _measure(law: str, label: str, settings, result: Run, plan: JointReference, strokes, targets: Targets,
             interior: np.ndarray, reference_ink: np.ndarray | None, arc_mm: float = ARC_MM) -> tuple[LawResult, np.ndarray]:
    """The measures of one law's run (module docstring)."""
    log = result.log
    times, tips, speeds, errors = [], [], [], []
    overshoot = np.zeros(len(interior))
    for rows in strokes:
        mine = np.flatnonzero((log.phase == DRAW) & (log.stroke == plan.stroke[rows[0]]))
        if len(mine) < 2:
            continue
        t, tip = log.time[mine], log.tip[mine, :2]
        times.append(t)
        tips.append(tip)
        speeds.append(np.linalg.norm(np.gradient(tip, t, axis=0), axis=1))
        errors.append(path_error(tip, plan.page_mm[rows, :2]))
        # the log's drawing rows of the stroke follow the plan's one for one from its first
        inside = np.flatnonzero((targets.row[interior] >= rows[0])
                                & (targets.row[interior] <= rows[-1]))
        overshoot[inside] = overshoots(tip, rows[0] + np.arange(len(mine)),
                                       plan.page_mm[rows, :2], rows, targets, interior[inside],
                                       arc_mm)
    if not errors:
        raise InputError(f"law {law!r}: the run drew nothing ({result.reason})", key="law",
                         value=law)
    error = np.concatenate(errors)
    peaks, top = speed_profile(tuple(speeds), tuple(times))
    canvas = result.canvas
    within = ink_within(canvas)
    ink = ink_centreline_mm(canvas.image, canvas.px_per_mm,
                            half_darkest(canvas.image, within) or 0.5e-9, within=within)
    to_reference = 0.0 if reference_ink is None else chamfer_mm(ink, reference_ink)
    return LawResult(
        law=law, label=label, settings=settings, run=result, time=tuple(times), tip=tuple(tips),
        speed=tuple(speeds), path_rms_mm=float(np.sqrt(np.mean(error ** 2))),
        path_max_mm=float(error.max()),
        tracking_rms_mm=float(result.metrics.to_dict().get("tracking_rms_mm", math.nan)),
        peaks_per_s=peaks, peak_speed_mm_s=top,
        ink_vs_plan_mm=float(result.metrics.to_dict().get("ink_chamfer_mm", math.nan)),
        ink_vs_reference_mm=to_reference,
        overshoot_mm=overshoot,
    ), ink


def compare_laws(scenario: Scenario, laws=DEFAULT_LAWS, compression: float | None = None,
                 arc_mm: float = ARC_MM) -> Comparison:
    """Draw ``scenario`` with each law of ``laws`` ((name, label[, settings]), the reference
    first; the scenario's own law with its ``[controller.<name>]`` settings, updated by
    ``settings``; another law with ``settings``) and measure them
    (module docstring). ``compression``: the DPPLA rate of the targets the overshoot is
    measured at; default the sensorimotor law's (its setting in the scenario, else its
    default)."""
    laws = tuple((entry[0], entry[1], tuple(sorted(dict(entry[2] if len(entry) > 2 else {})
                                                        .items())))
                 for entry in laws)
    if not laws:
        raise InputError("compare_laws: no law to compare", key="laws")
    if compression is None:
        spec = scenario.with_overrides({"controller.law": "sensorimotor"}).law
        compression = dict(spec.settings).get("compression", Sensorimotor().compression)
    runs = [run(scenario.with_overrides({"controller.law": name, **{
        f'controller."{name}".{key}': value for key, value in settings}}))
        for name, _, settings in laws]
    plan = _plan_of(scenario, runs[0])
    targets = dppla_targets(plan.page_mm, plan.phase, plan.stroke, compression)
    strokes = stroke_rows(plan.phase, plan.stroke)
    interior = np.array([j for j in range(1, len(targets) - 1)
                         if targets.stroke[j - 1] == targets.stroke[j] == targets.stroke[j + 1]],
                        dtype=np.intp)
    dt = scenario.robot.control_period_s
    reference = tuple(plan.page_mm[rows, :2] for rows in strokes)
    reference_time = tuple((rows - rows[0]) * dt for rows in strokes)
    reference_speed = tuple(np.linalg.norm(np.gradient(r, dt, axis=0), axis=1)
                            for r in reference)
    curvature = np.zeros(len(interior))
    for rows, path in zip(strokes, reference):
        mine = np.flatnonzero((targets.row[interior] >= rows[0])
                              & (targets.row[interior] <= rows[-1]))
        curvature[mine] = path_curvature(path, targets.row[interior[mine]] - rows[0], arc_mm)
    results, reference_ink = [], None
    for (name, label, settings), result in zip(laws, runs):
        measured, ink = _measure(name, label, settings, result, plan, strokes, targets, interior,
                                 reference_ink, arc_mm)
        if reference_ink is None:
            reference_ink = ink
        results.append(measured)
    return Comparison(scenario, float(compression), plan, targets, reference, reference_time,
                      reference_speed, interior, curvature, tuple(results))


def comparison_figure(comparison: Comparison, laws: tuple[str, ...] | None = None,
                      zoom_mm: float = 5.0, window_s: tuple[float, float] | None = None):
    """The figure of ``comparison`` (:func:`inkarm.plots.laws.plot_law_comparison`) for the
    ``laws`` keyed (:attr:`LawResult.key`; default all), with an inset ``zoom_mm`` either side of the target where the
    last of them overshoots most."""
    from inkarm.plots.laws import plot_law_comparison

    results = [r for r in comparison.results if laws is None or r.key in laws]
    zoom = None
    last = results[-1].overshoot_mm if results else np.zeros(0)
    sharp = comparison.curvature >= CURVATURE_BINS[-2]
    if last.size and (last[sharp] > 0).any():
        pick = np.flatnonzero(sharp)[int(np.argmax(last[sharp]))]
        x, y = comparison.targets.xy[comparison.interior[pick]]
        zoom = (float(x), float(y), zoom_mm)
    return plot_law_comparison(
        comparison.reference, comparison.targets.xy,
        paths={r.label: r.tip for r in results}, times={r.label: r.time for r in results},
        speeds={r.label: r.speed for r in results}, curvature=comparison.curvature,
        overshoot={r.label: r.overshoot_mm for r in results},
        reference_time=comparison.reference_time, reference_speed=comparison.reference_speed,
        zoom=zoom, bins=CURVATURE_BINS, window_s=window_s)


__all__ = ["ARC_MM", "CURVATURE_BINS", "DEFAULT_LAWS", "Comparison", "LawResult", "compare_laws", "comparison_figure",
           "curvature_bins", "overshoots", "path_curvature", "path_error", "speed_profile"]
