"""Learning the primitive fHMM by EM (seed 004 sec. 3 and appendix eq. 10-12).

Initialisation (sec. 3): each W^m row drawn from a zero-mean Gaussian with the data's
per-dimension variance; C the data's covariance; onset probability a_0 = N / T (N sequences,
T samples in all: each primitive expected once per sequence); pi^m puts 1 - N/T on the
silent state and spreads N/T over the active ones (a sequence may begin inside a primitive);
an active state lingers with probability ``stay_init`` (or never, without self loops).

M-step, given the E-step's <S> (sums run over every real sample of every sequence):

    W <- (sum_t Y_t <S_t>^T) (sum_t <S_t S_t^T> + lambda I)^-1      (eq. 10')
    pi^m <- <S_1^m>,  P_ij^m <- sum_t <S_t,i S_t-1,j> / sum_t <S_t-1,j>   (eq. 11)
    C <- (1/T) sum_t Y_t Y_t^T - (1/T) sum_t W <S_t> Y_t^T          (eq. 12)

Eq. 10 solves for all chains together. Under q the chains are independent, so the off-diagonal
blocks of <S S^T> are <S^m><S^l>^T, and a chain's own block is diag(<S^m>) (one state at a
time). The silent state's column is left out of the solve (its mean stays zero). Eq. 10' is
eq. 10 under a prior on each active state's mean, N(0, C / lambda) (lambda = ``prior_samples``:
as if each state were seen lambda more times at zero): the paper's pseudo-inverse (lambda = 0)
leaves W free where G is singular (a state never visited, chains that always move together) and,
where a state's occupancy is tiny, makes its mean a ratio of two tiny sums that the rounding of
the forward-backward decides (runs then part from the second iteration). Given the new W, eq.
12 is still C's maximiser when the prior's normaliser (lambda per state against T samples) is
left out, since W (G + lambda I) W^T = W A^T; EM then raises F - (lambda/2) sum_k w_k^T
C^-1 w_k (a never-visited state's mean is zero, as with the pseudo-inverse).

Eq. 11 under the constraint of Fig. 3: only the entries the band allows have expected counts
(the others are exactly zero), so eq. 11 reduces to a_i = E[#(i -> i+1)] / E[#(visits to i
before the last sample)], a state with no visits keeping its a_i; pi is averaged over the
sequences. Eq. 12 uses the new W; its eigenvalues are floored at ``min_variance`` times the
data's mean variance (never active on data with noise; it keeps C invertible when a model fits
exactly).

Stopping (sec. 3): EM stops after ``max_outer`` iterations or when no entry of W, C or the
transition probabilities moved by more than ``tol_outer`` (W alone is not enough: C can still be
shrinking, and the bound rising, while the primitives stand still); each E-step after
``max_inner`` sweeps or when <S> moves less than ``tol_inner``
(:func:`inkarm.models.primitives.inference.e_step`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np

from inkarm.core.budget import require_memory
from inkarm.errors import InputError
from inkarm.models.primitives.inference import Batch, Posterior, e_step, lower_bound
from inkarm.models.primitives.model import PrimitiveModel, PrimitivesConfig


@dataclass(frozen=True)
class Iteration:
    """One EM iteration: its number (1-based), the bound F after its E-step, the E-step's
    sweeps, the largest change of W in its M-step, and the log prior of W (:func:`log_prior`)
    of the model its E-step used: EM never lowers ``bound + log_prior``."""

    number: int
    bound: float
    sweeps: int
    w_change: float
    log_prior: float = 0.0


@dataclass(eq=False)
class FitResult:
    """A trained model, the posterior of the training data under it (one more E-step after
    the last M-step), the history, the bound F of that final posterior and the model's log
    prior (:func:`log_prior`); EM maximises their sum, :attr:`objective`."""

    model: PrimitiveModel
    posterior: Posterior
    batch: Batch
    history: list[Iteration] = field(default_factory=list)
    final_bound: float = -np.inf
    final_log_prior: float = 0.0

    @property
    def objective(self) -> float:
        """F + log p(W): what EM raises, and what restarts and moves are compared by."""
        return self.final_bound + self.final_log_prior

    @property
    def bounds(self) -> np.ndarray:
        return np.array([it.bound for it in self.history])


def initial_model(batch: Batch, config: PrimitivesConfig, rng: np.random.Generator,
                  scale=None, rate_hz: float = 200.0, channels=()) -> PrimitiveModel:
    """The paper's initialisation (module docstring)."""
    M, K = config.n_chains, config.n_states
    Y = batch.Y[batch.mask]
    D = Y.shape[1]
    C = np.cov(Y.T, bias=True).reshape(D, D) if len(Y) > 1 else np.eye(D)
    C = _floored(C, Y, config)
    W = rng.standard_normal((M, K, D)) * np.sqrt(np.diag(C))
    W[:, 0] = 0.0
    onset = min(len(batch.lengths) / batch.n_obs, 0.5)
    advance = np.full((M, K), 1.0 - config.stay_init if config.self_loops else 1.0)
    advance[:, 0] = onset
    start = np.zeros((M, K))
    start[:, 0], start[:, 1:] = 1.0 - onset, onset / (K - 1)
    return PrimitiveModel(W=W, advance=advance, start=start, C=C, scale=scale, rate_hz=rate_hz,
                          channels=channels)


