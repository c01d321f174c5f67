"""Structured variational E-step of the primitive fHMM (seed 004 sec. 2.4, appendix eq. 7-9).

The posterior over the M chains is approximated by M independent HMMs (Ghahramani & Jordan's
structured approximation). Chain m is an HMM with the model's own prior (pi^m, P^m) whose
observation likelihood is the responsibility

    h_t^m = exp{ W^m C^-1 Y~_t^m - Delta^m / 2 }                  (eq. 7, W^m as rows)
    Delta^m = diag(W^m C^-1 W^mT)                                   (eq. 8)
    Y~_t^m = Y_t - sum_{l != m} W^lT <S_t^l>                        (eq. 9)

and one forward-backward pass per chain, in the log domain, gives its <S_t^m>. The band of
Fig. 3 makes each step O(K): a state is reached only from itself and from the state before it.

Choices where the paper is loose (stated here and in the README):

* Chains are updated one after another (Gauss-Seidel), each with the others' newest <S>: each
  update is then the exact maximiser of the bound F over that chain, so F never decreases
  inside an E-step. The work is vectorised over sequences and states; the chains are a
  Python loop of M (a parallel update over chains can oscillate and lower F).
* The first E-step starts, as in the paper's pseudo-code, from every chain silent; later ones
  start from the previous E-step's <S> (warm start), which with the exact M-step makes F
  non-decreasing across EM iterations.

F = E_q[log p(Y, S)] + H[q] is computed exactly for the current q (:func:`lower_bound`):

    F = sum_t E_q[log N(Y_t; mu_t, C)] - sum_{t,m} <S_t^m> . log h_t^m + sum_m log Z^m

with log Z^m chain m's normaliser. Sequences of different lengths are padded; a padded step has
log h = 0 and no weight, which leaves every posterior and normaliser exact.

Arrays are time-major: Y (T, B, D) for B sequences of up to T samples, <S> (M, T, B, K).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.errors import InputError
from inkarm.models.primitives.model import PrimitiveModel


@dataclass(frozen=True, eq=False)
class Batch:
    """Sequences padded to one array.

    Attributes:
        Y: (T, B, D) observations; zero where padded.
        mask: (T, B) True at real samples.
        lengths: (B,) samples in each sequence.
    """

    Y: np.ndarray
    mask: np.ndarray
    lengths: np.ndarray

    @classmethod
    def of(cls, sequences) -> Batch:
        """Pad a list of (T_n, D) arrays (or one (T, D) array, or a (B, T, D) array)."""
        if isinstance(sequences, np.ndarray) and sequences.ndim == 3:
            sequences = list(sequences)
        elif isinstance(sequences, np.ndarray):
            sequences = [sequences]
        seqs = [np.asarray(s, dtype=float) for s in sequences]
        if not seqs:
            raise InputError("no sequences to learn from", key="sequences")
        dims = {s.shape[1] if s.ndim == 2 else -1 for s in seqs}
        if len(dims) != 1 or -1 in dims:
            raise InputError(f"expected 2-D (samples, D) sequences with one D, got shapes "
                             f"{sorted({s.shape for s in seqs})[:4]}", key="sequences")
        for i, s in enumerate(seqs):
            if s.shape[0] < 1:
                raise InputError("empty sequence", key=f"sequences[{i}]")
            if not np.all(np.isfinite(s)):
                raise InputError("holds non-finite values", key=f"sequences[{i}]")
        lengths = np.array([s.shape[0] for s in seqs])
        T, B, D = int(lengths.max()), len(seqs), dims.pop()
        Y = np.zeros((T, B, D))
        mask = np.zeros((T, B), dtype=bool)
        for b, s in enumerate(seqs):
            Y[: len(s), b] = s
            mask[: len(s), b] = True
        return cls(Y=Y, mask=mask, lengths=lengths)

    @property
    def n_obs(self) -> int:
        return int(self.lengths.sum())


@dataclass(eq=False)
class ChainPosterior:
    """What one forward-backward pass of one chain leaves behind.

    Attributes:
        gamma: (T, B, K) marginals <S_t> (zero at padded steps).
        log_h: (T, B, K) the log responsibilities it used (zero at padded steps).
        log_z: (B,) log normaliser of each sequence.
        advance_counts: (K,) expected number of i -> i+1 transitions, summed over sequences.
        occupancy: (K,) expected time in each state before a sequence's last sample.
    """

    gamma: np.ndarray
    log_h: np.ndarray
    log_z: np.ndarray
    advance_counts: np.ndarray
    occupancy: np.ndarray


def forward_backward(log_h: np.ndarray, log_stay: np.ndarray, log_advance: np.ndarray,
                     log_start: np.ndarray, mask: np.ndarray) -> ChainPosterior:
    """Log-domain forward-backward of one left-to-right chain over B sequences at once.

    Args:
        log_h: (T, B, K) log observation likelihoods, zero at padded steps.
        log_stay, log_advance: (K,) log(1 - a), log a.
        log_start: (K,) log pi.
        mask: (T, B) real samples.
    """
    T = log_h.shape[0]
    la = np.empty_like(log_h)
    lb = np.empty_like(log_h)
    stay = np.empty_like(log_h[0])
    moved = np.empty_like(log_h[0])
    # the band as two shifted views, without np.roll's allocations: state i is reached from i
    # (stay) and from i - 1 (advance), state 0 from K - 1
    np.add(log_start, log_h[0], out=la[0])
    for t in range(1, T):
        prev = la[t - 1]
        np.add(prev, log_stay, out=stay)
        np.add(prev[:, :-1], log_advance[:-1], out=moved[:, 1:])
        np.add(prev[:, -1], log_advance[-1], out=moved[:, 0])
        np.logaddexp(stay, moved, out=la[t])
        la[t] += log_h[t]
    # hb = log h_t + log beta_t: the evidence from t on, given the state at t
    lb[T - 1] = 0.0
    hb = np.empty_like(log_h[0])
    for t in range(T - 1, 0, -1):
        np.add(log_h[t], lb[t], out=hb)
        np.add(hb, log_stay, out=stay)
        np.add(hb[:, 1:], log_advance[:-1], out=moved[:, :-1])
        np.add(hb[:, 0], log_advance[-1], out=moved[:, -1])
        np.logaddexp(stay, moved, out=lb[t - 1])
    log_z = np.logaddexp.reduce(la[T - 1], axis=-1)
    K = log_h.shape[-1]
    if T > 1:
        # xi_t(i -> i+1) for the transition from t-1 to t, both inside the sequence
        ahead = np.add(log_h[1:], lb[1:])
        log_xi = np.empty_like(ahead)
        np.add(ahead[..., 1:], log_advance[:-1], out=log_xi[..., :-1])
        np.add(ahead[..., 0], log_advance[-1], out=log_xi[..., -1])
        log_xi += la[:-1]
        log_xi -= log_z[:, None]
        np.exp(log_xi, out=log_xi)
        inside = mask[1:, :, None]
        log_xi *= inside
        advance_counts = log_xi.sum(axis=(0, 1))
    else:
        advance_counts = np.zeros(K)
    gamma = np.add(la, lb, out=la)
    gamma -= log_z[:, None]
    np.exp(gamma, out=gamma)
    gamma *= mask[..., None]
    occupancy = (gamma[:-1] * mask[1:, :, None]).sum(axis=(0, 1)) if T > 1 else np.zeros(K)
    return ChainPosterior(gamma, log_h, log_z, advance_counts, occupancy)


@dataclass(eq=False)
class Posterior:
    """The structured variational posterior: one :class:`ChainPosterior` per chain."""

    chains: list[ChainPosterior]
    sweeps: int = 0

    @property
    def expectations(self) -> np.ndarray:
        """(M, T, B, K) <S_t^m>."""
        return np.stack([c.gamma for c in self.chains])

    @classmethod
    def silent(cls, model: PrimitiveModel, batch: Batch) -> Posterior:
        """Every chain in state 0 at every sample (the paper's E-step initialisation)."""
        T, B, _ = batch.Y.shape
        K = model.n_states
        chains = []
        for _ in range(model.n_chains):
            gamma = np.zeros((T, B, K))
            gamma[..., 0] = batch.mask
            chains.append(ChainPosterior(gamma, np.zeros((T, B, K)), np.zeros(B), np.zeros(K),
                                         np.zeros(K)))
        return cls(chains)


def _precision(model: PrimitiveModel) -> np.ndarray:
    return np.linalg.inv(model.C)


def e_step(model: PrimitiveModel, batch: Batch, start: Posterior | None = None,
           max_sweeps: int = 20, tol: float = 1e-4) -> Posterior:
    """Structured variational inference (eq. 7-9), Gauss-Seidel over chains.

    Sweeps until no <S> changes by more than ``tol`` or ``max_sweeps`` sweeps. ``start`` is the
    posterior to begin from (default: all chains silent).
    """
    post = Posterior.silent(model, batch) if start is None else Posterior(list(start.chains))
    P = _precision(model)
    log_stay, log_adv = model.log_transitions()
    with np.errstate(divide="ignore"):
        log_start = np.log(model.start)
    mean = sum(c.gamma @ model.W[m] for m, c in enumerate(post.chains))
    sweeps = 0
    for sweeps in range(1, max_sweeps + 1):
        change = 0.0
        for m in range(model.n_chains):
            old = post.chains[m].gamma
            new = update_chain(model, batch, m, old, mean, P, log_stay[m], log_adv[m],
                               log_start[m])
            mean += (new.gamma - old) @ model.W[m]
            change = max(change, float(np.max(np.abs(new.gamma - old))))
            post.chains[m] = new
        if change <= tol:
            break
    post.sweeps = sweeps
    return post


def log_responsibility(model: PrimitiveModel, batch: Batch, m: int, gamma: np.ndarray,
                       mean: np.ndarray, P: np.ndarray) -> np.ndarray:
    """(T, B, K) log h_t^m of eq. 7, from the full mean ``mean`` = sum_l W^l <S^l> (eq. 9 adds
    chain m's own part back)."""
    Wm = model.W[m]
    PW = P @ Wm.T                                # (D, K)
    Q = Wm @ PW                                  # (K, K) = W^m C^-1 W^mT
    log_h = (batch.Y - mean) @ PW + gamma @ Q - 0.5 * np.diag(Q)
    log_h *= batch.mask[..., None]
    return log_h


def update_chain(model, batch, m, gamma, mean, P, log_stay, log_adv, log_start) -> ChainPosterior:
    """Chain m's new posterior given the others (one step of the Gauss-Seidel sweep)."""
    log_h = log_responsibility(model, batch, m, gamma, mean, P)
    return forward_backward(log_h, log_stay, log_adv, log_start, batch.mask)


def lower_bound(model: PrimitiveModel, batch: Batch, post: Posterior) -> float:
    """The variational lower bound F <= log p(Y) for the current q (exact for q; see module)."""
    P = _precision(model)
    S = post.expectations                                  # (M, T, B, K)
    mask = batch.mask
    mean = np.einsum("mtbk,mkd->tbd", S, model.W)
    r = batch.Y - mean
    quad = np.einsum("tbd,de,tbe->tb", r, P, r)
    Q = np.einsum("mkd,de,mje->mkj", model.W, P, model.W)  # (M, K, K)
    delta = np.einsum("mkk->mk", Q)
    variance = (np.einsum("mtbk,mk->tb", S, delta)
                - np.einsum("mtbk,mkj,mtbj->tb", S, Q, S))
    D = model.dim
    _, logdet = np.linalg.slogdet(model.C)
    expected_loglik = (-0.5 * (D * np.log(2 * np.pi) + logdet) * mask
                       - 0.5 * (quad + variance) * mask).sum()
    entropy_terms = sum(float(c.log_z.sum() - (c.gamma * c.log_h).sum()) for c in post.chains)
    return float(expected_loglik + entropy_terms)
