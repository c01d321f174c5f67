"""Regression tests of controllers: re-run a scenario and compare it with its baseline.

Each metric has a direction and a tolerance in its own unit (:data:`RULES`); a metric fails
only when it gets *worse* than the baseline by more than its tolerance:

    worse_by = s (new - baseline)          s = +1 where lower is better, -1 where higher is
    worse_by = |new - F*| - |baseline - F*| for the mean contact force (F* the set point)
    regressed  <=>  worse_by > tolerance

Besides the run's own metrics (:mod:`inkarm.analysis.metrics`) the comparison measures the ink
against the baseline's ink (:mod:`inkarm.jobs.regress.ink`: missing and extra ink [mm],
IoU) and the drawn path against the baseline's (``path_deviation_mm``: the symmetric Hausdorff
distance between the pen-down paths, each resampled every :data:`PATH_SPACING_MM`). The
real-time factor is reported, never gated: wall-clock time is the machine's, not the
controller's.

Runs are deterministic: MuJoCo steps the same state to the same bits on one build, every
random choice is seeded by the scenario, and the controller sees simulated time, never the
clock, so a slower machine draws the same page. The tolerances leave room for a different
build of NumPy, SciPy or MuJoCo (other BLAS kernels, other summation order), not for noise.
A run whose status is not "ok" fails with its reason, whatever its metrics; one that finished
(e.g. "degraded") is measured too, so the failure also names every metric that got worse.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from inkarm.analysis.metrics import resample_polyline
from inkarm.errors import InputError
from inkarm.jobs.regress.baseline import (
    BASELINES_DIR,
    MARKER,
    Baseline,
    baseline_dir,
    page_grey,
    read_baseline,
)
from inkarm.jobs.regress.ink import compare_ink
from inkarm.jobs.run import Run
from inkarm.jobs.scenario import Scenario

LOWER, HIGHER, TARGET, REPORT = "lower", "higher", "target", "report"
PATH_SPACING_MM = 0.05


@dataclass(frozen=True)
class Rule:
    """How a metric is judged: ``direction`` is "lower" or "higher" (which is better),
    "target" (closer to the force set point is better) or "report" (never gated);
    ``tolerance`` is in the metric's ``unit``."""

    direction: str
    tolerance: float
    unit: str


RULES: dict[str, Rule] = {
    "tracking_rms_mm": Rule(LOWER, 0.02, "mm"),
    "tracking_max_mm": Rule(LOWER, 0.1, "mm"),
    "ink_chamfer_mm": Rule(LOWER, 0.02, "mm"),
    "gap_mm": Rule(LOWER, 0.5, "mm"),
    "contact_force_mean_n": Rule(TARGET, 0.02, "N"),
    "contact_force_std_n": Rule(LOWER, 0.01, "N"),
    "force_p1_n": Rule(TARGET, 0.02, "N"),  # the ends of the force band: further from F*
    "force_p99_n": Rule(TARGET, 0.02, "N"),
    "joint_limit_margin_rad": Rule(HIGHER, 0.01, "rad"),
    "realtime_factor": Rule(REPORT, 0.0, ""),
    "ink_missing_mm": Rule(LOWER, 0.3, "mm"),
    "ink_extra_mm": Rule(LOWER, 0.3, "mm"),
    "ink_iou": Rule(HIGHER, 0.1, ""),
    "path_deviation_mm": Rule(LOWER, 0.1, "mm"),
}
"""Default rules; a baseline's ``tolerances.toml`` replaces tolerances per scenario. A metric
not listed here is reported, not gated."""

# Metrics measured against the baseline: zero (one for IoU) when the run is the baseline.
COMPARED = {"ink_missing_mm": 0.0, "ink_extra_mm": 0.0, "ink_iou": 1.0, "path_deviation_mm": 0.0}


