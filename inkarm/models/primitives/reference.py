"""References for the primitive fHMM's tests and benchmark.

* :func:`em_iteration_loops`: one EM iteration written as plain loops. The same mathematics as
  :mod:`.inference` and :mod:`.learning` (eq. 7-12, Gauss-Seidel over chains), but one sequence
  and one chain at a time, a log-domain forward-backward one time step at a time with NumPy
  only over the K states, and the M-step's sums accumulated sample by sample. The tests check
  that it gives the same model as the vectorised code.
* :func:`scaled_forward_backward`: the textbook scaled forward-backward of one chain,
  vectorised over sequences: the floor the benchmark measures an E-step sweep against.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from inkarm.models.primitives.model import PrimitiveModel, PrimitivesConfig


def chain_forward_backward(lh, log_stay, log_adv, log_start):
    """(gamma (T, K), expected advances (K,), occupancy before the last sample (K,), log Z) of
    one chain on one sequence of log likelihoods ``lh`` (T, K), in the log domain."""
    T, K = lh.shape
    la = np.empty((T, K))
    lb = np.zeros((T, K))
    la[0] = log_start + lh[0]
    for t in range(1, T):
        la[t] = lh[t] + np.logaddexp(la[t - 1] + log_stay, np.roll(la[t - 1] + log_adv, 1))
    for t in range(T - 1, 0, -1):
        hb = lh[t] + lb[t]
        lb[t - 1] = np.logaddexp(log_stay + hb, log_adv + np.roll(hb, -1))
    log_z = np.logaddexp.reduce(la[-1])
    gamma = np.exp(la + lb - log_z)
    adv = np.zeros(K)
    for t in range(1, T):
        adv += np.exp(la[t - 1] + log_adv + np.roll(lh[t] + lb[t], -1) - log_z)
    return gamma, adv, gamma[:-1].sum(axis=0), log_z


def scaled_forward_backward(log_h: np.ndarray, transition: np.ndarray, start: np.ndarray,
                            mask: np.ndarray):
    """(gamma, log_z, expected transition counts) of one chain, Rabiner (1989) sec. V-A.

    log_h (T, B, K) is zero at padded steps (mask (T, B) False); transition (K, K) rows = from.

        h_t = exp(log h_t - s_t),  s_t = max_k log h_t,k                                 (0)
        a_1 = pi h_1 / c_1,  a_t = (a_t-1 P) h_t / c_t,  c_t = sum_k (a_t-1 P) h_t        (1)
        b_T = 1,  b_t-1 = P (h_t b_t) / c_t                                               (2)
        gamma_t = a_t b_t,  log Z = sum_t log c_t + s_t                                   (3)
        sum_t xi_t(i, j) = P_ij sum_t a_t-1,i h_t,j b_t,j / c_t                            (4)
    """
    T, B, K = log_h.shape
    shift = log_h.max(axis=-1, keepdims=True)
    h = np.exp(log_h - shift)                                               # (0)
    alpha = np.empty((T, B, K))
    beta = np.ones((T, B, K))
    c = np.empty((T, B, 1))
    alpha[0] = start * h[0]
    c[0] = alpha[0].sum(axis=-1, keepdims=True)
    alpha[0] /= c[0]
    for t in range(1, T):                                                   # (1)
        alpha[t] = (alpha[t - 1] @ transition) * h[t]
        c[t] = alpha[t].sum(axis=-1, keepdims=True)
        alpha[t] /= c[t]
    for t in range(T - 1, 0, -1):                                           # (2)
        beta[t - 1] = (h[t] * beta[t]) @ transition.T / c[t]
    gamma = alpha * beta * mask[..., None]                                  # (3)
    log_z = (np.log(c) + shift)[..., 0].sum(axis=0)
    ahead = h[1:] * beta[1:] / c[1:] * mask[1:, :, None]                    # (4)
    counts = transition * np.matmul(alpha[:-1].transpose(0, 2, 1), ahead).sum(axis=0)
    return gamma, log_z, counts


def em_iteration_loops(model: PrimitiveModel, sequences, gammas, config: PrimitivesConfig,
                       sweeps: int):
    """(new model, new gammas) after ``sweeps`` E-step sweeps and one M-step.

    ``gammas[b][m]`` is the (T_b, K) posterior of chain m on sequence b to start from.
    """
    M, K, D = model.W.shape
    P = np.linalg.inv(model.C)
    with np.errstate(divide="ignore"):
        log_stay, log_adv = np.log1p(-model.advance), np.log(model.advance)
        log_start = np.log(model.start)
    gammas = [[g.copy() for g in per_seq] for per_seq in gammas]
    counts = np.zeros((M, K))
    occupancy = np.zeros((M, K))
    for _ in range(sweeps):
        counts[:] = 0.0
        occupancy[:] = 0.0
        for m in range(M):
            Wm = model.W[m]
            PW = P @ Wm.T
            Q = Wm @ PW
            for b, Y in enumerate(sequences):
                residual = Y.copy()
                for other in range(M):
                    if other != m:
                        residual -= gammas[b][other] @ model.W[other]
                lh = residual @ PW - 0.5 * np.diag(Q)
                gamma, adv, occ, _ = chain_forward_backward(lh, log_stay[m], log_adv[m],
                                                             log_start[m])
                gammas[b][m] = gamma
                counts[m] += adv
                occupancy[m] += occ
    # M-step, sample by sample
    A = np.zeros((D, M * (K - 1)))
    G = np.zeros((M * (K - 1), M * (K - 1)))
    YY = np.zeros((D, D))
    n = 0
    for b, Y in enumerate(sequences):
        for t in range(len(Y)):
            x = np.concatenate([gammas[b][m][t, 1:] for m in range(M)])
            A += np.outer(Y[t], x)
            G += np.outer(x, x)
            YY += np.outer(Y[t], Y[t])
            n += 1
    for m in range(M):
        block = slice(m * (K - 1), (m + 1) * (K - 1))
        G[block, block] = np.diag(sum(g[m][:, 1:].sum(axis=0) for g in gammas))
    W_active = A @ np.linalg.pinv(G + config.prior_samples * np.eye(len(G)))  # (eq. 10 at 0)
    W = np.zeros_like(model.W)
    W[:, 1:] = W_active.T.reshape(M, K - 1, D)
    C = (YY - W_active @ A.T) / n
    C = 0.5 * (C + C.T)
    start = np.mean([[gammas[b][m][0] for m in range(M)] for b in range(len(sequences))], axis=0)
    advance = model.advance.copy()
    seen = occupancy > 1e-12
    advance[seen] = np.clip(counts[seen] / occupancy[seen], 0.0, 1.0)
    if not config.self_loops:
        advance[:, 1:] = 1.0
    return replace(model, W=W, C=C, start=start / start.sum(axis=1, keepdims=True),
                   advance=advance), gammas
