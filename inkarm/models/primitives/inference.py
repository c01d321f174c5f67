"""Structured variational E-step of the primitive fHMM (seed 004 sec. 2.4, appendix eq. 7-9).

The posterior over the M chains is approximated by M independent HMMs (Ghahramani & Jordan's
structured approximation). Chain m is an HMM with the model's own prior (pi^m, P^m) whose
observation likelihood is the responsibility

    h_t^m = exp{ W^m C^-1 Y~_t^m - Delta^m / 2 }                  (eq. 7, W^m as rows)
    Delta^m = diag(W^m C^-1 W^mT)                                   (eq. 8)
    Y~_t^m = Y_t - sum_{l != m} W^lT <S_t^l>                        (eq. 9)

and one forward-backward pass per chain gives its <S_t^m>: scaled (Rabiner's normalisation of
alpha at every step, :func:`forward_backward`), not in the log domain, which gives the same
posteriors to rounding (tests/models/test_primitives.py) at a fraction of the cost. Each step is
one (B, K) x (K, K) product with the chain's transition matrix (Fig. 3's band, stored dense: at
K = 16 one BLAS call beats two shifted views).

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
        log_z: (B,) log normaliser of each sequence.
        advance_counts: (K,) expected number of i -> i+1 transitions, summed over sequences.
        occupancy: (K,) expected time in each state before a sequence's last sample.
        expected_log_h: sum over samples of <S_t> . log h_t, with the log responsibilities
            log h it used (the bound's entropy term; the (T, B, K) log h itself is not kept).
    """

    gamma: np.ndarray
    log_z: np.ndarray
    advance_counts: np.ndarray
    occupancy: np.ndarray
    expected_log_h: float = 0.0


def forward_backward(log_h: np.ndarray, transition: np.ndarray, start: np.ndarray,
                     mask: np.ndarray, out: np.ndarray | None = None) -> ChainPosterior:
    """Scaled forward-backward of one chain over B sequences at once (Rabiner 1989 sec. V-A).

    With h_t = exp(log h_t - s_t), s_t = max_k log h_t,k (so that h_t <= 1 cannot overflow),
    and P the chain's (K, K) transition matrix (rows = from):

        a~_1 = pi * h_1,  a~_t = (a_t-1 P) * h_t,  c_t = sum_k a~_t,  a_t = a~_t / c_t   (1)
        b_T = 1,          b_t-1 = P (h_t * b_t) / c_t                                   (2)
        <S_t> = a_t * b_t,   log Z = sum_t (log c_t + s_t)                               (3)
        sum_t xi_t(i -> j) = P_ij sum_t a_t-1,i h_t,j b_t,j / c_t                         (4)

    A padded step has log h = 0: h = 1 there, c = 1 and b = 1 (up to rounding), so it changes
    no posterior and no normaliser; (3) and (4) leave it out by the mask. Where some c_t
    underflows to 0 (the states alpha reaches all have log h_t more than ~745 below the best
    one), or b overflows, the chain is done by :func:`log_forward_backward` instead.

    Args:
        log_h: (T, B, K) log observation likelihoods, zero at padded steps.
        transition: (K, K) P of the chain (Fig. 3's band: stay or advance to the next).
        start: (K,) pi.
        mask: (T, B) real samples.
        out: (T, B, K) array to hold <S> (default: a new one).
    """
    T, B, K = log_h.shape
    shift = log_h.max(axis=-1, keepdims=True)                      # s_t, (T, B, 1)
    h = np.subtract(log_h, shift)
    np.exp(h, out=h)
    alpha = np.empty_like(h) if out is None else out
    beta = np.empty_like(h)
    c = np.empty((T, B, 1))
    ones = np.ones((K, 1))
    multiply, divide, matmul = np.multiply, np.divide, np.matmul
    with np.errstate(invalid="ignore"):                             # 0 / 0: see below
        multiply(start, h[0], out=alpha[0])
        matmul(alpha[0], ones, out=c[0])
        divide(alpha[0], c[0], out=alpha[0])
        for t in range(1, T):                                      # (1)
            a = alpha[t]
            matmul(alpha[t - 1], transition, out=a)
            multiply(a, h[t], out=a)
            matmul(a, ones, out=c[t])
            divide(a, c[t], out=a)
    if not c.min() > 0:                    # every state left has h_t = 0 to double precision
        return log_domain_pass(log_h, transition, start, mask)
    hb = divide(h, c, out=h)                                       # h_t / c_t, then * b_t
    beta[T - 1] = 1.0
    to = transition.T
    with np.errstate(over="ignore", invalid="ignore"):  # b may overflow: caught below
        for t in range(T - 1, 0, -1):                              # (2)
            multiply(hb[t], beta[t], out=hb[t])
            matmul(hb[t], to, out=beta[t - 1])
    log_z = np.log(c[..., 0]).sum(axis=0) + shift[..., 0].sum(axis=0)
    if T > 1:                                                      # (4), inside the sequences
        with np.errstate(over="ignore", invalid="ignore"):
            multiply(hb[1:], mask[1:, :, None], out=hb[1:])
            pairs = transition * np.matmul(alpha[:-1].transpose(0, 2, 1), hb[1:]).sum(axis=0)
        if not np.all(np.isfinite(pairs)):        # b overflowed where alpha had underflowed
            return log_domain_pass(log_h, transition, start, mask)
        advance_counts = pairs[np.arange(K), (np.arange(K) + 1) % K]
        occupancy = pairs.sum(axis=1)                              # = sum_t <S_t-1> inside
    else:
        advance_counts, occupancy = np.zeros(K), np.zeros(K)
    gamma = multiply(alpha, beta, out=alpha)                       # (3)
    multiply(gamma, mask[..., None], out=gamma)
    return ChainPosterior(gamma, log_z, advance_counts, occupancy, _expected(gamma, log_h))


