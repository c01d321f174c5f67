"""Motor plans: ordered Gaussian targets per stroke, plus timing (seed 000, sec. 3.3).

A :class:`MotorPlan` is a list of :class:`StrokePlan`; each stroke is drawn pen-down and the pen
is lifted between strokes. Means in [mm], covariances in [mm^2], times in [s].

These are the Gaussian strokes. Every kind of stroke a plan file may hold (Gaussian targets,
key-points, human lines, minimum-jerk paths, an installed plug-in's) is registered in the
stroke-kind registry, one module each: the protocol is :class:`inkarm.io.planfile.StrokeKind`
(it reads a plan file's table, so it lives with the plan-file reader), the built-ins are in
:mod:`inkarm.plans.kinds`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from inkarm.core.equality import same
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
    # Python floats: the checks of one small matrix cost microseconds, not array operations
    rows = c.tolist()
    flat = [v for row in rows for v in row]
    if not all(map(math.isfinite, flat)):
        raise PlanError(f"{where}: covariance contains NaN or inf")
    scale = max(max(map(abs, flat)), _TINY)
    if max(abs(rows[i][j] - rows[j][i]) for i in range(dim) for j in range(dim)) > 1e-9 * scale:
        raise PlanError(f"{where}: covariance is not symmetric: {rows}")
    sym = [[0.5 * (rows[i][j] + rows[j][i]) for j in range(dim)] for i in range(dim)]
    c = np.array(sym)  # 0.5 (C + C^T), the same operations element by element
    if not _clearly_positive_definite(sym):
        try:
            np.linalg.cholesky(c)
        except np.linalg.LinAlgError:
            eig = np.linalg.eigvalsh(c)
            raise PlanError(
                f"{where}: covariance is not positive definite (eigenvalues {eig.tolist()})"
            ) from None
    return c


def check_covariances(covs, dim: int, where) -> np.ndarray:
    """:func:`check_covariance` of every matrix of ``covs`` (m, dim, dim) at once: the checked,
    symmetrised (m, dim, dim) float array, equal element for element to the matrices
    :func:`check_covariance` returns one by one. Raises the error :func:`check_covariance`
    raises for the first bad matrix i, named ``where(i)`` (a function of the index)."""
    c = np.asarray(covs, dtype=float)
    if c.ndim != 3 or c.shape[1:] != (dim, dim):
        raise PlanError(f"{where(0)}: covariances have shape {c.shape}, expected (m, {dim}, {dim})")
    checked = _checked_covariances(c)
    if checked is None:  # the first bad matrix raises its own error
        checked = np.array([check_covariance(c[i], dim, where(i)) for i in range(len(c))])
    return checked


def _checked_covariances(c: np.ndarray) -> np.ndarray | None:
    """(m, D, D) ``c`` symmetrised as :func:`check_covariance` does, or None if any matrix
    is not finite, not symmetric or not positive definite by its rules."""
    ct = np.swapaxes(c, 1, 2)
    with np.errstate(invalid="ignore", over="ignore"):
        scale = np.maximum(np.abs(c).max(axis=(1, 2), initial=0.0), _TINY)
        good = np.isfinite(c).all(axis=(1, 2)) & (
            np.abs(c - ct).max(axis=(1, 2), initial=0.0) <= 1e-9 * scale
        )
    if not good.all():
        return None
    sym = 0.5 * (c + ct)
    try:
        np.linalg.cholesky(sym)  # LAPACK on each matrix, as check_covariance asks it
    except np.linalg.LinAlgError:
        return None
    return sym


_TINY = np.finfo(float).tiny
_PD_MARGIN = 1e-4
"""Smallest Cholesky pivot, relative to its diagonal entry, that
:func:`_clearly_positive_definite` accepts. The product of these ratios is the determinant
of the matrix scaled to a unit diagonal, so every eigenvalue of that scaled matrix is then
above 1e-12 / 9 (D <= 3): far above the rounding error of LAPACK's factorisation (Demmel's
condition, about D^2 ulp), which therefore succeeds too."""


def _clearly_positive_definite(rows: list[list[float]]) -> bool:
    """True if the symmetric matrix ``rows`` (Python floats) is positive definite with every
    Cholesky pivot above ``_PD_MARGIN`` of its diagonal entry, its entries well inside the
    floating range: then :func:`numpy.linalg.cholesky` succeeds on it as well. False means "not
    clearly", and the caller asks LAPACK."""
    n = len(rows)
    if n == 2:  # the common case, unrolled
        a, b, d = rows[0][0], rows[1][0], rows[1][1]
        if not (1e-150 < a < 1e150 and 1e-150 < d < 1e150 and abs(b) < 1e150):
            return False
        l21 = b / math.sqrt(a)
        return d - l21 * l21 > _PD_MARGIN * d
    low = [[0.0] * n for _ in range(n)]
    for j in range(n):
        a = rows[j][j]
        if not 1e-150 < a < 1e150:
            return False
        s = a - sum(low[j][k] * low[j][k] for k in range(j))
        if not s > _PD_MARGIN * a:
            return False
        low[j][j] = d = math.sqrt(s)
        for i in range(j + 1, n):
            if not abs(rows[i][j]) < 1e150:
                return False
            low[i][j] = (rows[i][j] - sum(low[i][k] * low[j][k] for k in range(j))) / d
    return True


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
        return same(self.mean, other.mean) and same(self.cov, other.cov)

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
        targets: The Gaussian targets, in order (at least one): a tuple, or a
            :class:`TargetArray` (a stroke built from arrays, :func:`stroke_from_arrays`).
        segment_time: Duration T_s each target is tracked, in [s] (local isochrony, seed 000 sec. 3.3).
        keypoints: If True the targets are sparse key-points, each active at one instant
            (GI paper eq. 6-7) instead of held stepwise.
        velocities: Optional (m, D) velocities in [mm/s] imposed at each target's first step
            (key-points: at the key-point), GI sec. 4.3 (Bezier mimicking); a row of NaN leaves
            that target's velocity free.
        velocity_var: Variance of the velocity constraints in [(mm/s)^2] (small = hard).
    """

    targets: tuple[GaussianTarget, ...] | TargetArray
    segment_time: float = 0.5
    keypoints: bool = False
    meta: dict = field(default_factory=dict)
    velocities: np.ndarray | None = None
    velocity_var: float = 1e-6

    def __post_init__(self) -> None:
        targets = self.targets
        if not isinstance(targets, TargetArray):  # (whose arrays are checked already)
            targets = tuple(targets)
            _check_targets(targets)
        elif not len(targets):
            raise PlanError("stroke: no targets")
        st = float(self.segment_time)
        if not np.isfinite(st) or st <= 0:
            raise PlanError(
                f"stroke segment_time: must be a positive number of seconds, got {self.segment_time}"
            )
        object.__setattr__(self, "targets", targets)
        object.__setattr__(self, "segment_time", st)
        if self.velocities is not None:
            vel = np.asarray(self.velocities, dtype=float)
            dim = len(targets[0].mean)
            if vel.shape != (len(targets), dim):
                raise PlanError(
                    f"stroke velocities: expected shape {(len(targets), dim)}, got {vel.shape}"
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
            and same(self.velocities, other.velocities)
            and same(self.meta, other.meta)
        )

    def __hash__(self) -> int:
        return hash((self.targets, self.segment_time, self.keypoints, self.velocity_var))

    @property
    def dim(self) -> int:
        return self.targets[0].dim

    @cached_property
    def means(self) -> np.ndarray:
        """(m, D) target means in [mm] (read-only)."""
        if isinstance(self.targets, TargetArray):
            return self.targets.means
        return _frozen(np.array([tg.mean for tg in self.targets]))

    @cached_property
    def covs(self) -> np.ndarray:
        """(m, D, D) target covariances in [mm^2] (read-only)."""
        if isinstance(self.targets, TargetArray):
            return self.targets.covs
        return _frozen(np.array([tg.cov for tg in self.targets]))

    @cached_property
    def precisions(self) -> np.ndarray:
        """(m, D, D) target precisions Sigma_i^-1 in [mm^-2] (read-only, symmetric)."""
        p = np.linalg.inv(self.covs)
        return _frozen(0.5 * (p + np.swapaxes(p, 1, 2)))

    @staticmethod
    def from_arrays(
        means,
        covs,
        segment_time: float = 0.5,
        keypoints: bool = False,
        meta: dict | None = None,
    ) -> StrokePlan:
        """Build from (m, D) means and covariances given per target as scalars, diagonals or
        matrices (or one scalar for all). Arrays of one form are checked in bulk
        (:func:`stroke_from_arrays`); the plan, and the error for bad input, are those of
        building each :class:`GaussianTarget` in turn."""
        means = np.asarray(means, dtype=float)
        if means.ndim != 2:
            raise PlanError(f"stroke means: expected shape (m, D), got {means.shape}")
        if isinstance(covs, (int, float, np.number)) or (
            isinstance(covs, np.ndarray) and covs.ndim == 0
        ):
            covs = [covs] * len(means)
        if len(covs) != len(means):
            raise PlanError(f"stroke: {len(means)} means but {len(covs)} covariances")
        plan = stroke_from_arrays(means, covs, segment_time, keypoints, meta)
        if plan is not None:
            return plan
        targets = []
        for i, (m, c) in enumerate(zip(means, covs)):
            try:
                targets.append(GaussianTarget(m, c))
            except PlanError as e:
                raise PlanError(
                    f"stroke target {i}: {str(e).removeprefix('target: ').removeprefix('target ')}"
                ) from None
        return StrokePlan(tuple(targets), segment_time, keypoints, meta=dict(meta or {}))


def stroke_from_arrays(
    means, covs, segment_time: float = 0.5, keypoints: bool = False, meta: dict | None = None
) -> StrokePlan | None:
    """The stroke through ``means`` (m, D) with covariances ``covs``: m scalars, m diagonals
    (m, D) or m matrices (m, D, D), all checked at once (a few array operations per stroke,
    not a dozen per target). The plan equals the one built from a :class:`GaussianTarget`
    per target, element for element. None when the arrays are not all of one form or some
    target is bad: then build the targets one by one, which raises the target's own error.
    ``segment_time``, ``keypoints`` and ``meta`` go to :class:`StrokePlan` (which checks
    them)."""
    try:
        means = np.asarray(means, dtype=float)
        c = np.asarray(covs, dtype=float)
    except (TypeError, ValueError):  # ragged: scalars, diagonals and matrices mixed
        return None
    if means.ndim != 2 or not 1 <= means.shape[1] <= 3 or not len(means):
        return None
    m, dim = means.shape
    if not np.isfinite(means).all():
        return None
    if c.shape == (m,):
        c = c[:, None, None] * np.eye(dim)[None]  # as np.eye(dim) * c, target by target
    elif c.shape == (m, dim):
        diag = c
        c = np.zeros((m, dim, dim))  # as np.diag(c)
        c[:, np.arange(dim), np.arange(dim)] = diag
    if c.shape != (m, dim, dim):
        return None
    checked = _checked_covariances(c)
    if checked is None:
        return None
    means = _frozen(np.array(means))  # a copy: the caller's array stays writable and theirs
    checked = _frozen(checked)
    return StrokePlan(TargetArray._trusted(means, checked), segment_time, keypoints,
                      meta=dict(meta or {}))


class TargetArray(Sequence):
    """The targets of a stroke held as arrays, means (m, D) in [mm] and covariances (m, D, D)
    in [mm^2], both checked and read-only: each :class:`GaussianTarget` is made when asked
    for. A page of text holds a hundred thousand targets, a dozen small objects each when
    they are kept. Equal to, and hashed as, the tuple of its targets."""

    __slots__ = ("covs", "means")

    def __init__(self, means, covs) -> None:
        """Checked: finite means (m, D), covariances (m, D, D) each symmetric positive
        definite (as :func:`check_covariance` has them); both kept read-only copies."""
        means, covs = np.array(means, dtype=float), np.array(covs, dtype=float)
        m = len(means)
        if means.ndim != 2 or covs.shape != (m, means.shape[1], means.shape[1]):
            raise PlanError(f"targets: expected means (m, D) and covariances (m, D, D), got "
                            f"{means.shape} and {covs.shape}")
        checked = _checked_covariances(covs) if m else covs
        if not np.isfinite(means).all() or checked is None:
            raise PlanError("targets: expected finite means and symmetric positive definite "
                            "covariances")
        self.means, self.covs = _frozen(means), _frozen(checked)

    @classmethod
    def _trusted(cls, means: np.ndarray, covs: np.ndarray) -> TargetArray:
        """Arrays already checked and frozen (:func:`stroke_from_arrays`): kept as they are."""
        out = cls.__new__(cls)
        out.means, out.covs = means, covs
        return out

    def __len__(self) -> int:
        return len(self.means)

    def __getitem__(self, i):
        if isinstance(i, slice):
            return tuple(map(_target, self.means[i], self.covs[i]))
        return _target(self.means[i], self.covs[i])

    def __iter__(self):
        return map(_target, self.means, self.covs)

    def __eq__(self, other) -> bool:
        if not isinstance(other, (tuple, TargetArray)):
            return NotImplemented
        return tuple(self) == tuple(other)

    def __hash__(self) -> int:
        return hash(tuple(self))

    def __repr__(self) -> str:
        return repr(tuple(self))

    def __reduce__(self):
        return TargetArray, (self.means, self.covs)


def _target(mean: np.ndarray, cov: np.ndarray) -> GaussianTarget:
    """A GaussianTarget of a checked, read-only mean (D,) and covariance (D, D)."""
    tg = object.__new__(GaussianTarget)
    object.__setattr__(tg, "mean", mean)
    object.__setattr__(tg, "cov", cov)
    return tg


def _frozen(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def _check_targets(targets: tuple) -> None:
    """Refuse no targets, a target that is not a GaussianTarget, or mixed dimensions."""
    if not targets:
        raise PlanError("stroke: no targets")
    if not all(isinstance(tg, GaussianTarget) for tg in targets):
        i, tg = next(
            (i, tg) for i, tg in enumerate(targets) if not isinstance(tg, GaussianTarget)
        )
        raise PlanError(
            f"stroke target {i}: expected a GaussianTarget, got {type(tg).__name__}"
        )
    dims = [len(tg.mean) for tg in targets]
    if dims.count(dims[0]) != len(dims):
        i = next(i for i, d in enumerate(dims) if d != dims[0])
        raise PlanError(
            f"stroke target {i}: has {dims[i]} dimensions but target 0 has {dims[0]} (mixed dimensions)"
        )


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