@dataclass(frozen=True)
class MetricCheck:
    """One metric of a run against its baseline; ``worse_by`` None when not gated."""

    name: str
    baseline: float | None
    new: float | None
    rule: Rule
    tolerance: float
    worse_by: float | None

    @property
    def gated(self) -> bool:
        return self.rule.direction != REPORT

    @property
    def regressed(self) -> bool:
        return self.worse_by is not None and self.worse_by > self.tolerance

    def describe(self) -> str:
        """``tracking_rms_mm got worse by 0.12 mm (0.15 -> 0.27 mm; tolerance 0.02 mm)``."""
        unit = f" {self.rule.unit}" if self.rule.unit else ""
        if self.new is None:
            return f"{self.name} is undefined now (baseline {_fmt(self.baseline)}{unit})"
        return (f"{self.name} got worse by {_fmt(self.worse_by)}{unit} ({_fmt(self.baseline)} "
                f"-> {_fmt(self.new)}{unit}; tolerance {_fmt(self.tolerance)}{unit})")


@dataclass(eq=False)
class Comparison:
    """A scenario's run against its baseline.

    Attributes:
        name: The scenario's file stem (the baseline folder's name).
        status, reason: The new run's status and why it was not ok.
        checks: One per metric, gated or reported.
        base_grey, new_grey: The two pages (8-bit grey) for the report's images.
        versions: The baseline's library versions.
    """

    name: str
    scenario: Scenario
    status: str
    reason: str
    checks: tuple[MetricCheck, ...]
    px_per_mm: float
    base_grey: np.ndarray | None = None
    new_grey: np.ndarray | None = None
    wall_s: float = 0.0
    versions: dict[str, str] = field(default_factory=dict)

    @property
    def regressions(self) -> list[MetricCheck]:
        return [c for c in self.checks if c.regressed]

    @property
    def passed(self) -> bool:
        return self.status == "ok" and not self.regressions

    def failure_message(self) -> str:
        """Why it failed: the run's status and reason when it is not ok, then one line per
        metric that got worse; empty when it passed."""
        lines = [f"the run {self.status}: {self.reason}"] if self.status != "ok" else []
        return "\n".join(lines + [c.describe() for c in self.regressions])


def _fmt(value: float | None) -> str:
    if value is None:
        return "undefined"
    return f"{value:.4g}"


def _number(value) -> float | None:
    return float(value) if isinstance(value, int | float) and math.isfinite(value) else None


def check_metric(name: str, baseline, new, rule: Rule, tolerance: float,
                 set_point: float = 0.0) -> MetricCheck:
    """Judge one metric (see the module docstring). An undefined new value fails against a
    defined baseline; against an undefined baseline anything passes."""
    base, value = _number(baseline), _number(new)
    if rule.direction == REPORT or base is None:
        return MetricCheck(name, base, value, rule, tolerance, None)
    if value is None:
        return MetricCheck(name, base, value, rule, tolerance, math.inf)
    if rule.direction == LOWER:
        worse = value - base
    elif rule.direction == HIGHER:
        worse = base - value
    elif rule.direction == TARGET:
        worse = abs(value - set_point) - abs(base - set_point)
    else:
        raise InputError(f"unknown metric direction {rule.direction!r}", key=name)
    return MetricCheck(name, base, value, rule, tolerance, float(worse))


def path_deviation_mm(tip_a, down_a, tip_b, down_b) -> float:
    """Symmetric Hausdorff distance [mm] between two pen-down paths, each the (x, y) tips of
    its pen-down rows, resampled every :data:`PATH_SPACING_MM` along each stroke (so that
    the result does not depend on the control period). 0 when neither path has a pen-down
    row; inf when only one has."""
    a, b = _pen_down_points(tip_a, down_a), _pen_down_points(tip_b, down_b)
    if len(a) == 0 or len(b) == 0:
        return 0.0 if len(a) == len(b) else math.inf
    d_ab = cKDTree(b).query(a)[0].max()
    d_ba = cKDTree(a).query(b)[0].max()
    return float(max(d_ab, d_ba))