def _expected(gamma: np.ndarray, log_h: np.ndarray) -> float:
    """sum_t <S_t> . log h_t (one pass, no temporary)."""
    return float(np.einsum("tbk,tbk->", gamma, log_h))


def log_domain_pass(log_h, transition, start, mask, out=None) -> ChainPosterior:
    """:func:`log_forward_backward` called as :func:`forward_backward` (``out`` unused)."""
    K = len(start)
    with np.errstate(divide="ignore"):
        return log_forward_backward(log_h, np.log(np.diagonal(transition)),
                                    np.log(transition[np.arange(K), (np.arange(K) + 1) % K]),
                                    np.log(start), mask)


def log_forward_backward(log_h: np.ndarray, log_stay: np.ndarray, log_advance: np.ndarray,
                         log_start: np.ndarray, mask: np.ndarray) -> ChainPosterior:
    """Log-domain forward-backward of one left-to-right chain over B sequences at once: what
    :func:`forward_backward` falls back to where its scaled alpha underflows.

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
    return ChainPosterior(gamma, log_z, advance_counts, occupancy, _expected(gamma, log_h))


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
            chains.append(ChainPosterior(gamma, np.zeros(B), np.zeros(K), np.zeros(K)))
        return cls(chains)


def _precision(model: PrimitiveModel) -> np.ndarray:
    return np.linalg.inv(model.C)


def e_step(model: PrimitiveModel, batch: Batch, start: Posterior | None = None,
           max_sweeps: int = 20, tol: float = 1e-4, chain_pass=None) -> Posterior:
    """Structured variational inference (eq. 7-9), Gauss-Seidel over chains.

    Sweeps until no <S> changes by more than ``tol`` or ``max_sweeps`` sweeps. ``start`` is the
    posterior to begin from (default: all chains silent). ``chain_pass`` is the forward-backward
    of one chain, called as :func:`forward_backward` (default: that one; the references pass
    the log-domain one).
    """
    chain_pass = forward_backward if chain_pass is None else chain_pass
    post = Posterior.silent(model, batch) if start is None else Posterior(list(start.chains))
    P = _precision(model)
    T, B, D = batch.Y.shape
    # others = [Y~_t^m, 1]: eq. 9's residual of the chain being updated, with the mask as a last
    # column that carries the constant term of eq. 7 (so that log h is exactly 0 where padded)
    others = np.empty((T, B, D + 1))
    others[..., D] = batch.mask
    own = [c.gamma @ model.W[m] for m, c in enumerate(post.chains)]     # W^mT <S_t^m>
    residual = batch.Y - sum(own)                                       # Y_t - mu_t
    transitions = [model.transition_matrix(m) for m in range(model.n_chains)]
    scratch = np.empty((min(T, _BLOCK), B, model.n_states))
    log_h = np.empty((T, B, model.n_states))                            # one chain's at a time
    spare = None                 # the <S> array of a posterior this E-step made, then replaced
    sweeps = 0
    for sweeps in range(1, max_sweeps + 1):
        change = 0.0
        for m in range(model.n_chains):
            np.add(residual, own[m], out=others[..., :D])                   # eq. 9
            log_responsibility(model, m, others, P, out=log_h)
            new = chain_pass(log_h, transitions[m], model.start[m], batch.mask, spare)
            own[m] = new.gamma @ model.W[m]
            np.subtract(others[..., :D], own[m], out=residual)
            change = max(change, _largest_change(new.gamma, post.chains[m].gamma, scratch))
            spare = post.chains[m].gamma if sweeps > 1 else None
            post.chains[m] = new
        if change <= tol:
            break
    post.sweeps = sweeps
    return post


_BLOCK = 32
"""Time steps of <S> compared at once by :func:`_largest_change` (a block stays in cache)."""


def _largest_change(new: np.ndarray, old: np.ndarray, scratch: np.ndarray) -> float:
    """max |new - old| over (T, B, K) arrays, a block of time steps at a time."""
    largest = 0.0
    for t in range(0, len(new), len(scratch)):
        step = np.subtract(new[t:t + len(scratch)], old[t:t + len(scratch)],
                           out=scratch[:len(new[t:t + len(scratch)])])
        largest = max(largest, float(step.max()), -float(step.min()))
    return largest


def log_responsibility(model: PrimitiveModel, m: int, others: np.ndarray, P: np.ndarray,
                       out: np.ndarray | None = None) -> np.ndarray:
    """(T, B, K) log h_t^m of eq. 7-8 from ``others`` (T, B, D + 1) = [Y~_t^m, mask_t]: one
    product with [C^-1 W^mT; -Delta^m / 2], zero at padded steps."""
    Wm = model.W[m]
    PW = P @ Wm.T                                              # (D, K)
    delta = (Wm * PW.T).sum(axis=1)                            # eq. 8
    return np.matmul(others, np.vstack([PW, -0.5 * delta]), out=out)


def lower_bound(model: PrimitiveModel, batch: Batch, post: Posterior) -> float:
    """The variational lower bound F <= log p(Y) for the current q (exact for q; see module).

    Under q the chains are independent and each is in one state at a time, so with mu_t =
    sum_m W^mT <S_t^m> and Q^m = W^m C^-1 W^mT, E_q[(Y_t - mu)^T C^-1 (Y_t - mu)] =
    r_t^T C^-1 r_t + sum_m (<S_t^m> . diag Q^m - <S_t^m>^T Q^m <S_t^m>), r_t = Y_t - mu_t.
    Every term is zero at a padded step (Y, <S> and log h are zero there).
    """
    P = _precision(model)
    r = batch.Y - sum(c.gamma @ model.W[m] for m, c in enumerate(post.chains))
    quad = float(np.sum((r @ P) * r))
    variance = 0.0
    for m, c in enumerate(post.chains):
        Q = model.W[m] @ P @ model.W[m].T
        variance += float(np.sum(c.gamma @ np.diag(Q)) - np.sum((c.gamma @ Q) * c.gamma))
    _, logdet = np.linalg.slogdet(model.C)
    expected_loglik = (-0.5 * (model.dim * np.log(2 * np.pi) + logdet) * batch.n_obs
                       - 0.5 * (quad + variance))
    entropy_terms = sum(float(c.log_z.sum()) - c.expected_log_h for c in post.chains)
    return float(expected_loglik + entropy_terms)
