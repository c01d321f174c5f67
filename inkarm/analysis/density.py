"""Target density against curvature, and the target-based power law (seed 001, sec. 5).

DPPLA places its targets densely where the trajectory bends. Seed 001 measures this with

* the target density D_s(t_i) = 1 / ||Tg_i - Tg_{i-1}||, in [1/mm], the inverse length of
  segment i, correlated (Pearson, "linear regression", Table 1: 0.84-0.90 at compression
  65-85 %) with the curvature along the trajectory;
* the target-based velocity V_T(t_i) = ||Tg_i - Tg_{i-1}|| / (t_i - t_{i-1}) in [mm/s],
  which follows a power law V_T = K (1 / D_s)^gamma with gamma about 1.2 on an ellipse.
  (The paper prints the exponent as 2 in the equation but reports gamma = 1.2 in the text;
  the fit here estimates gamma.) Gamma reflects the trace's timing: on a 120 x 40 mm ellipse
  it is about 0.75 with the speed of the 1/3 power law, v ~ r^(1/3) (r the radius of
  curvature), and about 1.2 with v ~ r^0.6 (tests/analysis/test_gamma_timing.py).

Curvature, precisely: the paper does not say how it estimates curvature. Here the curvature
of segment i is its *mean curvature over arc length*, the total turning of the sampled
polyline within the segment divided by the segment's arc length,

    kappa_i = (theta_{n_{i-1}} / 2 + sum_{n_{i-1} < n < n_i} theta_n + theta_{n_i} / 2) / L_i,

theta_n being the exterior (turning) angle of the polyline at sample n, in [rad] (a turning
angle at a target is shared half and half between its two segments). It needs no
derivatives and no smoothing window: a cusp or a corner, where the pointwise curvature
|x' x x''| / |x'|^3 is unbounded, contributes its finite turning angle (pi for a full
reversal), so cusps do not make the estimate spiky. Samples that repeat (the pen at rest)
are skipped when taking turning angles, so a stop at a cusp still counts its turn. Density
and curvature are compared segment by segment, so both have the same resolution.

For figures (:mod:`inkarm.plots.density`), the pointwise curvature
theta_n / ((|x_{n+1} - x_n| + |x_n - x_{n-1}|) / 2) and the density (constant over each
segment) are plotted against time, like seed 001's Fig. 4.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.analysis.dppla import DPPLAResult, dppla, segments_for_compression
from inkarm.analysis.dppla_budget import dppla_cost
from inkarm.core.budget import DPPLA_STEPS, require, require_memory
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError

_EPS_MM = 1e-9


def turning_angles(pos) -> np.ndarray:
    """Exterior angle of the polyline at each sample in [rad], (w,): 0 at both ends.

    Zero-length steps are skipped: the turn between the steps either side of a run of
    repeated samples is assigned to the first sample of the run.
    """
    pos = np.asarray(pos, dtype=float)
    steps = np.diff(pos, axis=0)
    lengths = np.linalg.norm(steps, axis=1)
    moving = np.flatnonzero(lengths > _EPS_MM)
    theta = np.zeros(len(pos))
    if moving.size < 2:
        return theta
    u, v = steps[moving[:-1]], steps[moving[1:]]
    nu, nv = lengths[moving[:-1], None], lengths[moving[1:], None]
    # Kahan's angle between vectors: accurate at every angle, where arccos of the normalised
    # dot product (or the Lagrange identity for the cross) loses half the digits near 0.
    a, b = u * nv, v * nu
    angle = 2.0 * np.arctan2(np.linalg.norm(a - b, axis=1), np.linalg.norm(a + b, axis=1))
    # The vertex where step moving[m] ends is sample moving[m] + 1.
    theta[moving[:-1] + 1] = angle
    return theta


def pointwise_curvature(pos) -> np.ndarray:
    """Discrete curvature theta_n / (local arc length) in [1/mm], (w,), for plotting."""
    pos = np.asarray(pos, dtype=float)
    lengths = np.linalg.norm(np.diff(pos, axis=0), axis=1)
    local = 0.5 * (np.concatenate([[0.0], lengths]) + np.concatenate([lengths, [0.0]]))
    return turning_angles(pos) / np.maximum(local, _EPS_MM)


def segment_curvature(pos, breakpoints) -> np.ndarray:
    """Mean curvature over arc length of each segment in [1/mm], (k,) (module docstring)."""
    pos = np.asarray(pos, dtype=float)
    bp = np.asarray(breakpoints)
    theta = turning_angles(pos)
    cum_theta = np.concatenate([[0.0], np.cumsum(theta)])
    cum_len = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pos, axis=0), axis=1))])
    start, end = bp[:-1], bp[1:]
    turning = cum_theta[end + 1] - cum_theta[start] - 0.5 * (theta[start] + theta[end])
    length = cum_len[end] - cum_len[start]
    return turning / np.maximum(length, _EPS_MM)


def target_density(pos, breakpoints) -> np.ndarray:
    """D_s(t_i) = 1 / ||Tg_i - Tg_{i-1}|| in [1/mm], (k,) (seed 001, sec. 5)."""
    targets = np.asarray(pos, dtype=float)[np.asarray(breakpoints)]
    return 1.0 / np.maximum(np.linalg.norm(np.diff(targets, axis=0), axis=1), _EPS_MM)


def target_velocity(traj: Trajectory, breakpoints) -> np.ndarray:
    """V_T(t_i) = ||Tg_i - Tg_{i-1}|| / (t_i - t_{i-1}) in [mm/s], (k,) (seed 001, sec. 5)."""
    bp = np.asarray(breakpoints)
    with np.errstate(over="ignore", divide="ignore"):
        velocity = 1.0 / target_density(traj.pos, bp) / np.diff(traj.t[bp])
    if not np.all(np.isfinite(velocity)):
        i = int(np.argmax(~np.isfinite(velocity)))
        raise InputError(
            f"target velocity: segment {i} ({traj.t[bp[i]]:g} s to {traj.t[bp[i + 1]]:g} s) "
            "is too short in time for a finite speed; expected sample times at least a few "
            "ulps apart", value=float(velocity[i]),
        )
    return velocity


@dataclass(frozen=True)
class PowerLaw:
    """Least-squares fit of log V_T = log K + gamma log(1 / D_s).

    Attributes:
        gamma: Exponent.
        gain: K in [mm/s] / [mm]^gamma.
        r2: Coefficient of determination of the log-log fit.
    """

    gamma: float
    gain: float
    r2: float


def fit_power_law(inverse_density, velocity) -> PowerLaw:
    """Fit V_T = K (1/D_s)^gamma on log-log axes (seed 001, sec. 5, Fig. 5)."""
    lx, ly = np.log(np.asarray(inverse_density)), np.log(np.asarray(velocity))
    if lx.size < 3 or np.ptp(lx) == 0:
        raise InputError(
            f"power law: needs at least 3 segments of different lengths, got {lx.size}"
        )
    gamma, log_k = np.polyfit(lx, ly, 1)
    resid = ly - (gamma * lx + log_k)
    r2 = 1.0 - float(np.sum(resid**2) / np.sum((ly - ly.mean()) ** 2))
    return PowerLaw(float(gamma), float(np.exp(log_k)), r2)


@dataclass(frozen=True)
class Analysis:
    """Seed 001 sec. 5 measures of one trajectory at one compression rate.

    Attributes:
        traj: The analysed trajectory.
        result: Its DPPLA.
        compression: The compression rate rho.
        density: (k,) target density D_s in [1/mm].
        curvature: (k,) segment mean curvature in [1/mm].
        correlation: Pearson correlation of density and curvature (Table 1); NaN when either
            is constant.
        velocity: (k,) target-based velocity V_T in [mm/s].
        power_law: Fit of V_T against 1 / D_s; None when all segments are equally long.
    """

    traj: Trajectory
    result: DPPLAResult
    compression: float
    density: np.ndarray
    curvature: np.ndarray
    correlation: float
    velocity: np.ndarray
    power_law: PowerLaw | None


def analyse(traj: Trajectory, compression: float = 0.75, banded: bool = False) -> Analysis:
    """DPPLA of ``traj`` positions at compression rate ``compression``, then density against
    curvature and the target-based power law (seed 001, sec. 5).

    The DPPLA uses the paper's interpolation error with the sample times as chord parameter
    (the paper's frame index n when the trace is sampled uniformly); exact unless ``banded``.
    """
    k = segments_for_compression(compression, traj.n, traj.dim)
    if k < 3:
        raise InputError(
            f"analysis: compression {compression} leaves {k} segments on {traj.n} samples; "
            "need at least 3 (lower the compression or sample more densely)"
        )
    result = dppla(traj.pos, k, banded=banded, tau=traj.t)
    density = target_density(traj.pos, result.breakpoints)
    curvature = segment_curvature(traj.pos, result.breakpoints)
    velocity = target_velocity(traj, result.breakpoints)
    # A straight trace has no curvature to speak of: its "variation" is rounding noise.
    extent = float(np.max(np.ptp(traj.pos, axis=0)))
    if np.ptp(density) <= 1e-9 * np.max(density) or np.max(np.abs(curvature)) * extent <= 1e-9:
        correlation = float("nan")
    else:
        correlation = float(np.corrcoef(density, curvature)[0, 1])
    law = fit_power_law(1.0 / density, velocity) if np.ptp(density) > 0 else None
    return Analysis(traj, result, compression, density, curvature, correlation, velocity, law)


@dataclass(frozen=True)
class DrawingAnalysis:
    """Per-stroke analyses of a drawing, and the measures pooled over all their segments.

    Attributes:
        strokes: The analyses of the strokes long enough (at least 3 segments).
        skipped: Indices of the strokes too short to analyse.
        correlation: Pearson correlation of density and curvature over all segments.
        power_law: Power-law fit over all segments.
    """

    strokes: tuple[Analysis, ...]
    skipped: tuple[int, ...]
    correlation: float
    power_law: PowerLaw


def analyse_drawing(
    drawing: Drawing, compression: float = 0.75, banded: bool = False
) -> DrawingAnalysis:
    """:func:`analyse` every stroke with enough samples and pool their segments.

    The DPPLA of every stroke is estimated first: a stroke whose tables exceed
    ``INKARM_MAX_MEMORY_MB``, or strokes whose DP steps together exceed
    ``INKARM_MAX_DPPLA_STEPS``, are refused (:class:`~inkarm.core.budget.BudgetError`) before
    any is computed.
    """
    todo, skipped, steps = [], [], 0.0
    for i, traj in enumerate(drawing.strokes):
        k = segments_for_compression(compression, traj.n, traj.dim)
        if k < 3:
            skipped.append(i)
            continue
        stroke_steps, n_bytes, what = dppla_cost(k, traj.n, traj.dim, banded=banded)
        require_memory(n_bytes, f"stroke {i}: {what}")
        require(stroke_steps, DPPLA_STEPS, f"stroke {i}: {what}")
        steps += stroke_steps
        todo.append(i)
    if len(todo) > 1:
        samples = sum(drawing.strokes[i].n for i in todo)
        kind = "banded" if banded else "exact"
        require(steps, DPPLA_STEPS, f"{kind} DPPLA of {len(todo)} strokes, {samples} samples")
    analyses = [analyse(drawing.strokes[i], compression, banded) for i in todo]
    if not analyses:
        raise InputError(
            f"analysis: no stroke has enough samples for 3 segments at compression {compression}"
        )
    density = np.concatenate([a.density for a in analyses])
    curvature = np.concatenate([a.curvature for a in analyses])
    velocity = np.concatenate([a.velocity for a in analyses])
    correlation = float(np.corrcoef(density, curvature)[0, 1])
    law = fit_power_law(1.0 / density, velocity)
    return DrawingAnalysis(tuple(analyses), tuple(skipped), correlation, law)
