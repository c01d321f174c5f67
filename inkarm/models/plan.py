"""Motor plans: ordered Gaussian targets per stroke, plus timing (seed 000, sec. 3.3).

A :class:`MotorPlan` is a list of :class:`StrokePlan`; each stroke is drawn pen-down and the pen
is lifted between strokes. Means in [mm], covariances in [mm^2], times in [s].
"""

from __future__ import annotations

from dataclasses import dataclass, field

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
            raise PlanError(f"{where}: diagonal covariance has {c.shape[0]} entries, expected {dim}")
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


@dataclass(frozen=True)
class GaussianTarget:
    """A target N(mean, cov): mean (D,) in [mm], cov (D, D) in [mm^2], symmetric positive definite."""

    mean: np.ndarray
    cov: np.ndarray

    def __post_init__(self) -> None:
        m = np.asarray(self.mean, dtype=float)
        if m.ndim != 1 or not 1 <= m.shape[0] <= 3:
            raise PlanError(f"target mean: expected 1 to 3 coordinates, got shape {m.shape}")
        if not np.all(np.isfinite(m)):
            raise PlanError(f"target mean: NaN or inf in {m.tolist()}")
        object.__setattr__(self, "mean", m)
        object.__setattr__(self, "cov", check_covariance(self.cov, m.shape[0], "target"))

    @property
    def dim(self) -> int:
        return self.mean.shape[0]


@dataclass(frozen=True)
class StrokePlan:
    """One pen-down stroke: an ordered sequence of targets, each held ``segment_time`` [s].

    Attributes:
        targets: The Gaussian targets, in order (at least one).
        segment_time: Duration T_s each target is tracked, in [s] (local isochrony, seed 000 sec. 3.3).
        keypoints: If True the targets are sparse key-points, each active at one instant
            (GI paper eq. 6-7) instead of held stepwise.
    """

    targets: tuple[GaussianTarget, ...]
    segment_time: float = 0.5
    keypoints: bool = False
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        targets = tuple(self.targets)
        if not targets:
            raise PlanError("stroke: no targets")
        for i, tg in enumerate(targets):
            if not isinstance(tg, GaussianTarget):
                raise PlanError(f"stroke target {i}: expected a GaussianTarget, got {type(tg).__name__}")
        dims = [tg.dim for tg in targets]
        if len(set(dims)) > 1:
            i = next(i for i, d in enumerate(dims) if d != dims[0])
            raise PlanError(
                f"stroke target {i}: has {dims[i]} dimensions but target 0 has {dims[0]} (mixed dimensions)"
            )
        st = float(self.segment_time)
        if not np.isfinite(st) or st <= 0:
            raise PlanError(f"stroke segment_time: must be a positive number of seconds, got {self.segment_time}")
        object.__setattr__(self, "targets", targets)
        object.__setattr__(self, "segment_time", st)

    @property
    def dim(self) -> int:
        return self.targets[0].dim

    @property
    def means(self) -> np.ndarray:
        """(m, D) target means in [mm]."""
        return np.array([tg.mean for tg in self.targets])

    @property
    def covs(self) -> np.ndarray:
        """(m, D, D) target covariances in [mm^2]."""
        return np.array([tg.cov for tg in self.targets])

    @staticmethod
    def from_arrays(means, covs, segment_time: float = 0.5, keypoints: bool = False) -> "StrokePlan":
        """Build from (m, D) means and covariances given per target as scalars, diagonals or matrices."""
        means = np.asarray(means, dtype=float)
        if means.ndim != 2:
            raise PlanError(f"stroke means: expected shape (m, D), got {means.shape}")
        if np.ndim(covs) == 0:
            covs = [covs] * len(means)
        if len(covs) != len(means):
            raise PlanError(f"stroke: {len(means)} means but {len(covs)} covariances")
        targets = []
        for i, (m, c) in enumerate(zip(means, covs)):
            try:
                targets.append(GaussianTarget(m, c))
            except PlanError as e:
                raise PlanError(f"stroke target {i}: {str(e).removeprefix('target: ').removeprefix('target ')}") from None
        return StrokePlan(tuple(targets), segment_time, keypoints)


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
