"""Settings and inputs of the LQT (seed 000): :class:`LQTConfig`, extra tracking terms
(:class:`Reference`) and the checks shared by the banded solver and the dense oracle.

Units: [mm] and [s]; ``d`` in [mm], ``r`` in [(mm/s^n)^-2].

Valid ranges (refused outside them, naming the key, the range and the value; the plan-file
reader :mod:`inkarm.io.plansections` applies the same ones):

==================  =======================  ==========================================
quantity            range                    why
==================  =======================  ==========================================
coordinates         abs(x) <= 1e6 mm         a kilometre; P mu stays far from overflow
std                 1e-6 .. 1e6 mm           variances (eigenvalues) 1e-12 .. 1e12 mm^2
covariance          condition number <= 1e12 nearly singular beyond (its inverse is used)
dt                  1e-4 .. 1 s
d                   1e-6 .. 1e6 mm           see below
r                   1e-40 .. 1e40            control^2 = r / dt^(2n) <= 1e96
segment_time        dt .. 3600 s
velocities          abs(v) <= 1e10 mm/s      1e6 mm in dt = 1e-4 s
==================  =======================  ==========================================

With order n <= 7, dt in [1e-4, 1] s and segment_time in [dt, 3600] s, omega = 2 pi /
segment_time lies in [1.7e-3, 6.3e4] rad/s, so d in [1e-6, 1e6] mm gives r = 1 / (omega^n d)^2
in [6.7e-80, 4.1e50] and control^2 = r / dt^(2n) (the entries of the normal matrix) at most
4.1e106: no overflow or underflow to 0 in float64 anywhere in the solvers.

Budgets (:mod:`inkarm.core.budget`): the number of time steps N of a stroke is checked against
INKARM_MAX_STEPS by :func:`time_grid`, before anything is allocated; the memory of the solve,
the samples and the covariance against INKARM_MAX_MEMORY_MB, and the time of the O((N D)^3)
operations (eigen draws, covariance, dense oracle) against INKARM_MAX_COMPUTE_S
(:mod:`.cost`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.core import budget
from inkarm.core.plan import StrokePlan
from inkarm.core.ranges import expected_in, outside
from inkarm.errors import InputError, PlanError

MAX_ORDER = 7
MAX_COORDINATE = 1e6  # |x| of a mean or point [mm]
STD_RANGE = (1e-6, 1e6)  # a standard deviation [mm]
VARIANCE_RANGE = (1e-12, 1e12)  # an eigenvalue of a covariance [mm^2]: STD_RANGE squared
MAX_CONDITION = 1e12  # largest / smallest variance of one covariance
DT_RANGE = (1e-4, 1.0)  # [s]
D_RANGE = (1e-6, 1e6)  # [mm]
R_RANGE = (1e-40, 1e40)  # [(mm/s^n)^-2]
MAX_TIME = 3600.0  # segment_time, durations, pauses [s]
MAX_VELOCITY = 1e10  # [mm/s]
SOLVERS = ("auto", "cholesky", "augmented", "batch")
DISCRETISATIONS = ("euler", "zoh")


def coordinate_error(values) -> str | None:
    """The message for coordinates [mm] beyond +-:data:`MAX_COORDINATE`, else None."""
    bad = outside(values, -MAX_COORDINATE, MAX_COORDINATE)
    if bad is None:
        return None
    return f"{expected_in(-MAX_COORDINATE, MAX_COORDINATE, 'mm', 'coordinates')}, got {bad:g}"


def covariance_error(cov) -> str | None:
    """The message for a symmetric positive definite covariance (D, D) [mm^2] whose variances
    (eigenvalues) leave :data:`VARIANCE_RANGE` or whose condition number exceeds
    :data:`MAX_CONDITION`, else None."""
    return _covariance_errors(np.asarray(cov, dtype=float)[None])[1]


def _covariance_errors(covs: np.ndarray) -> tuple[int, str | None]:
    """(index, message) of the first of the covariances (m, D, D) out of range, else (-1, None)."""
    eig = np.linalg.eigvalsh(covs)  # ascending, per covariance
    low, high = VARIANCE_RANGE
    bad = ~((eig >= low) & (eig <= high))
    if bad.any():
        i, j = np.argwhere(bad)[0]
        return int(i), (f"{expected_in(low, high, 'mm^2', 'variances (eigenvalues)')} (std "
                        f"{STD_RANGE[0]:g} to {STD_RANGE[1]:g} mm), got {eig[i, j]:g}")
    ill = eig[:, -1] > MAX_CONDITION * eig[:, 0]
    if ill.any():
        i = int(np.argmax(ill))
        return i, (f"condition number {eig[i, -1] / eig[i, 0]:.3g} (variances {eig[i, 0]:g} to "
                   f"{eig[i, -1]:g} mm^2), more than {MAX_CONDITION:g}: nearly singular")
    return -1, None


def check_stroke_ranges(stroke: StrokePlan, means_only: bool = False) -> None:
    """Refuse means, covariances and velocities of ``stroke`` outside the valid ranges (see
    the module docstring); errors name ``targets[i].mean``, ``targets[i].cov``,
    ``velocities``. A stroke plan is immutable, so a stroke that passed is not checked again
    (realising a plan sizes each stroke before solving it). ``means_only``: the rest is known
    to pass (covariances equal to a checked stroke's, no velocities, :mod:`.structure`)."""
    if stroke.__dict__.get("_ranges_checked"):
        return
    means = stroke.means
    far = ~(np.abs(means) <= MAX_COORDINATE)
    if far.any():
        i = int(np.argwhere(far)[0, 0])
        raise PlanError(coordinate_error(means[i]), key=f"targets[{i}].mean", value=means[i])
    if means_only:
        object.__setattr__(stroke, "_ranges_checked", True)
        return
    i, message = _covariance_errors(stroke.covs)
    if message:
        raise PlanError(message, key=f"targets[{i}].cov", value=stroke.covs[i])
    if stroke.velocities is not None:
        vel = stroke.velocities[np.all(np.isfinite(stroke.velocities), axis=1)]
        bad = outside(vel, -MAX_VELOCITY, MAX_VELOCITY)
        if bad is not None:
            raise PlanError(f"{expected_in(-MAX_VELOCITY, MAX_VELOCITY, 'mm/s')}, got {bad:g}",
                            key="velocities", value=stroke.velocities)
        bad = outside(stroke.velocity_var, *VARIANCE_RANGE)
        if bad is not None:
            raise PlanError(f"{expected_in(*VARIANCE_RANGE, '(mm/s)^2', 'a number')}, got "
                            f"{bad:g}",
                            key="velocity_var", value=stroke.velocity_var)
    object.__setattr__(stroke, "_ranges_checked", True)


def positive_number(value) -> bool:
    """True for a finite number > 0 (anything float() accepts)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return False
    return bool(np.isfinite(v) and v > 0)


@dataclass(frozen=True)
class LQTConfig:
    """Settings of the LQT.

    Attributes:
        order: n, order of the integrator chain, 1..7 (eq. 3); 4 is the papers' usual choice.
        dt: Time step Delta_t in [s].
        d: Maximum displacement in [mm]: R = I / (omega^n d)^2 with omega = 2 pi / segment_time
            (seed 000 eq. 9). Exactly one of ``d`` and ``r`` is given.
        r: Raw control weight in [(mm/s^n)^-2] (GI sec. 3.2, R = r I).
        discretisation: ``"euler"`` (eq. 4, default) or ``"zoh"`` (zero-order hold). Both sample
            the continuous optimum at the same instants for stepwise Gaussian targets; Euler
            lags it by (n - 1) / 2 steps only near the rest ends of key-point plans (measured,
            see :mod:`inkarm.models.lqt`).
        end_at_rest: Zero derivatives at the last step (GI sec. 4.1), imposed exactly. A plan
            that prescribes a non-zero velocity at its last step (the last key-point of a
            Bezier mimic, GI sec. 4.3) overrides it: the end is then free, as with
            ``end_at_rest=False``, because a movement cannot both stop there and leave at that
            velocity (see :func:`rests_at_end`).
        solver: ``"auto"``, ``"cholesky"``, ``"augmented"`` or ``"batch"`` (see
            :mod:`inkarm.models.lqt`).
    """

    order: int = 4
    dt: float = 0.01
    d: float | None = 5.0
    r: float | None = None
    discretisation: str = "euler"
    end_at_rest: bool = True
    solver: str = "auto"

    def __post_init__(self) -> None:
        if isinstance(self.order, bool) or not isinstance(self.order, (int, np.integer)):
            raise InputError(
                f"expected an integer 1..{MAX_ORDER}, got {self.order!r}",
                key="order",
                value=self.order,
            )
        if not 1 <= self.order <= MAX_ORDER:
            raise InputError(
                f"expected 1..{MAX_ORDER}, got {self.order}", key="order", value=self.order
            )
        if not positive_number(self.dt):
            raise InputError(
                f"must be a positive number of seconds, got {self.dt}", key="dt", value=self.dt
            )
        if outside(self.dt, *DT_RANGE) is not None:
            raise InputError(f"{expected_in(*DT_RANGE, 's', 'a number')}, got {self.dt:g}",
                             key="dt", value=self.dt)
        if (self.d is None) == (self.r is None):
            raise InputError(
                f"give exactly one of d (max displacement in mm) and r (raw control weight), "
                f"got d={self.d}, r={self.r} (d defaults to 5.0: pass d=None with r)",
                key="d",
                value=self.d,
            )
        if self.d is not None and not positive_number(self.d):
            raise InputError(f"must be a positive number of mm, got {self.d}", key="d", value=self.d)
        if self.r is not None and not positive_number(self.r):
            raise InputError(f"must be a positive number, got {self.r}", key="r", value=self.r)
        for name, value, bounds, unit in (("d", self.d, D_RANGE, "mm"),
                                          ("r", self.r, R_RANGE, "(mm/s^n)^-2")):
            if value is not None and outside(value, *bounds) is not None:
                raise InputError(f"{expected_in(*bounds, unit, 'a number')}, got {float(value):g}",
                                 key=name, value=value)
        if self.discretisation not in DISCRETISATIONS:
            raise InputError(
                f"expected 'euler' or 'zoh', got {self.discretisation!r}",
                key="discretisation",
                value=self.discretisation,
                choices=DISCRETISATIONS,
            )
        if self.solver not in SOLVERS:
            raise InputError(
                f"expected one of {SOLVERS}, got {self.solver!r}",
                key="solver",
                value=self.solver,
                choices=SOLVERS,
            )
        object.__setattr__(self, "order", int(self.order))
        object.__setattr__(self, "dt", float(self.dt))

    def control_weight(self, segment_time: float) -> float:
        """r such that R = r I, in [(mm/s^n)^-2] (seed 000 eq. 9).

        r = 1 / (omega^n d)^2 with omega = 2 pi / segment_time [rad/s]. The paper prints
        omega = 2 pi T_s (MOCO eq. 9) and omega = 2 pi T / (m - 1) (GI eq. 10); both are
        dimensionally a typo for a frequency with the segment duration as period, which is what
        the authors' code computes.
        """
        if self.r is not None:
            return float(self.r)
        omega = 2.0 * np.pi / segment_time
        return 1.0 / (omega**self.order * self.d) ** 2


DEFAULT_CONFIG = LQTConfig()  # order 4, dt 0.01 s, d 5 mm, Euler, end at rest, auto solver


@dataclass(frozen=True)
class Reference:
    """An extra quadratic tracking term of the LQT cost (seed 000 eq. 18-19), on one derivative
    of the pen position.

    Not to be confused with the reference trajectory a controller follows (the control loop's
    set points): this is a term P_i of the *planning* cost,

        sum over ``steps`` t of (x^(k)_t - value_t)^T precision_t (x^(k)_t - value_t),

    added to the Gaussian-target tracking and the control cost. :func:`velocity_direction_reference`
    builds the velocity term of eq. 20-21.

    Attributes:
        derivative: k, 0 (position) .. order - 1 (only state entries can be observed).
        precision: (D, D) or (len(steps), D, D) symmetric positive semi-definite weights in
            [(mm/s^k)^-2].
        value: Reference (D,) or (len(steps), D) in [mm/s^k]; zero by default (eq. 20).
        steps: Time-step indices where the term applies; all steps by default.
    """

    derivative: int
    precision: np.ndarray
    value: np.ndarray | None = None
    steps: np.ndarray | None = None


def velocity_direction_reference(v, weight: float = 1.0) -> Reference:
    """The velocity reference of seed 000 eq. 20-21: zero velocity with precision weight v v^T.

    As printed, this costs weight (v . dx/dt)^2, i.e. it penalises the velocity component *along*
    ``v`` and so pushes the motion across it (the paper's Fig. 5b is ambiguous about which was
    meant); pass the perpendicular vector to favour motion along a direction. ``v`` is
    dimensionless, ``weight`` in [(mm/s)^-2].
    """
    v = np.asarray(v, dtype=float)
    if v.ndim != 1 or not np.all(np.isfinite(v)) or not np.any(v):
        raise InputError(
            f"expected a finite non-zero direction vector, got {v.tolist()}", key="v", value=v
        )
    if not positive_number(weight):
        raise InputError(f"must be a positive number, got {weight}", key="weight", value=weight)
    return Reference(derivative=1, precision=weight * np.outer(v, v))


@dataclass(frozen=True)
class CheckedReference:
    """A validated :class:`Reference` expanded to its steps: k, steps (T,), precision
    (T, D, D) in [(mm/s^k)^-2], value (T, D) in [mm/s^k] (absolute, not shifted)."""

    derivative: int
    steps: np.ndarray
    precision: np.ndarray
    value: np.ndarray


def check_reference(i: int, ref, order: int, dim: int, n_steps: int) -> CheckedReference:
    """Validate the i-th reference of a solve; errors name ``references[i].<field>``."""
    where = f"references[{i}]"
    if not isinstance(ref, Reference):
        raise InputError(
            f"expected a Reference, got {type(ref).__name__}", key=where, value=ref
        )
    k = ref.derivative
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k < order:
        raise InputError(
            f"expected an integer 0..{order - 1} (order - 1), got {k!r}",
            key=f"{where}.derivative",
            value=k,
        )
    steps = np.arange(n_steps) if ref.steps is None else np.asarray(ref.steps)
    if steps.ndim != 1 or steps.size == 0 or steps.dtype.kind not in "iu":
        raise InputError(
            "expected a non-empty 1-D array of integers", key=f"{where}.steps", value=ref.steps
        )
    if steps.min() < 0 or steps.max() >= n_steps:
        raise InputError(
            f"must lie in 0..{n_steps - 1}, got {steps.min()}..{steps.max()}",
            key=f"{where}.steps",
            value=ref.steps,
        )
    prec = _per_step(f"{where}.precision", ref.precision, (dim, dim), steps.size)
    scale = max(float(np.max(np.abs(prec))), 1e-300)
    if np.max(np.abs(prec - np.swapaxes(prec, 1, 2))) > 1e-9 * scale:
        raise InputError("not symmetric", key=f"{where}.precision", value=ref.precision)
    if np.min(np.linalg.eigvalsh(prec)) < -1e-9 * scale:
        raise InputError(
            "not positive semi-definite", key=f"{where}.precision", value=ref.precision
        )
    value = np.zeros(dim) if ref.value is None else ref.value
    value = _per_step(f"{where}.value", value, (dim,), steps.size)
    return CheckedReference(int(k), steps, np.array(prec, dtype=float), np.array(value, dtype=float))


def _per_step(key: str, value, shape: tuple[int, ...], count: int) -> np.ndarray:
    """``value`` of ``shape`` broadcast to (count, *shape), or given per step; finite."""
    arr = np.asarray(value, dtype=float)
    if arr.shape == shape:
        arr = np.broadcast_to(arr, (count, *shape))
    if arr.shape != (count, *shape):
        raise InputError(
            f"expected shape {shape} or {(count, *shape)}, got {arr.shape}", key=key, value=value
        )
    if not np.all(np.isfinite(arr)):
        raise InputError("contains NaN or inf", key=key, value=value)
    return arr


def time_grid(stroke: StrokePlan, cfg: LQTConfig) -> tuple[int, int]:
    """(steps per segment, N): each target held segment_time / dt steps, a whole number.

    N = m segment_time / dt for held targets (seed 000 sec. 3.3), (m - 1) segment_time / dt + 1
    for key-points (one every segment_time, GI eq. 6-7). segment_time is at most
    :data:`MAX_TIME`, and N is checked against the budget INKARM_MAX_STEPS
    (:mod:`inkarm.core.budget`) before anything is allocated.
    """
    if stroke.segment_time > MAX_TIME:
        raise PlanError(
            f"{expected_in(cfg.dt, MAX_TIME, 's', 'a number')} (dt .. {MAX_TIME:g} s), got "
            f"{stroke.segment_time:g}",
            key="segment_time",
            value=stroke.segment_time,
        )
    ratio = stroke.segment_time / cfg.dt
    per = round(ratio)
    if per >= 1 and abs(ratio - per) > 1e-6 * ratio:
        raise PlanError(
            f"{stroke.segment_time} s is not a whole number of dt = {cfg.dt} s steps "
            f"({ratio:.4g}); the targets would be held {per * cfg.dt:g} s instead",
            key="segment_time",
            value=stroke.segment_time,
        )
    if per < 1:
        raise PlanError(
            f"{stroke.segment_time} s is shorter than dt = {cfg.dt} s",
            key="segment_time",
            value=stroke.segment_time,
        )
    m = len(stroke.targets)
    held = m - 1 if stroke.keypoints else m
    budget.require(
        held * per + (1 if stroke.keypoints else 0),
        budget.STEPS,
        f"time steps of the stroke ({held} x segment_time {stroke.segment_time:g} s / "
        f"dt {cfg.dt:g} s)",
        key="dt",
        value=cfg.dt,
    )
    if stroke.keypoints:
        if m < 2:
            raise PlanError(
                "key-point interpolation needs at least 2 key-points, got 1",
                key="targets",
                value=m,
            )
        n_steps = (m - 1) * per + 1
    else:
        n_steps = m * per
    if n_steps < cfg.order + 1:
        raise PlanError(
            f"{n_steps} time steps (segment_time {stroke.segment_time} s / dt {cfg.dt} s "
            f"x {m} targets) but order {cfg.order} needs at least {cfg.order + 1}; "
            "use a smaller dt or a longer segment_time",
            key="segment_time",
            value=stroke.segment_time,
        )
    return per, n_steps


def velocity_steps(stroke: StrokePlan, per: int) -> tuple[np.ndarray, np.ndarray]:
    """(indices i of the targets with a prescribed velocity, their steps i * per).

    GI sec. 4.3: a velocity applies at its target's first step (a key-point's own step)."""
    vel = stroke.velocities
    if vel is None:
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    known = np.flatnonzero(np.all(np.isfinite(vel), axis=1))
    return known, known * per


def rests_at_end(stroke: StrokePlan, cfg: LQTConfig, per: int, n_steps: int) -> bool:
    """Whether the last state is held at rest: ``cfg.end_at_rest``, unless the plan prescribes
    a non-zero velocity at the last step (the last key-point of a Bezier mimic).

    A prescribed final velocity is the more specific request and wins. Kept at rest, the
    velocity term could not act at all (the derivatives of xi_N are pinned to 0) and the
    movement had to brake onto a key-point it was told to leave at speed: with a 190 mm/s
    tangent and key-point variance 1 mm^2 the path ended about 16 mm off the key-point.
    """
    if not cfg.end_at_rest:
        return False
    known, steps = velocity_steps(stroke, per)
    last = known[steps == n_steps - 1]
    return not (cfg.order > 1 and last.size and np.any(stroke.velocities[last]))
