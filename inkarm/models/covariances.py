"""Generated target covariances: semi-tied covariances (seed 000 eq. 22).

Units: covariances in [mm^2].
"""

from __future__ import annotations

import numpy as np

from inkarm.core.plan import check_covariance
from inkarm.errors import InputError

MAX_BASIS = 1e6  # |entries| of H


def semi_tied_covariances(m: int, H, h, rho: float = 0.0, seed=None) -> np.ndarray:
    """m covariances Sigma_i = H D_i H^T with D_i = h_i I, h_i ~ N(h, rho) (seed 000 eq. 22).

    Args:
        m: Number of targets.
        H: (D, D) oblique basis, non-singular (its columns are the shared axes), entries
            within +-1e6.
        h: Magnitude in [1e-12, 1e12]; with unit-length columns of H, Sigma_i has variances
            h_i in [mm^2].
        rho: Variance of the perturbation of h (eq. 22 writes N(h, rho)), 0 .. 1e24; 0 = all
            equal. Draws h_i <= 0 are redrawn (a covariance must stay positive definite).
        seed: None, an int or a numpy Generator.
    Returns:
        (m, D, D) symmetric positive definite covariances.
    """
    if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or m < 1:
        raise InputError(f"expected a positive integer number of targets, got {m!r}", key="m",
                         value=m)
    from inkarm.core.ranges import expected_in, outside
    from inkarm.models.lqt.config import VARIANCE_RANGE

    basis = _basis(H)
    if not _positive(h):
        raise InputError(f"must be a positive number, got {h}", key="h", value=h)
    if outside(h, *VARIANCE_RANGE) is not None:
        raise InputError(f"{expected_in(*VARIANCE_RANGE, 'mm^2', 'a number')}, got {float(h):g}",
                         key="h", value=h)
    try:
        rho = float(rho)
    except (TypeError, ValueError):
        raise InputError(f"expected a number, got {rho!r}", key="rho", value=rho) from None
    if not np.isfinite(rho) or rho < 0:
        raise InputError(f"must be >= 0, got {rho}", key="rho", value=rho)
    if rho > VARIANCE_RANGE[1] ** 2:
        raise InputError(f"{expected_in(0, VARIANCE_RANGE[1] ** 2, 'mm^4', 'a number')}, got "
                         f"{rho:g}",
                         key="rho", value=rho)
    mags = _magnitudes(int(m), float(h), rho, seed)
    covs = mags[:, None, None] * (basis @ basis.T)[None]  # eq. 22: H D_i H^T, D_i = h_i I
    for i, c in enumerate(covs):
        check_covariance(c, basis.shape[0], f"semi-tied covariance {i}")
    return 0.5 * (covs + np.swapaxes(covs, 1, 2))


def _basis(H) -> np.ndarray:
    """H as a finite, non-singular (D, D) array, D in 1..3."""
    basis = np.asarray(H, dtype=float)
    if basis.ndim != 2 or basis.shape[0] != basis.shape[1] or not 1 <= basis.shape[0] <= 3:
        raise InputError(
            f"expected a square (D, D) matrix, D in 1..3, got shape {basis.shape}", key="H",
            value=H,
        )
    if not np.all(np.isfinite(basis)):
        raise InputError("contains NaN or inf", key="H", value=H)
    scale = float(np.max(np.abs(basis)))
    if scale > MAX_BASIS:
        raise InputError(f"expected entries in [{-MAX_BASIS:g}, {MAX_BASIS:g}], got {scale:g}",
                         key="H", value=H)
    if np.linalg.matrix_rank(basis) < basis.shape[0]:
        raise InputError(
            f"singular basis {basis.tolist()}; expected a non-singular matrix", key="H", value=H
        )
    return basis


def _magnitudes(m: int, h: float, rho: float, seed) -> np.ndarray:
    """h_i ~ N(h, rho), redrawing non-positive values; all h when rho = 0."""
    if rho == 0:
        return np.full(m, h)
    rng = np.random.default_rng(seed)
    mags = rng.normal(h, np.sqrt(rho), m)
    for _ in range(1000):
        bad = mags <= 0
        if not bad.any():
            return mags
        mags[bad] = rng.normal(h, np.sqrt(rho), int(bad.sum()))
    raise InputError(f"h = {h} with rho = {rho} gives no positive draws", key="rho", value=rho)


def _positive(value) -> bool:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return False
    return bool(np.isfinite(v) and v > 0)
