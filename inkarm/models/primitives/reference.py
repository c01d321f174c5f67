"""One EM iteration of the primitive fHMM written as plain loops (the benchmark's reference).

The same mathematics as :mod:`.inference` and :mod:`.learning` (eq. 7-12, Gauss-Seidel over
chains, log-domain band forward-backward), but one sequence and one chain at a time, the
forward-backward one time step at a time with NumPy only over the K states, and the M-step's sums accumulated sample by sample.
The tests check that it gives the same model as the vectorised code; the benchmark times both.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from inkarm.models.primitives.model import PrimitiveModel, PrimitivesConfig


def _chain_fb(lh, log_stay, log_adv, log_start):
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
    return gamma, adv, gamma[:-1].sum(axis=0)


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
                gamma, adv, occ = _chain_fb(lh, log_stay[m], log_adv[m], log_start[m])
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
    W_active = A @ np.linalg.pinv(G)
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