def _floored(C: np.ndarray, Y: np.ndarray, config: PrimitivesConfig) -> np.ndarray:
    """C symmetrised, its eigenvalues floored at ``min_variance`` times the mean variance of
    the data Y (N, D)."""
    mean_var = float(np.mean(np.var(Y, axis=0))) if len(Y) > 1 else 1.0
    floor = max(mean_var, 1e-12) * max(config.min_variance, 1e-12)
    C = 0.5 * (C + C.T)
    values, vectors = np.linalg.eigh(C)
    if values.min() >= floor:
        return C
    return (vectors * np.maximum(values, floor)) @ vectors.T


def m_step(model: PrimitiveModel, batch: Batch, post: Posterior,
           config: PrimitivesConfig) -> PrimitiveModel:
    """The exact maximiser of F over the parameters given q (eq. 10-12)."""
    M, K, D = model.W.shape
    mask = batch.mask
    Y = batch.Y[mask]                                        # (N, D)
    S = np.stack([c.gamma[mask][:, 1:] for c in post.chains], axis=1)  # (N, M, K-1)
    X = S.reshape(len(Y), M * (K - 1))
    A = Y.T @ X                                              # sum_t Y_t <S_t>^T
    G = X.T @ X                                              # products of independent chains
    occupancy = X.sum(axis=0)
    for m in range(M):
        block = slice(m * (K - 1), (m + 1) * (K - 1))
        G[block, block] = np.diag(occupancy[block])          # one state at a time
    lam = config.prior_samples
    G[np.diag_indices_from(G)] += lam                        # the prior on W (eq. 10')
    W_active = (np.linalg.solve(G, A.T) if lam > 0           # = A (G + lambda I)^-1
                else np.linalg.lstsq(G, A.T, rcond=None)[0]).T   # = A G^+ (minimum norm)
    W = np.zeros_like(model.W)
    W[:, 1:] = W_active.T.reshape(M, K - 1, D)
    C = _floored((Y.T @ Y - W_active @ A.T) / len(Y), Y, config)

    starts = batch.lengths > 0
    start = np.stack([c.gamma[0][starts].mean(axis=0) for c in post.chains])
    start /= start.sum(axis=1, keepdims=True)
    advance = model.advance.copy()
    for m, c in enumerate(post.chains):
        seen = c.occupancy > 1e-12
        advance[m, seen] = np.clip(c.advance_counts[seen] / c.occupancy[seen], 0.0, 1.0)
    if not config.self_loops:
        advance[:, 1:] = 1.0
    return replace(model, W=W, C=C, start=start, advance=advance)


def log_prior(model: PrimitiveModel, config: PrimitivesConfig) -> float:
    """log p(W) up to its normaliser: -(lambda/2) sum over active states of w^T C^-1 w, with
    lambda = ``config.prior_samples`` (eq. 10')."""
    W = model.W[:, 1:].reshape(-1, model.dim)
    return -0.5 * config.prior_samples * float(np.sum(W.T * np.linalg.solve(model.C, W.T)))


