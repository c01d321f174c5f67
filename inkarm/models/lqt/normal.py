"""Normal equations of the banded LQT problem, H c = A^T b, in LAPACK lower band storage
ab[off, col] = H[col + off, col].

H = control^2 (Delta^n)^T Delta^n + sum_blocks A^T P A: the control part (seed 000 eq. 9's
R = r I on u = Delta^n c / dt^n) plus the tracking part (eq. 6-7, 18-19). The free unknowns
are interleaved in time: column (i - n) D + d holds c_i,d.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from inkarm.models.lqt.problem import Block, Problem, difference, extend, merged, psd_sqrt

_EPS = np.finfo(float).eps


def band_add(ab: np.ndarray, block: Block, n: int, dim: int) -> None:
    """ab += sum_t A_t^T P_t A_t for one block."""
    n_free = ab.shape[1] // dim
    t, coef, prec = block.steps, block.coef, block.precision
    start, width = block.start, coef.shape[1]
    for j1 in range(width):
        for j2 in range(j1, width):
            w = coef[:, j1] * coef[:, j2] if width > 1 else coef[:, 0] ** 2
            if start >= 0:  # rows lo..hi-1 have c_{t+j1}, c_{t+j2} both free
                lo, hi = max(n - start - j1, 0), min(n_free + n - start - j2, t.size)
                if hi <= lo:
                    continue
                rows = slice(lo, hi)
                c0 = (start + lo + j1 - n) * dim
            else:
                rows = np.flatnonzero((t + j1 >= n) & (t + j2 - n < n_free))
                if rows.size == 0:
                    continue
                cols = (t[rows] + j1 - n) * dim
            w = w[rows]
            for d1 in range(dim):
                for d2 in range(d1 if j1 == j2 else 0, dim):
                    if prec is None and d1 != d2:
                        continue
                    val = w if prec is None else w * prec[rows, d2, d1]
                    off = (j2 - j1) * dim + d2 - d1
                    if start >= 0:
                        ab[off, c0 + d1 : c0 + d1 + dim * (hi - lo) : dim] += val
                    else:
                        ab[off, cols + d1] += val


def _rhs_add(rhs: np.ndarray, block: Block, g: np.ndarray, n: int) -> None:
    """rhs (..., n_free, D) += A^T g for rows g (..., T, D) already weighted by P_t."""
    n_free = rhs.shape[-2]
    t, coef, start = block.steps, block.coef, block.start
    for j in range(coef.shape[1]):
        if start >= 0:
            lo, hi = max(n - start - j, 0), min(n_free + n - start - j, t.size)
            if hi > lo:
                c0 = start + lo + j - n
                rhs[..., c0 : c0 + hi - lo, :] += coef[lo:hi, j, None] * g[..., lo:hi, :]
        else:
            cols = t + j - n
            ok = (cols >= 0) & (cols < n_free)
            if ok.any():
                rhs[..., cols[ok], :] += coef[ok, j, None] * g[..., ok, :]


@lru_cache(maxsize=32)
def control_rows(n: int, n_steps: int, n_coef: int) -> np.ndarray:
    """(N-1, n+1) merged Delta^n stencils of the controls u_0 .. u_{N-2}."""
    coef = merged(np.arange(n_steps - 1), difference(n), n_coef)
    coef.flags.writeable = False
    return coef


@lru_cache(maxsize=32)
def _control_band(n: int, dim: int, n_steps: int, n_coef: int) -> np.ndarray:
    """Lower band of (Delta^n)^T Delta^n (x) I_D on the free unknowns, unscaled."""
    ab = np.zeros(((n + 1) * dim, (n_coef - n) * dim))
    rows = Block(n, np.arange(n_steps - 1), control_rows(n, n_steps, n_coef), None, None)
    band_add(ab, rows, n, dim)
    ab.flags.writeable = False
    return ab


def obs_band(prob: Problem) -> np.ndarray:
    """Lower band of the tracking part sum_blocks A^T P A, bandwidth of the widest stencil."""
    width = max(b.coef.shape[1] for b in prob.blocks)
    ab = np.zeros((width * prob.dim, prob.n_free * prob.dim))
    first = prob.blocks[0]
    if len(prob.blocks) == 1 and width == 1 and first.start == 0:  # Euler, every step tracked
        count = prob.n_steps - prob.n
        rows = ab.reshape(prob.dim, prob.n_free, prob.dim)
        for off in range(prob.dim):  # ab[off, t D + d] = P_t[d + off, d]
            diagonal = np.diagonal(first.targets_precision, -off, 1, 2)
            rows[off, :count, : prob.dim - off] = np.repeat(diagonal, first.repeat, 0)[prob.n :]
        return ab
    for block in prob.blocks:
        band_add(ab, block, prob.n, prob.dim)
    return ab


def normal_band(prob: Problem, obs: np.ndarray) -> np.ndarray:
    """Lower band of the normal matrix H = control^2 (Delta^n)^T Delta^n + tracking part, in
    Fortran order (as LAPACK takes it, no copy)."""
    control = _control_band(prob.n, prob.dim, prob.n_steps, prob.n_coef)
    band = np.multiply(prob.control**2, control, order="F")
    band[: obs.shape[0]] += obs
    return band


def rhs(prob: Problem, noise: tuple | None = None) -> np.ndarray:
    """A^T b, (n_free, D); with noise (rng, K): (K, n_free, D) for perturbed targets."""
    shape = (prob.n_free, prob.dim) if noise is None else (noise[1], prob.n_free, prob.dim)
    out = np.zeros(shape)
    blocks = prob.blocks
    first = blocks[0]
    if noise is None and first.coef.shape[1] == 1 and first.start == 0:  # Euler, every step
        out[: prob.n_steps - prob.n] = first.weighted[prob.n :]  # c_t = x_t: A^T b = P_t v_t
        blocks = blocks[1:]
    for block in blocks:
        g = block.weighted
        if noise is not None:
            rng, k = noise
            # y_t ~ N(v_t, P_t^-1): P_t y_t = P_t v_t + L_t z with P_t = L_t L_t^T
            z = rng.standard_normal((block.value.shape[0], block.value.shape[1], k))
            g = g + np.swapaxes(psd_sqrt(block.precision) @ z, 0, 2).swapaxes(1, 2)
        _rhs_add(out, block, g, prob.n)
    return out


def held_targets(prob: Problem) -> bool:
    """Whether the only rows of ``prob`` track the position at every step (Euler, targets held
    or key-points one step apart, starting at rest, no velocities or references): A^T b is
    then the weighted targets P_t v_t themselves (:func:`held_rhs`)."""
    first = prob.blocks[0]
    return (len(prob.blocks) == 1 and prob.discretisation == "euler"
            and first.coef.shape[1] == 1 and first.start == 0 and prob.control_target is None)


def held_rhs(prob: Problem, weighted: np.ndarray, repeat: int) -> np.ndarray:
    """A^T b (n_free, D) of a problem of :func:`held_targets` with the targets' P_i v_i
    ``weighted`` (m, D), each held ``repeat`` steps: row t - n is P_t v_t (c_t = x_t, eq. 6),
    the rows of the tied tail 0; as :func:`rhs`, without expanding the targets first."""
    n, n_steps = prob.n, prob.n_steps
    held = weighted.repeat(repeat, axis=0)[n:] if repeat > 1 else weighted[n:]
    if prob.n_free == n_steps - n:  # at rest (L = N)
        return held
    out = np.zeros((prob.n_free, prob.dim))
    out[: n_steps - n] = held
    return out


def control_adjoint(prob: Problem, e: np.ndarray) -> np.ndarray:
    """control * (Delta^n)^T e for rows e (N-1, D) -> (n_free, D)."""
    return (prob.control if prob.n % 2 == 0 else -prob.control) * _backward(prob, e)


def _backward(prob: Problem, e: np.ndarray) -> np.ndarray:
    """(-1)^n (Delta^n)^T e, (N-1, D) -> (n_free, D): the adjoint of the forward difference is
    minus the backward difference with zero padding; the rows of the fixed c_0 .. c_{n-1} are
    dropped, those of the tied tail c_{N-1} = ... = c_{N+n-2} summed onto c_{N-1}."""
    n, n_free = prob.n, prob.n_coef - prob.n
    full = np.zeros((e.shape[0] + n, e.shape[1]))
    full[: e.shape[0]] = e
    full = differences(full, n)  # on c_n .. c_{N+n-2}
    out = full[:n_free]
    if full.shape[0] > n_free:
        out[-1] += full[n_free:].sum(axis=0)
    return out


def couplings(obs: np.ndarray) -> tuple[tuple[int, np.ndarray], ...]:
    """The non-zero sub-diagonals (off, ab[off, :-off]) of the tracking band ``obs`` (none for
    diagonal precisions held at every step, Euler): what :func:`normal_residual` multiplies."""
    return tuple((off, obs[off, :-off]) for off in range(1, obs.shape[0]) if obs[off].any())


def normal_residual(prob: Problem, obs: np.ndarray, b: np.ndarray, c: np.ndarray,
                    coupled: tuple | None = None) -> np.ndarray:
    """b - H c, with the control part computed as (Delta^n)^T (Delta^n c) from differences.

    The differences of the solution are accurate to their own size, whereas the rounded normal
    matrix loses the tracking precisions next to its control entries of size ~4^n control^2.
    b, c: (n_free, D); ``coupled``: :func:`couplings` of ``obs``, if known.
    """
    r = b - obs[0].reshape(c.shape) * c
    coupled = couplings(obs) if coupled is None else coupled
    if coupled:
        flat, hc = c.reshape(-1), np.zeros(c.size)
        for off, w in coupled:
            hc[off:] += w * flat[:-off]
            hc[:-off] += w * flat[off:]
        r -= hc.reshape(c.shape)
    gram = _gram(prob, c)
    gram *= prob.control**2 if prob.n % 2 == 0 else -(prob.control**2)
    r -= gram
    return r


def _gram(prob: Problem, c: np.ndarray) -> np.ndarray:
    """(-1)^n (Delta^n)^T Delta^n c (n_free, D) by repeated differences.

    At rest the coefficients stay at c_{N-1} beyond the tied tail, so Delta^n of them is 0
    there and the zero padding of :func:`_backward` comes for free: the rows are
    Delta^2n of c_0 .. c_{N+2n-2}, and the tail rows c_{N-1} .. c_{N+n-2} telescope into
    -Delta^(2n-1) at c_{N-1}. Delta^(2n-1): two differences, then one :func:`stencil`."""
    n, n_free, n_steps = prob.n, prob.n_coef - prob.n, prob.n_steps
    if prob.n_coef != n_steps:
        return _backward(prob, differences(extend(prob, c), n))
    ext = np.zeros((n_steps + 2 * n - 1, c.shape[1]))
    ext[n:n_steps] = c
    ext[n_steps:] = c[-1]
    lead = min(2 * n - 1, 2)
    d = stencil(differences(ext, lead), 2 * n - 1 - lead)[: n_free + 1]
    d[-1] = 0.0
    return d[1:] - d[:-1]


def stencil(a: np.ndarray, k: int) -> np.ndarray:
    """Delta^k along axis 0 of ``a`` (L, D) in one correlation with the stencil of Delta^k.

    As accurate as k repeated differences where the leading differences already took the size
    of the positions out of ``a`` (the rounding of the first two dominates: refined means within
    1e-16 of their extent of those with repeated differences, N 200-10,000, orders 3-4), in one
    NumPy call instead of k."""
    if k == 0:
        return a
    dim = a.shape[1]
    return np.correlate(a.reshape(-1), _spaced_stencil(k, dim), "valid").reshape(-1, dim)


@lru_cache(maxsize=32)
def _spaced_stencil(k: int, dim: int) -> np.ndarray:
    """difference(k) with dim - 1 zeros between its taps: Delta^k of a flattened (L, D)."""
    out = np.zeros(k * dim + 1)
    out[::dim] = difference(k)
    out.flags.writeable = False
    return out


def differences(a: np.ndarray, n: int) -> np.ndarray:
    """Delta^n along axis -2 by repeated differences (each exact to its own rounding)."""
    if a.ndim == 2:
        for _ in range(n):
            a = a[1:] - a[:-1]
        return a
    for _ in range(n):
        a = a[..., 1:, :] - a[..., :-1, :]
    return a


def precision_loss(prob: Problem, obs: np.ndarray) -> float:
    """eps * (a bound on cond of the normal matrix): about 10x the relative error of Cholesky.

    lambda_max <= 4^n control^2 + max row sum of |tracking part| (Gershgorin); lambda_min >= the
    smallest tracking precision when every step is tracked in position (Euler), else unknown.
    """
    if prob.floor <= 0:
        return np.inf
    ceiling = prob.ceiling
    if not ceiling >= 0:
        rows = np.abs(obs).sum(axis=0)
        for off in range(1, obs.shape[0]):
            rows[off:] += np.abs(obs[off, :-off])
        ceiling = rows.max()
    return _EPS * (4.0**prob.n * prob.control**2 + ceiling) / prob.floor
