"""Linear-time solvers of the banded LQT problem, and sampling from its posterior.

* ``"cholesky"``: the banded normal equations H c = A^T b (LAPACK pbtrf), followed by one step
  of iterative refinement whose residual is computed from differences of the solution (not
  from the rounded normal matrix).
* ``"augmented"``: Bjorck's augmented system with the whitened control residuals y as extra
  unknowns, interleaved in time so that it stays banded (LAPACK gbtrf):

      [[H_obs, beta E^T], [beta E, -beta^2 I]] [c; y] = [A_obs^T b; beta z],

  E = control Delta^n. It avoids squaring the condition number and stays accurate at orders
  6-7. ``"auto"`` picks Cholesky only where a bound on its conditioning says it is safe.

The posterior of the free coefficients is N(c_hat, H^-1) (the image of seed 000 eq. 15's
Sigma_xi = S_u Sigma_u S_u^T under the invertible map u <-> c); :class:`Factor` draws from it
exactly, and :func:`eigen_draws` follows the paper's eq. 16-17.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.linalg import eig_banded, lapack

from inkarm.errors import SolverError
from inkarm.models.lqt.normal import (
    control_adjoint,
    control_rows,
    couplings,
    normal_band,
    normal_residual,
    obs_band,
    precision_loss,
    rhs,
)
from inkarm.models.lqt.problem import Problem


class Factor:
    """A factorisation of the banded problem, reused for the mean, every draw and the
    covariance.

    Attributes:
        method: ``"cholesky"`` or ``"augmented"`` (``"auto"`` resolved).
        obs: Lower band of the tracking part of H.
    """

    def __init__(self, prob: Problem, method: str):
        self.prob = prob
        self.obs = obs_band(prob)
        loss = precision_loss(prob, self.obs)
        if method == "auto":
            # one refinement step squares the relative error (measured: < 1e-8 up to loss 1e-3)
            method = "cholesky" if loss < 1e-4 else "augmented"
        self.refine = loss > 1e-9
        self.coupled = couplings(self.obs) if self.refine else ()
        self.method = method
        if method == "cholesky":
            self._factor_cholesky()
        else:
            self._factor_augmented()

    # normal equations ------------------------------------------------------------------------
    def _factor_cholesky(self) -> None:
        """H = L L^T in band storage."""
        chol, info = lapack.dpbtrf(normal_band(self.prob, self.obs), lower=1, overwrite_ab=1)
        if info != 0:
            raise SolverError(
                f"LQT normal equations not positive definite (pbtrf info {info}): too "
                "ill-conditioned for them; use solver='augmented' (and method='exact' to sample)",
                key="solver",
                value="cholesky",
            )
        self.chol = chol

    def _chol_solve(self, b: np.ndarray, overwrite: bool = True) -> np.ndarray:
        """H^-1 b for b (n_free, D) or (K, n_free, D); b may be overwritten."""
        flat = b.reshape(b.shape[0], -1).T if b.ndim == 3 else b.reshape(-1)
        x, info = lapack.dpbtrs(self.chol, flat, lower=1, overwrite_b=overwrite)
        if info != 0:
            raise SolverError(f"LQT banded solve failed (pbtrs info {info})")
        return x.T.reshape(b.shape) if b.ndim == 3 else x.reshape(b.shape)

    # augmented system ------------------------------------------------------------------------
    def _factor_augmented(self) -> None:
        """LU of the banded augmented matrix K."""
        p = self.prob
        diag = self.obs[0][self.obs[0] > 0]
        # Bjorck's scaling: beta^2, the weight of the control residuals, at the geometric mean of
        # the extreme tracking precisions keeps K about as well conditioned as the stacked rows
        self.beta = float(np.sqrt(np.min(diag) * np.max(diag))) ** 0.5 if diag.size else 1.0
        s = _augmented_structure(p.n, p.dim, p.n_steps, p.n_coef, self.obs.shape[0] // p.dim)
        vals = np.concatenate(
            [
                self.obs[s.obs_mask],
                self.obs[s.obs_mask_upper],
                self.beta * p.control * s.ctrl_values,
                np.full(s.n_y, -(self.beta**2)),
            ]
        )
        ab = np.zeros((2 * s.kl + s.ku + 1, s.size))
        ab.flat[s.flat] = vals
        lu, piv, info = lapack.dgbtrf(ab, s.kl, s.ku)
        if info != 0:
            raise SolverError(f"LQT augmented system singular (gbtrf info {info})")
        self.lu, self.piv, self.s = lu, piv, s

    def _aug_solve(self, b: np.ndarray, zc: np.ndarray | None = None) -> np.ndarray:
        """Solve K [c; y] = [b; beta zc] for c: c = H^-1 (b + control (Delta^n)^T zc)."""
        p, s = self.prob, self.s
        many = b.ndim == 3
        k = b.shape[0] if many else 1
        full = np.zeros((s.size, k))
        full[s.x_pos] = b.reshape(k, -1).T
        if zc is not None:  # control targets: beta E x - beta^2 y = beta z
            full[s.y_pos] = self.beta * np.broadcast_to(zc, (k, *zc.shape[-2:])).reshape(k, -1).T
        x, info = lapack.dgbtrs(self.lu, s.kl, s.ku, full, self.piv)
        if info != 0:
            raise SolverError(f"LQT augmented solve failed (gbtrs info {info})")
        out = x[s.x_pos].T.reshape(k, p.n_free, p.dim)
        return out if many else out[0]

    # public ----------------------------------------------------------------------------------
    def mean(self, prob: Problem, b: np.ndarray | None = None) -> np.ndarray:
        """Free coefficients (n_free, D) of the optimum of ``prob`` (this factor's problem, or
        one of the same structure with other means, :mod:`.structure`): c_hat = H^-1 A^T b;
        ``b``: A^T b (n_free, D) if known (then ``prob`` gives the structure only)."""
        b = rhs(prob) if b is None else b
        if self.method == "augmented":
            return self._aug_solve(b, prob.control_target)
        if prob.control_target is not None:
            b += control_adjoint(prob, prob.control_target)
        c = self._chol_solve(b, overwrite=not self.refine)
        if self.refine:  # one step of iterative refinement with an accurately computed residual
            c += self._chol_solve(normal_residual(prob, self.obs, b, c, self.coupled))
        return c

    def samples(self, k: int, rng: np.random.Generator, mean: np.ndarray,
                prob: Problem) -> np.ndarray:
        """K exact draws (K, n_free, D) of the coefficients of ``prob`` (as for :meth:`mean`)
        around ``mean`` (= :meth:`mean`).

        Cholesky (H = L L^T): c = c_hat + L^-T z, z ~ N(0, I), whose covariance is H^-1, the
        posterior covariance of the coefficients. Augmented: perturbation sampling, re-solving
        the factorised system, all K draws as K right-hand sides, with targets
        y_t ~ N(mu_t, Sigma_t) and controls pulled towards u0 ~ N(0, R^-1); the solution is
        linear in (y, u0), its mean is the optimum and its covariance
        Sigma_u (S_u^T Q S_u + R) Sigma_u = Sigma_u, mapped through S_u.
        """
        p = prob
        if self.method == "cholesky":
            z = rng.standard_normal((k, p.n_free * p.dim)).T
            dev, info = lapack.dtbtrs(self.chol, z, uplo="L", trans="T", overwrite_b=1)
            if info != 0:
                raise SolverError(f"LQT banded triangular solve failed (tbtrs info {info})")
            dev = dev.T.reshape(k, p.n_free, p.dim)
            dev += mean
            return dev
        b = rhs(p, noise=(rng, k))
        zc = rng.standard_normal((k, p.n_steps - 1, p.dim))
        if p.control_target is not None:
            zc += p.control_target
        return self._aug_solve(b, zc)

    def inverse(self) -> np.ndarray:
        """H^-1 (n_free D, n_free D), the posterior covariance of the free coefficients in
        [mm^2]; dense, O(N^2) memory."""
        p = self.prob
        size = p.n_free * p.dim
        if self.method == "cholesky":  # H^-1 = L^-T L^-1
            w, info = lapack.dtbtrs(self.chol, np.eye(size), uplo="L")
            if info != 0:
                raise SolverError(f"LQT banded triangular solve failed (tbtrs info {info})")
            inv = w.T @ w
        else:
            inv = self._aug_solve(np.eye(size).reshape(size, p.n_free, p.dim)).reshape(size, size)
        return 0.5 * (inv + inv.T)


def eigen_draws(
    factor: Factor, mean: np.ndarray, k: int, components: int | None, rng: np.random.Generator
) -> np.ndarray:
    """K draws (K, n_free, D) of the coefficients by seed 000 eq. 16-17.

    xi ~ mu + V Lambda^1/2 N(0, I) with the ``components`` largest eigenpairs of the
    covariance H^-1, i.e. the smallest of the banded precision H (LAPACK, banded); None uses
    all of them.
    """
    p = factor.prob
    band = normal_band(p, factor.obs)
    count = band.shape[1] if components is None else min(int(components), band.shape[1])
    lam, vec = eig_banded(band, lower=True, select="i", select_range=(0, count - 1))  # eq. 17
    z = rng.standard_normal((k, count))
    draws = mean.reshape(-1) + (z / np.sqrt(lam)) @ vec.T  # eq. 16
    return draws.reshape(k, p.n_free, p.dim)


@dataclass(frozen=True)
class _AugStructure:
    size: int
    kl: int
    ku: int
    flat: np.ndarray
    obs_mask: np.ndarray
    obs_mask_upper: np.ndarray
    ctrl_values: np.ndarray
    n_y: int
    x_pos: np.ndarray
    y_pos: np.ndarray


@lru_cache(maxsize=32)
def _augmented_structure(
    n: int, dim: int, n_steps: int, n_coef: int, obs_width: int
) -> _AugStructure:
    """Index structure of K = [[H_obs, beta E^T], [beta E, -beta^2 I]] in LAPACK gb storage.

    Unknowns: the free coefficients x_i (i = n..L-1) and the whitened control residuals y_t
    (t = 0..N-2), each y_t placed beside x at the centre of its stencil so that K is banded.
    """
    n_free = n_coef - n
    rows = control_rows(n, n_steps, n_coef)
    n_ctrl = n_steps - 1
    # ordering keys: x_i at 2 i, y_t at 2 clip(t + ceil(n / 2), n, L - 1) + 1
    x_key = np.repeat(2 * np.arange(n, n_coef), dim)
    y_key = np.repeat(2 * np.clip(np.arange(n_ctrl) + (n + 1) // 2, n, n_coef - 1) + 1, dim)
    keys = np.concatenate([x_key, y_key])
    order = np.argsort(keys, kind="stable")
    pos = np.empty_like(order)
    pos[order] = np.arange(order.size)
    x_pos, y_pos = pos[: x_key.size], pos[x_key.size :]
    size = order.size
    # tracking block entries from the lower band storage (off, col) -> (col + off, col)
    off, col = np.indices((obs_width * dim, n_free * dim))
    obs_mask = col + off < n_free * dim
    r_obs, c_obs = x_pos[(col + off)[obs_mask]], x_pos[col[obs_mask]]
    upper = obs_mask & (off > 0)
    r_up, c_up = x_pos[col[upper]], x_pos[(col + off)[upper]]
    # control entries: y_t,d with x_{t+j},d
    t, j = np.indices(rows.shape)
    i = t + j
    ok = (i >= n) & (i < n_coef)
    t, j, i = t[ok], j[ok], i[ok]
    d = np.arange(dim)
    yi = (t[:, None] * dim + d).ravel()
    xi = ((i[:, None] - n) * dim + d).ravel()
    ctrl_values = np.repeat(rows[t, j], dim)
    r_c = np.concatenate([y_pos[yi], x_pos[xi]])
    c_c = np.concatenate([x_pos[xi], y_pos[yi]])
    r_all = np.concatenate([r_obs, r_up, r_c, y_pos])
    c_all = np.concatenate([c_obs, c_up, c_c, y_pos])
    kl = int(max(np.max(r_all - c_all), 0))
    ku = int(max(np.max(c_all - r_all), 0))
    flat = (kl + ku + r_all - c_all) * size + c_all
    return _AugStructure(
        size,
        kl,
        ku,
        flat,
        obs_mask,
        upper,
        np.concatenate([ctrl_values, ctrl_values]),
        y_pos.size,
        x_pos,
        y_pos,
    )
