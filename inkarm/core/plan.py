"""Motor plans: ordered Gaussian targets per stroke, plus timing (seed 000, sec. 3.3).

A :class:`MotorPlan` is a list of :class:`StrokePlan`; each stroke is drawn pen-down and the pen
is lifted between strokes. Means in [mm], covariances in [mm^2], times in [s].
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from inkarm.errors import PlanError


def check_covariance(cov, dim: int, where: str) -> np.ndarray:
    """Return ``cov`` as a (dim, dim) float array, or raise naming ``where``.

    Accepts a scalar variance (spherical), a length-dim vector (diagonal) or a full matrix,
    which must be symmetric (relative tolerance 1e-9) and positive definite.
    """
    c = np.asarray(cov, dtype=float)
    if c.ndim == 0:
        c = np.eye(dim) * c
    elif c.ndim == 1:
        if c.shape[0] != dim:
            raise PlanError(
                f"{where}: diagonal covariance has {c.shape[0]} entries, expected {dim}"
            )
        c = np.diag(c)
    if c.shape != (dim, dim):
        raise PlanError(f"{where}: covariance has shape {c.shape}, expected ({dim}, {dim})")
    if not np.all(np.isfinite(c)):
        raise PlanError(f"{where}: covariance contains NaN or inf")
    scale = max(float(np.max(np.abs(c))), np.finfo(float).tiny)
    if np.max(np.abs(c - c.T)) > 1e-9 * scale:
        raise PlanError(f"{where}: covariance is not symmetric: {c.tolist()}")
    c = 0.5 * (c + c.T)
    try:
        np.linalg.cholesky(c)
    except np.linalg.LinAlgError:
        eig = np.linalg.eigvalsh(c)
        raise PlanError(
            f"{where}: covariance is not positive definite (eigenvalues {eig.tolist()})"
        ) from None
    return c


def _same(a, b) -> bool:
    """Value equality that also holds for NumPy arrays (element-wise, NaN equal to NaN, shapes
    equal) and for dicts, lists and tuples holding them."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        if a.shape != b.shape:
            return False
        try:
            return bool(np.array_equal(a, b, equal_nan=True))
        except TypeError:  # non-numeric arrays: NaN has no meaning there
            return bool(np.array_equal(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(map(_same, a, b))
    return bool(a == b)


@dataclass(frozen=True, eq=False)
class GaussianTarget:
    """A target N(mean, cov): mean (D,) in [mm], cov (D, D) in [mm^2], symmetric positive definite.

    Both arrays are read-only copies, so a target is a value: ``==`` compares the arrays
    element by element and equal targets hash alike.
    """

    mean: np.ndarray
    cov: np.ndarray

    def __post_init__(self) -> None:
        m = np.array(self.mean, dtype=float)  # a copy: frozen below without touching the caller's
        if m.ndim != 1 or not 1 <= m.shape[0] <= 3:
            raise PlanError(f"target mean: expected 1 to 3 coordinates, got shape {m.shape}")
        if not np.all(np.isfinite(m)):
            raise PlanError(f"target mean: NaN or inf in {m.tolist()}")
        object.__setattr__(self, "mean", _frozen(m))
        object.__setattr__(self, "cov", _frozen(check_covariance(self.cov, m.shape[0], "target")))

    def __eq__(self, other) -> bool:
        if other.__class__ is not self.__class__:
            return NotImplemented
        return _same(self.mean, other.mean) and _same(self.cov, other.cov)

    def __hash__(self) -> int:
        # Python floats hash -0.0 like 0.0, as == has them equal; means and covs are finite.
        return hash((tuple(self.mean.tolist()), tuple(self.cov.ravel().tolist())))

    @property
    def dim(self) -> int:
        return self.mean.shape[0]


@dataclass(frozen=True, eq=False)
class StrokePlan:
    """One pen-down stroke: an ordered sequence of targets, each held ``segment_time`` [s].

    A value: ``==`` compares every field, arrays element by element (NaN velocity rows equal);
    the hash covers the targets and the timing (equal plans hash alike; ``meta``, a mutable
    dict, and ``velocities`` are left out of the hash but not of ``==``).

    Attributes:
        targets: The Gaussian targets, in order (at least one).
        segment_time: Duration T_s each target is tracked, in [s] (local isochrony, seed 000 sec. 3.3).
        keypoints: If True the targets are sparse key-points, each active at one instant
            (GI paper eq. 6-7) instead of held stepwise.
        velocities: Optional (m, D) velocities in [mm/s] imposed at each target's first step
            (key-points: at the key-point), GI sec. 4.3 (Bezier mimicking); a row of NaN leaves
            that target's velocity free.
        velocity_var: Variance of the velocity constraints in [(mm/s)^2] (small = hard).
    """

    targets: tuple[GaussianTarget, ...]
    segment_time: float = 0.5
    keypoints: bool = False
    meta: dict = field(default_factory=dict)
    velocities: np.ndarray | None = None
    velocity_var: float = 1e-6

    def __post_init__(self) -> None:
        targets = tuple(self.targets)
        if not targets:
            raise PlanError("stroke: no targets")
        for i, tg in enumerate(targets):
            if not isinstance(tg, GaussianTarget):
                raise PlanError(
                    f"stroke target {i}: expected a GaussianTarget, got {type(tg).__name__}"
                )
        dims = [tg.dim for tg in targets]
        if len(set(dims)) > 1:
            i = next(i for i, d in enumerate(dims) if d != dims[0])
            raise PlanError(
                f"stroke target {i}: has {dims[i]} dimensions but target 0 has {dims[0]} (mixed dimensions)"
            )
        st = float(self.segment_time)
        if not np.isfinite(st) or st <= 0:
            raise PlanError(
                f"stroke segment_time: must be a positive number of seconds, got {self.segment_time}"
            )
        object.__setattr__(self, "targets", targets)
        object.__setattr__(self, "segment_time", st)
        if self.velocities is not None:
            vel = np.asarray(self.velocities, dtype=float)
            if vel.shape != (len(targets), dims[0]):
                raise PlanError(
                    f"stroke velocities: expected shape {(len(targets), dims[0])}, got {vel.shape}"
                )
            partial = np.isnan(vel).any(axis=1) & ~np.isnan(vel).all(axis=1)
            if partial.any() or np.isinf(vel).any():
                i = int(np.flatnonzero(partial | np.isinf(vel).any(axis=1))[0])
                raise PlanError(
                    f"stroke velocity {i}: {vel[i].tolist()}; expected finite values or a row of NaN (free)"
                )
            object.__setattr__(self, "velocities", _frozen(vel.copy()))
        vv = float(self.velocity_var)
        if not np.isfinite(vv) or vv <= 0:
            raise PlanError(
                f"stroke velocity_var: must be a positive variance in (mm/s)^2, got {self.velocity_var}"
            )
        object.__setattr__(self, "velocity_var", vv)

    def __eq__(self, other) -> bool:
        if other.__class__ is not self.__class__:
            return NotImplemented
        return (
            self.targets == other.targets
            and self.segment_time == other.segment_time
            and self.keypoints == other.keypoints
            and self.velocity_var == other.velocity_var
            and _same(self.velocities, other.velocities)
            and _same(self.meta, other.meta)
        )

    def __hash__(self) -> int:
        return hash((self.targets, self.segment_time, self.keypoints, self.velocity_var))

    @property
    def dim(self) -> int:
        return self.targets[0].dim

    @cached_property
    def means(self) -> np.ndarray:
        """(m, D) target means in [mm] (read-only)."""
        return _frozen(np.array([tg.mean for tg in self.targets]))

    @cached_property
    def covs(self) -> np.ndarray:
        """(m, D, D) target covariances in [mm^2] (read-only)."""
        return _frozen(np.array([tg.cov for tg in self.targets]))

    @cached_property
    def precisions(self) -> np.ndarray:
        """(m, D, D) target precisions Sigma_i^-1 in [mm^-2] (read-only, symmetric)."""
        p = np.linalg.inv(self.covs)
        return _frozen(0.5 * (p + np.swapaxes(p, 1, 2)))

    @staticmethod
    def from_arrays(means, covs, segment_time: float = 0.5, keypoints: bool = False) -> StrokePlan:
        """Build from (m, D) means and covariances given per target as scalars, diagonals or matrices."""
        means = np.asarray(means, dtype=float)
        if means.ndim != 2:
            raise PlanError(f"stroke means: expected shape (m, D), got {means.shape}")
        if isinstance(covs, (int, float, np.number)) or (
            isinstance(covs, np.ndarray) and covs.ndim == 0
        ):
            covs = [covs] * len(means)
        if len(covs) != len(means):
            raise PlanError(f"stroke: {len(means)} means but {len(covs)} covariances")
        targets = []
        for i, (m, c) in enumerate(zip(means, covs)):
            try:
                targets.append(GaussianTarget(m, c))
            except PlanError as e:
                raise PlanError(
                    f"stroke target {i}: {str(e).removeprefix('target: ').removeprefix('target ')}"
                ) from None
        return StrokePlan(tuple(targets), segment_time, keypoints)


def _frozen(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def bezier_keypoints(
    control_points, segment_time: float = 0.5, variance: float = 1e-6, velocity_var: float = 1e-6
) -> StrokePlan:
    """Key-points with velocities that mimic a piecewise cubic Bezier curve (GI sec. 4.3).

    Args:
        control_points: (3 k + 1, D) points P0, P1, P2, P3, P4, ... in [mm]: k cubic segments
            sharing end points.
        segment_time: Duration of each cubic segment in [s].
        variance: Position variance of every key-point in [mm^2] (small = interpolate).
        velocity_var: Variance of the velocity constraints in [(mm/s)^2].
    Returns:
        A key-point :class:`StrokePlan` through the segment end points whose velocities are the
        Bezier end tangents 3 (P1 - P0) / T and 3 (P3 - P2) / T. Where segments meet, the
        incoming tangent is used (the curve is C1 only if the control points are collinear there).
    """
    cps = np.asarray(control_points, dtype=float)
    if cps.ndim != 2 or cps.shape[0] < 4 or (cps.shape[0] - 1) % 3:
        raise PlanError(
            f"bezier control_points: expected (3k + 1, D) points, got shape {cps.shape}"
        )
    if not np.all(np.isfinite(cps)):
        raise PlanError("bezier control_points: NaN or inf")
    ends = cps[::3]
    vel = np.empty_like(ends)
    vel[:-1] = 3.0 * (cps[1::3] - cps[0:-1:3]) / segment_time
    vel[-1] = 3.0 * (cps[-1] - cps[-2]) / segment_time
    vel[1:-1] = 3.0 * (cps[3:-1:3] - cps[2:-2:3]) / segment_time
    plan = StrokePlan.from_arrays(ends, variance, segment_time=segment_time, keypoints=True)
    return StrokePlan(
        plan.targets, plan.segment_time, True, velocities=vel, velocity_var=velocity_var
    )


@dataclass(frozen=True)
class MotorPlan:
    """Strokes drawn in order, pen up between them."""

    strokes: tuple[StrokePlan, ...]

    def __post_init__(self) -> None:
        strokes = tuple(self.strokes)
        if not strokes:
            raise PlanError("motor plan: no strokes")
        dims = {s.dim for s in strokes}
        if len(dims) > 1:
            raise PlanError(f"motor plan: strokes mix dimensions {sorted(dims)}")
        object.__setattr__(self, "strokes", strokes)
