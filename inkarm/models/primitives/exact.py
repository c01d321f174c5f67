"""Exact inference in a small primitive fHMM: the cross-product HMM (the test oracle).

The M chains of K states are one HMM over the K^M joint states, with transition matrix the
Kronecker product of the chains' matrices and Gaussian output N(sum_m W^m[s_m], C) (eq. 2-6).
A log-domain forward-backward over it gives the exact log-likelihood log p(Y) and the exact
marginals P(S_t^m = k | Y), which the structured variational posterior approximates. The cost
is O(T K^(2M)): only for small models (M = 2, K = 3 in the tests).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.special import logsumexp

from inkarm.errors import InputError
from inkarm.models.primitives.model import PrimitiveModel

MAX_JOINT_STATES = 4096


@dataclass(frozen=True, eq=False)
class ExactPosterior:
    """log p(Y) and the per-chain marginals (M, T, K) of one sequence."""

    log_likelihood: float
    marginals: np.ndarray


def joint_states(model: PrimitiveModel) -> np.ndarray:
    """(K^M, M) the state of each chain in each joint state (last chain fastest)."""
    K, M = model.n_states, model.n_chains
    if K ** M > MAX_JOINT_STATES:
        raise InputError(f"{K}^{M} joint states is more than the exact oracle's "
                         f"{MAX_JOINT_STATES}", key="model")
    return np.array(list(itertools.product(range(K), repeat=M)))


def exact_posterior(model: PrimitiveModel, Y: np.ndarray) -> ExactPosterior:
    """Exact inference for one (T, D) sequence."""
    states = joint_states(model)
    M = model.n_chains
    log_P = np.zeros((len(states), len(states)))
    log_pi = np.zeros(len(states))
    with np.errstate(divide="ignore"):
        for m in range(M):
            Pm = np.log(model.transition_matrix(m))
            log_P += Pm[states[:, m][:, None], states[:, m][None, :]]
            log_pi += np.log(model.start[m])[states[:, m]]
    means = sum(model.W[m][states[:, m]] for m in range(M))      # (J, D)
    Y = np.asarray(Y, dtype=float)
    r = Y[:, None, :] - means[None]                                # (T, J, D)
    P = np.linalg.inv(model.C)
    _, logdet = np.linalg.slogdet(model.C)
    log_b = -0.5 * (np.einsum("tjd,de,tje->tj", r, P, r) + logdet
                    + model.dim * np.log(2 * np.pi))
    T = len(Y)
    la = np.empty((T, len(states)))
    lb = np.zeros((T, len(states)))
    la[0] = log_pi + log_b[0]
    for t in range(1, T):
        la[t] = log_b[t] + logsumexp(la[t - 1][:, None] + log_P, axis=0)
    for t in range(T - 1, 0, -1):
        lb[t - 1] = logsumexp(log_P + (log_b[t] + lb[t])[None, :], axis=1)
    log_likelihood = float(logsumexp(la[-1]))
    joint = np.exp(la + lb - log_likelihood)                        # (T, J)
    K = model.n_states
    marginals = np.zeros((M, T, K))
    for m in range(M):
        for k in range(K):
            marginals[m, :, k] = joint[:, states[:, m] == k].sum(axis=1)
    return ExactPosterior(log_likelihood, marginals)


def exact_log_likelihood(model: PrimitiveModel, sequences) -> float:
    """sum_n log p(Y_n) over (T_n, D) sequences."""
    return float(sum(exact_posterior(model, Y).log_likelihood for Y in sequences))
