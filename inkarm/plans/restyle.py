"""Trace to stylised drawing: DPPLA targets (seed 001) drive a Gaussian-target LQT (seed 000).

Each stroke of a trace is reduced to the DPPLA targets at a compression rate (seed 001,
sec. 3); every target becomes a Gaussian whose covariance follows the local geometry, and the
LQT (seed 000, eq. 13) re-draws the stroke through them. The result keeps the trace's shape
where it bends (targets are dense there) and replaces its fine detail and timing by the
smooth, isochronous movement of the LQT.

Geometric covariances: at target i, with u_i the unit direction of the chord from target
i-1 to target i+1 (the adjacent segment at the ends) and L_i the mean length of the segments
meeting at target i,

    Sigma_i = (across L_i)^2 I + ((along L_i)^2 - (across L_i)^2) u_i u_i^T,

elongated along the path: the movement may slide along the trace but must pass close across
it. ``style="semi-tied"`` uses seed 000's eq. 22 covariances Sigma_i = H h I H^T instead,
with one oblique basis H = along L (I + shear e_x e_y^T) for the whole stroke (L the mean
segment length, h = 1): every target shares the same slanted ellipse, a uniform "hand".
``style="handstyle"`` (:meth:`RestyleConfig.from_handstyle`) takes the covariances of one of
inkarm's handstyles (:mod:`inkarm.plans.handstyles`: Sigma_i = h_i H H^T, h_i ~ N(h, rho),
seed 000 eq. 22) with its order and d. The LQT's optimum is linear in the means, so the
shape of a restyled stroke depends on sqrt(h) / d, H, the order and rho, not on the size of
the drawing nor on the time per target (r = 1 / (omega^n d)^2, omega = 2 pi / segment_time):
a handstyle made for letters restyles a 300 mm drawing the same way.

A stroke too short in time for the LQT's chain (fewer than order + 1 steps) has its targets
held longer, (order + 1) / targets steps each, rounded up. Strokes of fewer than 3 samples
cannot hold two DPPLA targets and are dropped; the restyled
drawing's ``meta["restyle_dropped"]`` lists their indices in the input (absent when none).
Layers: when the input carries ``meta["layers"]`` (one layer id per stroke, the convention of
:mod:`inkarm.io.trace`), the restyled drawing carries the ids of the strokes it kept, in the
same order.

Budgets (:mod:`inkarm.core.budget`): before any stroke is restyled, every stroke's DPPLA is
estimated (:func:`inkarm.analysis.dppla_budget.check_budget`) and the LQT's time steps, targets x
max(1, segment_time / dt), are summed and checked against ``INKARM_MAX_STEPS``; the memory
of the longest stroke's solve (the strokes are solved one after the other), about
:data:`LQT_BYTES_PER_STEP` x order x D bytes a step, against ``INKARM_MAX_MEMORY_MB``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from inkarm.analysis.dppla import (
    EXACT_BUDGET,
    DPPLAResult,
    dppla,
    segments_for_compression,
)
from inkarm.analysis.dppla_budget import check_budget
from inkarm.core.budget import STEPS, require, require_memory
from inkarm.core.plan import MotorPlan, StrokePlan
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.errors import InputError
from inkarm.plans.handstyles import PULSE_DT, TIMINGS, Handstyle

STYLES = ("geometric", "semi-tied")
"""Covariances a restyle chooses by name (``"handstyle"`` comes with :attr:`RestyleConfig.hand`)."""
MIN_SAMPLES = 3
"""Fewest samples of a restyled stroke (two DPPLA targets and a point between)."""
MIN_TARGETS = 4
"""Fewest DPPLA targets of a restyled stroke (fewer only when it has fewer samples). With two,
a closed outline (an SVG circle or rectangle: its ends coincide) collapses to a dot, and the
LQT, which starts at rest on the first, falls short of the second (a straight 10 mm line at
compression 0.8: the cursive pen ends at 4.0 mm, the italic at 1.8 mm); with three it
overshoots (10.8 mm); from four on every preset ends within 0.6 mm of the end."""
D_RANGE = (1e-3, 1e4)
"""Accepted LQT maximum displacements d in [mm]."""
DT_RANGE = (1e-4, 1.0)
"""Accepted LQT time steps in [s]."""
MAX_SEGMENT_TIME = 1e4
"""Longest time per target in [s]."""
MAX_FRACTION = 100.0
"""Largest ``along`` and ``across`` (standard deviations per local segment length)."""
LQT_BYTES_PER_STEP = 500
"""Memory of the LQT per time step, per state dimension (order x D), in bytes (measured: 440
for order 4, 410 for order 7, in 2-D)."""


@dataclass(frozen=True)
class RestyleConfig:
    """How a trace is restyled.

    Attributes:
        compression: DPPLA compression rate rho in (0, 1) (seed 001, sec. 3).
        order: Order n of the LQT's integrator chain (seed 000).
        d: LQT maximum displacement in [mm] (seed 000, eq. 9-10).
        dt: LQT time step in [s].
        segment_time: Time per target in [s]; default the stroke's duration divided by its
            number of targets, so the restyled stroke lasts as long as the trace.
        style: "geometric" or "semi-tied" covariances (module docstring).
        along: Standard deviation along the path, as a fraction of the local segment length.
        across: Standard deviation across the path, as a fraction of the local segment length.
        min_std: Lower bound on both standard deviations in [mm].
        shear: Shear of the semi-tied basis H (seed 000, eq. 22), for style "semi-tied".
        banded: Use the banded DPPLA (O(w^2 / k)) or the exact one (O(k w^2)); None picks the
            exact one where k w^2 / 2 <= ``dppla.EXACT_BUDGET``.
        seed: Random seed of the semi-tied magnitudes h_i (and of a handstyle's, rho > 0).
        hand: The handstyle whose covariances style "handstyle" uses (set both with
            :meth:`from_handstyle`); None otherwise.
        timing: "isochronous" (DPPLA targets at ``compression``, each held ``segment_time``)
            or "pulses" (key-points at the trace's speed minima and peaks and at its ends, at
            its own times, positions, velocities and accelerations: :mod:`inkarm.plans.pulses`;
            ``compression`` and ``segment_time`` are then unused).
    """

    compression: float = 0.95
    order: int = 4
    d: float = 5.0
    dt: float = 0.01
    segment_time: float | None = None
    style: str = "geometric"
    along: float = 0.4
    across: float = 0.08
    min_std: float = 0.05
    shear: float = 0.5
    banded: bool | None = None
    seed: int | None = 0
    hand: Handstyle | None = None
    timing: str = "isochronous"

    @classmethod
    def from_handstyle(cls, hand: Handstyle, **overrides) -> RestyleConfig:
        """The restyle of handstyle ``hand``: its covariances, order, d and timing (module
        docstring; timing "pulses" at :data:`inkarm.plans.handstyles.PULSE_DT` unless ``dt`` is given);
        ``overrides`` set any other field (compression, dt, segment_time, seed, ...)."""
        settings = {"timing": hand.timing, **overrides}
        if settings["timing"] == "pulses" and "dt" not in overrides:
            settings["dt"] = PULSE_DT
        return replace(cls(), style="handstyle", hand=hand, order=hand.order, d=hand.d,
                       **settings)

    def __post_init__(self) -> None:
        from inkarm.models.lqt.config import MAX_ORDER

        if not (isinstance(self.compression, (int, float)) and 0 < self.compression < 1):
            self._fail("compression", f"must lie in (0, 1), got {self.compression!r}")
        if self.timing not in TIMINGS:
            self._fail("timing", f"expected one of {TIMINGS}, got {self.timing!r}")
        if self.style == "handstyle" or self.hand is not None:
            self._check_hand()
        elif self.style not in STYLES:
            self._fail("style", f"expected one of {STYLES}, got {self.style!r}")
        if (isinstance(self.order, bool) or not isinstance(self.order, (int, np.integer))
                or not 1 <= self.order <= MAX_ORDER):
            self._fail("order", f"expected an integer 1..{MAX_ORDER}, got {self.order!r}")
        if self.timing == "pulses" and self.order < 2:
            self._fail("order", f"timing 'pulses' constrains velocities at its key-points: "
                       f"expected an order of 2 or more, got {self.order}")
        for name, (low, high), unit in (("d", D_RANGE, "mm"), ("dt", DT_RANGE, "s")):
            value = getattr(self, name)
            if not (_number(value) and low <= value <= high):
                self._fail(name, f"must lie in [{low:g}, {high:g}] {unit}, got {value!r}")
        for name, high in (("along", MAX_FRACTION), ("across", MAX_FRACTION),
                           ("min_std", D_RANGE[1])):
            value = getattr(self, name)
            if not (_number(value) and 0 < value <= high):
                self._fail(name, f"must be positive and at most {high:g}, got {value!r}")
        if not (_number(self.shear) and abs(self.shear) <= MAX_FRACTION):
            self._fail("shear", f"expected a number in [-{MAX_FRACTION:g}, {MAX_FRACTION:g}], "
                       f"got {self.shear!r}")
        if self.segment_time is not None and not (
            _number(self.segment_time) and 0 < self.segment_time <= MAX_SEGMENT_TIME
        ):
            self._fail("segment_time", f"must be positive seconds, at most {MAX_SEGMENT_TIME:g}, "
                       f"got {self.segment_time!r}")

    def _check_hand(self) -> None:
        if not isinstance(self.hand, Handstyle):
            self._fail("hand", "style 'handstyle' needs hand, a Handstyle (use "
                       f"RestyleConfig.from_handstyle), got {self.hand!r}")
        if self.style != "handstyle":
            self._fail("style", f"a hand is given: expected style 'handstyle', got {self.style!r}")

    def _fail(self, key: str, message: str):
        raise InputError(message, key=key, value=getattr(self, key))


def _number(value) -> bool:
    """A finite real number (not a bool)."""
    return (isinstance(value, (int, float, np.integer, np.floating))
            and not isinstance(value, bool) and bool(np.isfinite(value)))


@dataclass(frozen=True)
class Restyled:
    """A restyled drawing with what produced it: per stroke, the DPPLA and the motor plan."""

    drawing: Drawing
    plan: MotorPlan
    targets: tuple[DPPLAResult, ...]


def geometric_covariances(targets, along: float, across: float, min_std: float) -> np.ndarray:
    """(m, D, D) covariances in [mm^2] elongated along the local chord (module docstring)."""
    targets = np.asarray(targets, dtype=float)
    m, dim = targets.shape
    seg = np.linalg.norm(np.diff(targets, axis=0), axis=1)
    local = 0.5 * (np.concatenate([seg[:1], seg]) + np.concatenate([seg, seg[-1:]]))
    chord = targets[np.minimum(np.arange(m) + 1, m - 1)] - targets[np.maximum(np.arange(m) - 1, 0)]
    norm = np.linalg.norm(chord, axis=1, keepdims=True)
    u = np.divide(chord, norm, out=np.zeros_like(chord), where=norm > 0)
    s_along = np.maximum(along * local, min_std)
    s_across = np.maximum(across * local, min_std)
    eye = np.eye(dim)[None]
    return (s_across**2)[:, None, None] * eye + (s_along**2 - s_across**2)[:, None, None] * (
        u[:, :, None] * u[:, None, :]
    )


def stroke_targets(traj: Trajectory, compression: float, banded: bool | None = None) -> DPPLAResult:
    """DPPLA of a stroke's positions at a compression rate (time as the chord parameter), at
    least :data:`MIN_TARGETS` targets."""
    k = stroke_segments(traj, compression)
    return dppla(traj.pos, k, banded=_banded(banded, k, traj.n), tau=traj.t, verify=False)


def stroke_segments(traj: Trajectory, compression: float) -> int:
    """DPPLA segments of ``traj`` at ``compression`` (seed 001, sec. 3), at least
    :data:`MIN_TARGETS` - 1 where the stroke has the samples."""
    k = segments_for_compression(compression, traj.n, traj.dim)
    return max(k, min(MIN_TARGETS, traj.n) - 1)


def stroke_plan(traj: Trajectory, result: DPPLAResult, cfg: RestyleConfig,
                rng: np.random.Generator | None = None) -> StrokePlan:
    """Gaussian targets at the DPPLA break points of ``traj``; ``rng`` draws a handstyle's
    magnitudes h_i (rho > 0; default a generator seeded with ``cfg.seed``)."""
    means = traj.pos[result.breakpoints]
    covs = _covariances(traj, means, cfg, rng)
    if cfg.timing == "pulses":
        from inkarm.plans.pulses import pulse_plan

        return pulse_plan(traj, result.breakpoints, covs, cfg.dt)
    if not (cfg.segment_time or traj.duration / len(means)) > 0:
        raise InputError(f"restyle: stroke of duration {traj.duration} s; give segment_time")
    per = _steps_per_target(traj, len(means), cfg)
    return StrokePlan.from_arrays(means, covs, segment_time=per * cfg.dt)


def _covariances(traj: Trajectory, means: np.ndarray, cfg: RestyleConfig,
                 rng: np.random.Generator | None) -> np.ndarray:
    """(m, D, D) covariances of the targets ``means`` [mm^2] (module docstring)."""
    if cfg.hand is not None:
        if traj.dim != 2:
            raise InputError(f"restyle: a handstyle's covariances are 2 x 2; the stroke has "
                             f"{traj.dim} coordinates", key="style", value=cfg.hand.name)
        return cfg.hand.covariances(len(means), rng or np.random.default_rng(cfg.seed))
    if cfg.style == "geometric":
        return geometric_covariances(means, cfg.along, cfg.across, cfg.min_std)
    from inkarm.models.lqt import semi_tied_covariances

    scale = max(float(np.mean(np.linalg.norm(np.diff(means, axis=0), axis=1))), cfg.min_std)
    basis = cfg.along * scale * np.eye(traj.dim)
    if traj.dim > 1:
        basis[0, 1] = cfg.along * scale * cfg.shear
    return semi_tied_covariances(len(means), basis, 1.0, seed=cfg.seed)


def pulse_targets(traj: Trajectory) -> DPPLAResult:
    """The targets of timing "pulses" (:func:`inkarm.plans.pulses.pulse_breakpoints`) as a
    :class:`DPPLAResult`: its cost and rms those of the polyline through them, linear in time
    between them (DPPLA's chord parameter); not an optimum (``optimal_in_band`` None)."""
    from inkarm.plans.pulses import pulse_breakpoints

    cuts = pulse_breakpoints(traj)
    chord = np.column_stack([np.interp(traj.t, traj.t[cuts], traj.pos[cuts, k])
                             for k in range(traj.dim)])
    cost = float(np.sum((traj.pos - chord) ** 2))
    return DPPLAResult(cuts, cost, float(np.sqrt(cost / traj.n)), optimal_in_band=None)


def stroke_lqt_config(traj: Trajectory, targets: int, cfg: RestyleConfig):
    """The LQT settings of one stroke: the restyle's, with timing "pulses" the control weight
    of its targets' mean hold (:func:`inkarm.plans.pulses.control_weight`)."""
    from inkarm.models.lqt import LQTConfig

    if cfg.timing != "pulses":
        return LQTConfig(order=cfg.order, dt=cfg.dt, d=cfg.d)
    from inkarm.plans.pulses import control_weight

    return LQTConfig(order=cfg.order, dt=cfg.dt, d=None,
                     r=control_weight(cfg.order, cfg.d, traj.duration, targets))


def stroke_references(plan: StrokePlan, cfg: RestyleConfig) -> tuple:
    """The extra LQT cost terms of one stroke's ``plan``: with timing "pulses" the recording's
    accelerations at the key-points (:func:`inkarm.plans.pulses.pulse_references`), else none."""
    if cfg.timing != "pulses":
        return ()
    from inkarm.plans.pulses import pulse_references

    return pulse_references(plan, cfg.order)


def _steps_per_target(traj: Trajectory, targets: int, cfg: RestyleConfig) -> int:
    """LQT steps each of ``targets`` targets is held: segment_time / dt rounded (the LQT holds
    a target a whole number of steps), at least 1, and at least (order + 1) / targets rounded
    up, the fewest steps an order-n chain needs (a short stroke is slowed rather than refused
    by :func:`inkarm.models.lqt.config.time_grid`)."""
    segment_time = cfg.segment_time or traj.duration / targets
    return max(1, round(segment_time / cfg.dt), -(-(cfg.order + 1) // targets))


def _lqt_steps(traj: Trajectory, targets: int, cfg: RestyleConfig) -> float:
    """Time steps of the LQT that re-draws ``traj`` through ``targets`` DPPLA targets, or with
    timing "pulses" at most the trace's duration in steps plus one a sample (key-points closer
    than a step apart are moved a step on)."""
    if cfg.timing == "pulses":
        return float(round(traj.duration / cfg.dt) + traj.n)
    return float(targets * _steps_per_target(traj, targets, cfg))


def check_restyle(drawing: Drawing, cfg: RestyleConfig = RestyleConfig()) -> None:
    """Refuse a restyle over the budgets (module docstring) before any work."""
    steps, longest, dim = 0.0, 0.0, drawing.dim
    for i, traj in enumerate(drawing.strokes):
        if traj.n < MIN_SAMPLES:
            continue
        k = 0  # (pulses take no DPPLA)
        if cfg.timing != "pulses":
            k = stroke_segments(traj, cfg.compression)
            try:
                check_budget(k, traj.n, traj.dim, banded=_banded(cfg.banded, k, traj.n))
            except InputError as e:
                raise e.within(key=f"stroke {i}") from None
        stroke_steps = _lqt_steps(traj, k + 1, cfg)
        steps += stroke_steps
        longest = max(longest, stroke_steps)
    key = "dt" if cfg.segment_time is None else "segment_time"
    what = (f"LQT of the restyled drawing ({len(drawing.strokes)} strokes, order {cfg.order}, "
            f"dt = {cfg.dt:g} s)")
    require(steps, STEPS, what, key=key, value=getattr(cfg, key))
    require_memory(longest * LQT_BYTES_PER_STEP * cfg.order * dim, what, key=key,
                   value=getattr(cfg, key))


def _banded(banded: bool | None, k: int, w: int) -> bool:
    return k * w**2 / 2 > EXACT_BUDGET if banded is None else banded


def restyle(drawing: Drawing, cfg: RestyleConfig = RestyleConfig()) -> Restyled:
    """Restyle every stroke of ``drawing`` (strokes too short for two targets are dropped:
    fewer than :data:`MIN_SAMPLES` samples, listed in ``meta["restyle_dropped"]``), layers
    kept (module docstring); the whole job is checked against the budgets first."""
    from inkarm.models.lqt import solve

    layers = drawing.layer_ids() if "layers" in drawing.meta else None
    check_restyle(drawing, cfg)
    rng = np.random.default_rng(cfg.seed)
    strokes, plans, results, kept = [], [], [], []
    for i, traj in enumerate(drawing.strokes):
        if traj.n < MIN_SAMPLES:
            continue
        result = (pulse_targets(traj) if cfg.timing == "pulses" else
                  stroke_targets(traj, cfg.compression, cfg.banded))
        plan = stroke_plan(traj, result, cfg, rng)
        strokes.append(solve(plan, stroke_lqt_config(traj, len(result.breakpoints), cfg),
                             stroke_references(plan, cfg)))
        plans.append(plan)
        results.append(result)
        kept.append(i)
    if not strokes:
        raise InputError(f"restyle: the trace has no stroke with at least {MIN_SAMPLES} samples")
    meta: dict = {}
    if layers is not None:
        meta["layers"] = layers[kept]
    if len(kept) < len(drawing.strokes):
        meta["restyle_dropped"] = tuple(sorted(set(range(len(drawing.strokes))) - set(kept)))
    out = Drawing(strokes, page_size=drawing.page_size, meta=meta).sequential()
    return Restyled(out, MotorPlan(tuple(plans)), tuple(results))