def _pen_down_points(tip, down) -> np.ndarray:
    tip, down = np.asarray(tip, float)[:, :2], np.asarray(down, bool)
    edges = np.diff(np.concatenate(([0], down.astype(np.int8), [0])))
    pieces = [resample_polyline(tip[start:stop], PATH_SPACING_MM)
              for start, stop in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1))]
    return np.concatenate(pieces) if pieces else np.zeros((0, 2))


def compare(run: Run, baseline: Baseline, name: str = "") -> Comparison:
    """Judge ``run`` against ``baseline`` metric by metric (:data:`RULES`, the baseline's
    tolerances first)."""
    name = name or baseline.folder.name
    wall_s = run.log.wall_s if run.log is not None else 0.0
    common = {"scenario": run.scenario, "px_per_mm": baseline.px_per_mm,
              "base_grey": baseline.grey, "wall_s": wall_s, "versions": baseline.versions}
    if not run.metrics:  # it did not finish: nothing to measure
        return Comparison(name, status=run.status, reason=run.reason, checks=(),
                          new_grey=page_grey(run), **common)
    new_grey = page_grey(run)
    measured = dict(run.metrics)
    measured.update(compare_ink(baseline.grey, new_grey, baseline.px_per_mm).metrics())
    # the baseline keeps the path in float32: round the new one alike, so that a run
    # identical to its baseline deviates by exactly 0
    new_tip = run.log.tip[:, :2].astype(np.float32).astype(float)
    measured["path_deviation_mm"] = path_deviation_mm(baseline.tip_mm, baseline.pen_down,
                                                      new_tip, run.log.drawing)
    reference = {**baseline.metrics, **COMPARED}
    checks = []
    for metric in dict.fromkeys([*reference, *measured]):
        rule = RULES.get(metric, Rule(REPORT, 0.0, ""))
        tolerance = baseline.tolerances.get(metric, rule.tolerance)
        checks.append(check_metric(metric, reference.get(metric), measured.get(metric), rule,
                                   tolerance, set_point=run.scenario.controller.force_n))
    return Comparison(name, status=run.status, reason=run.reason, checks=tuple(checks),
                      new_grey=new_grey, **common)


def regress(scenario: Scenario, folder: str | Path, name: str = "") -> Comparison:
    """Run ``scenario`` and compare it with the baseline in ``folder``."""
    from inkarm.jobs.run import run as run_scenario

    baseline = read_baseline(folder, known_metrics=tuple(RULES))
    return compare(run_scenario(scenario), baseline, name or Path(folder).name)


def find_scenarios(paths: Iterable[str | Path], baselines: str | Path | None = None,
                   update: bool = False) -> list[tuple[Path, Path]]:
    """The (scenario file, baseline folder) pairs to check. A file is taken as it is (without
    ``update`` its baseline must exist); a folder gives its ``*.toml`` files that have a
    baseline, or all of them with ``update``. Errors name the path."""
    pairs: list[tuple[Path, Path]] = []
    for given in paths:
        path = Path(given)
        if path.is_file():
            folder = baseline_dir(path, baselines)
            if not update and not (folder / MARKER).is_file():
                raise InputError(f"{path} has no baseline in {folder}; make one with "
                                 f"inkarm regress {path} --update", key="SCENARIOS",
                                 value=str(path))
            pairs.append((path, folder))
        elif path.is_dir():
            found = [(p, baseline_dir(p, baselines)) for p in sorted(path.glob("*.toml"))]
            found = [(p, f) for p, f in found if update or (f / MARKER).is_file()]
            if not found:
                what = "no scenario (*.toml)" if update else \
                    f"no scenario with a baseline in {Path(baselines or path / BASELINES_DIR)}"
                raise InputError(f"{path}: {what}", key="SCENARIOS", value=str(path))
            pairs.extend(found)
        else:
            raise InputError(f"{path}: no such scenario file or folder", key="SCENARIOS",
                             value=str(path))
    return list(dict.fromkeys(pairs))