def fit(sequences, config: PrimitivesConfig | None = None, *, seed: int = 0,
        restarts: int = 1, model: PrimitiveModel | None = None, scale=None,
        rate_hz: float = 200.0, channels=(),
        progress: Callable[[int, Iteration], None] | None = None) -> FitResult:
    """Learn primitives from ``sequences`` ((T_n, D) arrays) by EM.

    EM finds a local optimum; ``restarts`` runs it from that many random initialisations
    (seeds ``seed``, ``seed + 1``, ...) and keeps the one with the highest F + log p(W)
    (:attr:`FitResult.objective`: what EM raises).

    Args:
        config: Sizes and stopping rules (default :class:`PrimitivesConfig`).
        seed: Seed of the initial primitives (``numpy.random.default_rng``).
        restarts: Number of random initialisations (ignored when ``model`` is given).
        model: Start from this model instead of the paper's initialisation.
        scale, rate_hz, channels: Stored in the model (see :class:`PrimitiveModel`).
        progress: Called as ``progress(restart, iteration)`` after each EM iteration.
    """
    config = PrimitivesConfig() if config is None else config
    batch = sequences if isinstance(sequences, Batch) else Batch.of(sequences)
    if isinstance(restarts, bool) or not isinstance(restarts, (int, np.integer)) or restarts < 1:
        raise InputError(f"expected an integer >= 1, got {restarts!r}", key="restarts",
                         value=restarts)
    require_memory(em_bytes(batch, config), f"memory of EM on {len(batch.lengths)} sequences "
                   f"of up to {batch.Y.shape[0]} samples, M = {config.n_chains}, K = "
                   f"{config.n_states}", key="sequences")
    runs = []
    for restart in range(1 if model is not None else int(restarts)):
        runs.append(_fit_once(batch, config, seed + restart, model, scale, rate_hz, channels,
                              None if progress is None else partial(progress, restart)))
    return max(runs, key=lambda r: r.objective)


def em_bytes(batch: Batch, config: PrimitivesConfig) -> float:
    """Bytes EM holds at once: per chain <S> and W^mT <S^m> over the padded (T, B) grid, one
    chain's log h and forward-backward tables, the M-step's design matrix, the data, residuals."""
    T, B, D = batch.Y.shape
    M, K = config.n_chains, config.n_states
    return 8.0 * T * B * (2 * M * K + 6 * K + M * (K - 1) + M * D + 4 * D)


def _fit_once(batch, config, seed, model, scale, rate_hz, channels, progress) -> FitResult:
    if model is None:
        model = initial_model(batch, config, np.random.default_rng(seed), scale=scale,
                              rate_hz=rate_hz, channels=channels)
    post = None
    history: list[Iteration] = []
    for iteration, new, post in em_iterations(model, batch, config):
        model = new
        history.append(iteration)
        if progress is not None:
            progress(iteration)
    post = e_step(model, batch, post, config.max_inner, config.tol_inner)
    return FitResult(model=model, posterior=post, batch=batch, history=history,
                     final_bound=lower_bound(model, batch, post),
                     final_log_prior=log_prior(model, config))


def em_iterations(model: PrimitiveModel, batch: Batch, config: PrimitivesConfig,
                  chain_pass=None) -> Iterator[tuple[Iteration, PrimitiveModel, Posterior]]:
    """EM from ``model``: after each iteration, (its record, the new model, the E-step's
    posterior that made it), until ``max_outer`` iterations or the outer tolerance (module
    docstring). ``chain_pass``: the E-step's forward-backward (:func:`.inference.e_step`)."""
    post = None
    for number in range(1, config.max_outer + 1):
        post = e_step(model, batch, post, config.max_inner, config.tol_inner, chain_pass)
        bound = lower_bound(model, batch, post)
        new = m_step(model, batch, post, config)
        change = max(float(np.max(np.abs(new.W - model.W))),
                     float(np.max(np.abs(new.C - model.C))),
                     float(np.max(np.abs(new.advance - model.advance))))
        prior = log_prior(model, config)
        model = new
        yield Iteration(number, bound, post.sweeps, change, prior), model, post
        if change <= config.tol_outer:
            return
