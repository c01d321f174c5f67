"""The dense batch LQT of seed 000 sec. 3.5, as printed: the test oracle (O(N^3), small N).

    xi = S_xi xi_1 + S_u u                                                        (eq. 10-11)
    u  = (sum_i S_u^T Q_i S_u + R)^-1 sum_i S_u^T Q_i (xi_hat_i - S_xi xi_1)      (eq. 13, 19)
    Sigma_u = (sum_i S_u^T Q_i S_u + R)^-1,  Sigma_xi = S_u Sigma_u S_u^T         (eq. 14-15)

with one term Q_i, xi_hat_i per kind of target: the Gaussians (eq. 4-7; Q_t = C^T Sigma^-1 C),
key-point velocities (GI sec. 4.3) and each extra :class:`Reference` (eq. 18-19). Built straight
from the plan, independently of the banded position form in :mod:`.problem`. Two numerical
choices, neither changing the solution: eq. 13 is evaluated in its square-root form
(least squares on [Q^1/2 S_u; R^1/2], which does not square the condition number, so that it
stays an oracle at orders 6-7), and end at rest is imposed exactly, u = u_0 + Z w with Z a
null-space basis of the derivative rows of xi_N (the limit of the paper's precision 1e10).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm, lstsq, null_space, solve_triangular

from inkarm.core.plan import StrokePlan
from inkarm.models.lqt import cost
from inkarm.models.lqt.config import (
    LQTConfig,
    check_reference,
    check_stroke_ranges,
    rests_at_end,
    time_grid,
    velocity_steps,
)


def system_matrices(
    order: int, dim: int, dt: float, discretisation: str = "euler"
) -> tuple[np.ndarray, np.ndarray]:
    """Discrete A (nD, nD) and B (nD, D) of the integrator chain (eq. 3-4, or zero-order hold)."""
    n = order
    a_bar = np.kron(np.eye(n, k=1), np.eye(dim))
    b_bar = np.kron(np.eye(n)[:, -1:], np.eye(dim))
    if discretisation == "euler":
        return np.eye(n * dim) + dt * a_bar, dt * b_bar  # eq. 4
    big = np.zeros(((n + 1) * dim, (n + 1) * dim))
    big[: n * dim, : n * dim] = a_bar
    big[: n * dim, n * dim :] = b_bar
    e = expm(big * dt)
    return e[: n * dim, : n * dim], e[: n * dim, n * dim :]


def transfer_matrices(a: np.ndarray, b: np.ndarray, n_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """S_xi (N nD, nD) = [I; A; ...; A^(N-1)] and S_u (N nD, (N-1) D) with block (t, s) =
    A^(t-1-s) B for s < t (eq. 11)."""
    nd, d = b.shape
    powers = [np.eye(nd)]
    for _ in range(n_steps - 1):
        powers.append(a @ powers[-1])
    a_b = [p @ b for p in powers]  # A^k B
    s_u = np.zeros((n_steps * nd, (n_steps - 1) * d))
    for t in range(1, n_steps):
        for s in range(t):
            s_u[t * nd : (t + 1) * nd, s * d : (s + 1) * d] = a_b[t - 1 - s]
    return np.vstack(powers), s_u


def tracking_terms(stroke: StrokePlan, cfg: LQTConfig, references=()) -> list[tuple]:
    """The terms (k, steps, P (T, D, D), target (T, D)) of eq. 18: x^(k)_t tracks target_t with
    precision P_t at each of ``steps``."""
    per, n_steps = time_grid(stroke, cfg)
    if stroke.keypoints:  # GI eq. 6-7: key-point i at step i * per
        s = np.arange(len(stroke.targets))
        terms = [(0, s * per, stroke.precisions, stroke.means)]
    else:  # seed 000 eq. 6: s = {1, 1, 2, 2, ...}, each target held per steps
        s = np.arange(n_steps) // per
        terms = [(0, np.arange(n_steps), stroke.precisions[s], stroke.means[s])]
    known, steps = velocity_steps(stroke, per)
    if known.size:  # GI sec. 4.3: velocities of the key-points
        eye = np.eye(stroke.dim) / stroke.velocity_var
        terms.append((1, steps, np.broadcast_to(eye, (known.size, *eye.shape)),
                      stroke.velocities[known]))
    for i, ref in enumerate(references):
        r = check_reference(i, ref, cfg.order, stroke.dim, n_steps)
        terms.append((r.derivative, r.steps, r.precision, r.value))
    return terms


def initial_state(stroke: StrokePlan, order: int) -> np.ndarray:
    """xi_1 = (mu_1, v_1, 0, ..., 0) (nD,): at rest unless the first key-point has a velocity."""
    xi1 = np.zeros((order, stroke.dim))
    xi1[0] = stroke.means[0]
    vel = stroke.velocities
    if order > 1 and vel is not None and np.all(np.isfinite(vel[0])):
        xi1[1] = vel[0]
    return xi1.reshape(-1)


def _stacked_rows(stroke, cfg, references, s_xi, s_u, xi1):
    """[Q^1/2 S_u; R^1/2] and [Q^1/2 (xi_hat - S_xi xi_1); 0]: eq. 13 as least squares."""
    n, dim = cfg.order, stroke.dim
    nd = n * dim
    free = (s_xi @ xi1).reshape(-1, nd)  # S_xi xi_1, per step
    su = s_u.reshape(-1, nd, s_u.shape[1])
    rows, rhs = [], []
    for k, steps, precision, target in tracking_terms(stroke, cfg, references):
        sel = slice(k * dim, (k + 1) * dim)  # C: the x^(k) entries of the state
        for t, p, v in zip(steps, precision, target):
            root = _psd_root(p)  # Q_t = C^T root root^T C
            rows.append(root.T @ su[t, sel])
            rhs.append(root.T @ (v - free[t, sel]))
    r = cfg.control_weight(stroke.segment_time)
    rows.append(np.sqrt(r) * np.eye(s_u.shape[1]))  # R^1/2, R = r I (eq. 9)
    rhs.append(np.zeros(s_u.shape[1]))
    return np.vstack(rows), np.concatenate(rhs)


def _psd_root(p: np.ndarray) -> np.ndarray:
    """L with L L^T = P for a positive semi-definite P."""
    w, v = np.linalg.eigh(p)
    return v * np.sqrt(np.clip(w, 0.0, None))


def batch(stroke: StrokePlan, cfg: LQTConfig, references=(), with_cov: bool = False):
    """States xi (N, nD) in [mm], [mm/s], ... (absolute) of the optimum (eq. 10, 13) and, with
    ``with_cov``, the position covariance (N D, N D) in [mm^2] (eq. 15), else None."""
    check_stroke_ranges(stroke)
    per, n_steps = time_grid(stroke, cfg)
    n, dim = cfg.order, stroke.dim
    cost.require(
        cost.batch_bytes(n_steps, dim, n, with_cov),
        f"memory of the dense LQT oracle ({n_steps} steps x {dim}-D, order {n}; O(N^2))",
    )
    cost.require_time(
        cost.batch_seconds(n_steps, dim, with_cov),
        f"time of the dense LQT oracle ({n_steps} steps x {dim}-D; O((N D)^3))",
    )
    nd = n * dim
    a, b = system_matrices(n, dim, cfg.dt, cfg.discretisation)
    s_xi, s_u = transfer_matrices(a, b, n_steps)
    xi1 = initial_state(stroke, n)
    big_a, big_b = _stacked_rows(stroke, cfg, references, s_xi, s_u, xi1)
    basis = np.eye(s_u.shape[1])
    u = np.zeros(s_u.shape[1])
    if n > 1 and rests_at_end(stroke, cfg, per, n_steps):  # derivatives of xi_N = 0, exactly
        last = s_u[(n_steps - 1) * nd + dim :]
        target = -(s_xi @ xi1)[(n_steps - 1) * nd + dim :]
        norms = np.linalg.norm(last, axis=1)
        last, target = last / norms[:, None], target / norms
        basis, u = null_space(last), lstsq(last, target)[0]
    u = u + basis @ lstsq(big_a @ basis, big_b - big_a @ u)[0]  # eq. 13
    states = (s_xi @ xi1 + s_u @ u).reshape(n_steps, nd)  # eq. 10
    if not with_cov:
        return states, None
    _, tri = np.linalg.qr(big_a @ basis)  # Z^T (S_u^T Q S_u + R) Z = tri^T tri
    half = solve_triangular(tri, basis.T, trans="T")  # Sigma_u = half^T half (eq. 14)
    positions = s_u.reshape(n_steps, nd, -1)[:, :dim].reshape(n_steps * dim, -1)
    root = positions @ half.T
    return states, root @ root.T  # eq. 15: Sigma_x = C S_u Sigma_u S_u^T C^T
