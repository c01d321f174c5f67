"""The outer search of primitive EM: deterministic annealing, starts from data segments, moves.

EM (:func:`inkarm.models.primitives.learning.fit`) climbs the bound F to a local optimum. With
the paper's initialisation (W^m drawn from N(0, var Y), seed 004 sec. 3) the usual optimum it
stops at has two chains sharing one primitive (each holding part of it, or shifted copies)
while another primitive is explained by none, or by pieces of several; more random starts
find the global one only by luck. Three remedies are here, each usable alone:

* **Deterministic annealing** (:func:`anneal`, Ueda & Nakano 1998), the default: EM first
  runs with the likelihood tempered, tau C in place of C for tau = 4, then 2 (5 iterations
  each), then plainly; early on the chains share every piece of data softly, so none locks
  onto a fragment before the others have taken shape.
* **Starts from data segments** (:func:`segment_model`): W^m is a window of K - 1 samples of
  the data itself, chosen as k-means++ seeds (Arthur & Vassilvitskii 2007) among windows: the
  first with probability proportional to its energy ||w||^2, each next one with probability
  proportional to its distance to the nearest chosen window over shifts,

      d(w, c) = min_{|s| <= (L-1)/2} ||w - shift_s(c)||^2.                             (1)

* **Re-seeding moves** (:func:`reseed`), split-and-merge in the sense of Ueda et al. (2000,
  SMEM) for a factorial model: the chain whose removal costs least (the weaker of the most
  similar pair: a merge; else the one that explains least energy) is replaced by the window
  of the data that the current model explains worst (a split of the residual),

      r_t = Y_t - sum_m W^mT <S_t^m>,   window = argmax_w sum_{t in w} ||r_t||^2,       (2)

  then EM runs from there, and the move is kept only if it raises F; moves are tried until
  ``moves`` have been rejected in a row, so F never decreases.

Chosen on evidence, the planted-recovery problem of tests/models/test_primitives_recovery.py (3
primitives of 8 samples, 30 sequences of 50, noise 0.2, at most 15 EM iterations), worst
correlation >= 0.9 on how many data seeds, CPU per seed on the loaded development machine:

    =====================  ==============  ==============  ==============
    search                 K = 13          K = 9           K = 13, loops
    =====================  ==============  ==============  ==============
    best of 4 random       20/20 (1.8 s)   7/12 (2.2 s)    1/12
    best of 4 segments     14/20           3/12            7/12
    1 random + 2 moves     20/20           7/12            0/12
    1 annealed             .               8/12 (0.6 s)
    best of 3 annealed     20/20 (2.2 s)   12/12 (1.9 s)   10/12 (3.2 s)
    =====================  ==============  ==============  ==============

(K = 9: no slack around the primitive; "loops": with self loops.) Data segments were worse
than random starts (the windows hold overlapping pieces), moves helped a little, annealing
most: :data:`DEFAULT` is the best of 3 annealed starts, no moves.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from inkarm.errors import InputError
from inkarm.models.primitives.generate import reconstruct
from inkarm.models.primitives.inference import Batch, e_step
from inkarm.models.primitives.learning import FitResult, Iteration, fit, initial_model, m_step
from inkarm.models.primitives.model import PrimitiveModel, PrimitivesConfig

INITS = ("random", "segments")
MAX_CANDIDATES = 4000
"""Windows drawn at random as candidates for k-means++ (bounds its cost on large data)."""


@dataclass(frozen=True)
class SearchConfig:
    """How the outer search spends its EM runs.

    Attributes:
        starts: Independent EM starts; the best by F + log p(W) is kept (and then moved).
        init: ``random`` (the paper's) or ``segments`` (windows of the data, k-means++).
        temperatures: Annealing temperatures tau > 1, hottest first, each held for
            ``anneal_iterations`` EM iterations before EM at tau = 1 (() for none).
        moves: Re-seeding moves rejected in a row before the search stops (0: none).
        move_iterations: Most EM iterations after a move before it is judged (the full
            ``max_outer`` of the EM config is then run on an accepted one).
    """

    starts: int = 3
    init: str = "random"
    temperatures: tuple[float, ...] = (4.0, 2.0)
    anneal_iterations: int = 5
    moves: int = 0
    move_iterations: int = 50

    def __post_init__(self) -> None:
        for name, low, high in (("starts", 1, 100), ("moves", 0, 100),
                                ("move_iterations", 1, 10_000)):
            value = getattr(self, name)
            if (isinstance(value, bool) or not isinstance(value, (int, np.integer))
                    or not low <= value <= high):
                raise InputError(f"expected an integer in {low}..{high}, got {value!r}",
                                 key=name, value=value)
        if isinstance(self.anneal_iterations, bool) or not isinstance(
                self.anneal_iterations, (int, np.integer)) or not 1 <= self.anneal_iterations <= 1000:
            raise InputError(f"expected an integer in 1..1000, got {self.anneal_iterations!r}",
                             key="anneal_iterations", value=self.anneal_iterations)
        temps = tuple(self.temperatures)
        if any(not (isinstance(t, (int, float)) and np.isfinite(t) and t > 1) for t in temps) \
                or list(temps) != sorted(temps, reverse=True) or len(temps) > 20:
            raise InputError(f"expected up to 20 decreasing temperatures > 1, got {temps!r}",
                             key="temperatures", value=temps)
        object.__setattr__(self, "temperatures", tuple(float(t) for t in temps))
        if self.init not in INITS:
            raise InputError(f"unknown initialisation {self.init!r}", key="init",
                             value=self.init, choices=INITS)


DEFAULT = SearchConfig()
"""The settings chosen on evidence (module docstring): 3 random starts, each annealed at
tau = 4 and 2 for 5 EM iterations, the best by F + log p(W) kept; no moves."""


def windows(batch: Batch, length: int) -> tuple[np.ndarray, np.ndarray]:
    """(W (N, length, D), where (N, 2) = (first sample, sequence)): every window of ``length``
    samples that lies inside one sequence (a sequence shorter than it gives none)."""
    D = batch.Y.shape[2]
    out, where = [], []
    for b, n in enumerate(batch.lengths):
        if n < length:
            continue
        idx = np.arange(n - length + 1)[:, None] + np.arange(length)
        out.append(batch.Y[idx, b])
        where.append(np.column_stack([idx[:, 0], np.full(len(idx), b)]))
    if not out:
        return np.zeros((0, length, D)), np.zeros((0, 2), dtype=int)
    return np.concatenate(out), np.concatenate(where)


def shift_distance(candidates: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """(N,) eq. (1): min over shifts s of ||w - shift_s(c)||^2 for each candidate window
    (N, L, D) and one chosen window c (L, D); a shift moves c by s samples, zero filled, and
    |s| <= (L - 1) / 2 (so that a shift keeps at least half of c)."""
    L = centre.shape[0]
    best = np.full(len(candidates), np.inf)
    half = (L - 1) // 2
    for s in range(-half, half + 1):
        shifted = np.zeros_like(centre)
        if s >= 0:
            shifted[s:] = centre[: L - s]
        else:
            shifted[:s] = centre[-s:]
        best = np.minimum(best, ((candidates - shifted) ** 2).sum(axis=(1, 2)))
    return best


def segment_model(batch: Batch, config: PrimitivesConfig, rng: np.random.Generator,
                  scale=None, rate_hz: float = 200.0, channels=()) -> PrimitiveModel:
    """The paper's initial model with each W^m a k-means++ window of the data (eq. 1)."""
    model = initial_model(batch, config, rng, scale=scale, rate_hz=rate_hz, channels=channels)
    M, K = config.n_chains, config.n_states
    cand, _ = windows(batch, K - 1)
    if len(cand) < M:
        return model                      # sequences too short for windows: the paper's start
    if len(cand) > MAX_CANDIDATES:
        cand = cand[rng.choice(len(cand), MAX_CANDIDATES, replace=False)]
    weight = (cand ** 2).sum(axis=(1, 2))
    W = model.W.copy()
    for m in range(M):
        total = weight.sum()
        pick = int(rng.choice(len(cand), p=weight / total)) if total > 0 else \
            int(rng.integers(len(cand)))
        W[m, 1:] = cand[pick]
        weight = np.minimum(weight, shift_distance(cand, cand[pick])) if m else \
            shift_distance(cand, cand[pick])
    return replace(model, W=W)


def chain_energy(model: PrimitiveModel, result: FitResult) -> np.ndarray:
    """(M,) the energy sum_t ||W^mT <S_t^m>||^2 each chain puts into the reconstruction."""
    S = result.posterior.expectations                              # (M, T, B, K)
    return np.array([float(((S[m] @ model.W[m]) ** 2).sum()) for m in range(model.n_chains)])


def similarity(a: np.ndarray, b: np.ndarray) -> float:
    """Largest normalised correlation of two primitives' means (L, D) over every shift."""
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    if na == 0 or nb == 0:
        return 0.0
    L = len(a)
    return max(float(np.sum(a[max(s, 0): L + min(s, 0)] * b[max(-s, 0): L - max(s, 0)]))
               for s in range(-(L - 1), L)) / (na * nb)


def removal_order(model: PrimitiveModel, result: FitResult) -> list[int]:
    """Chains in the order a move replaces them: first the weaker of each pair, most similar
    pair first (a merge), then the rest by the energy they explain, least first."""
    means = model.means()
    energy = chain_energy(model, result)
    M = model.n_chains
    pairs = sorted(((similarity(means[i], means[j]), i, j) for i in range(M)
                    for j in range(i + 1, M)), reverse=True)
    order: list[int] = []
    for _, i, j in pairs:
        weaker = i if energy[i] <= energy[j] else j
        if weaker not in order:
            order.append(weaker)
    order += [int(m) for m in np.argsort(energy) if m not in order]
    return order


def worst_window(result: FitResult, length: int, exclude: list[tuple[int, int]]) -> np.ndarray:
    """Eq. (2): the (length, D) window of the data with the most residual energy, away from
    the windows already used (``exclude``: (first sample, sequence) pairs)."""
    batch = result.batch
    r = batch.Y - reconstruct(result.model, result.posterior.expectations)
    e = (r ** 2).sum(axis=-1) * batch.mask                           # (T, B)
    c = np.vstack([np.zeros((1, e.shape[1])), np.cumsum(e, axis=0)])
    T = e.shape[0]
    length = min(length, T)
    energy = c[length:] - c[:-length]                                # (T - length + 1, B)
    valid = (np.arange(T - length + 1)[:, None] + length) <= batch.lengths[None, :]
    energy = np.where(valid, energy, -np.inf)
    for first, b in exclude:
        energy[max(first - length + 1, 0): first + length, b] = -np.inf
    first, b = np.unravel_index(int(np.argmax(energy)), energy.shape)
    exclude.append((int(first), int(b)))
    window = np.zeros((length, batch.Y.shape[2]))
    window[:] = batch.Y[first: first + length, b]
    return window


def reseed(result: FitResult, config: PrimitivesConfig, search: SearchConfig,
           progress: Callable[[str], None] | None = None) -> FitResult:
    """Re-seeding moves (module docstring) from ``result`` until ``search.moves`` are rejected
    in a row; returns the best fit (F never lower than ``result``'s)."""
    best = result
    rejected = 0
    used: list[tuple[int, int]] = []
    short = replace(config, max_outer=min(search.move_iterations, config.max_outer))
    while rejected < search.moves:
        order = removal_order(best.model, best)
        chain = order[rejected % len(order)]
        W = best.model.W.copy()
        W[chain, 1:] = worst_window(best, best.model.n_states - 1, used)
        advance = best.model.advance.copy()
        advance[chain, 0] = max(advance[chain, 0], best.model.advance[:, 0].mean())
        trial = fit(best.batch, short, model=replace(best.model, W=W, advance=advance))
        accepted = trial.objective > best.objective + 1e-6 * abs(best.objective)
        if progress is not None:
            progress(f"move: chain {chain} re-seeded, F + log p(W) {trial.objective:.6g} "
                     f"({'kept' if accepted else 'rejected'}; best {best.objective:.6g})")
        if accepted:
            best, rejected, used = trial, 0, []
        else:
            rejected += 1
    return best


def anneal(model: PrimitiveModel, batch: Batch, config: PrimitivesConfig,
           temperatures=(4.0, 2.0), iterations: int = 5) -> PrimitiveModel:
    """Deterministic annealing EM (Ueda & Nakano 1998) on the likelihood: at temperature tau
    the E-step sees tau C in place of C, which raises every responsibility h (eq. 7) to the
    power 1 / tau, since N(y; mu, C)^(1/tau) is proportional to N(y; mu, tau C); so while tau
    is high the chains share the data softly and none locks early on a piece of it. The M-step
    (eq. 10-12) is the model's own. ``iterations`` EM iterations at each temperature (hottest
    first); returns the model to start EM at tau = 1 from."""
    post = None
    for tau in temperatures:
        for _ in range(iterations):
            hot = replace(model, C=model.C * tau)
            post = e_step(hot, batch, post, config.max_inner, config.tol_inner)
            model = m_step(model, batch, post, config)
    return model


def search_fit(sequences, config: PrimitivesConfig | None = None,
               search: SearchConfig = DEFAULT, *, seed: int = 0, scale=None,
               rate_hz: float = 200.0, channels=(),
               progress: Callable[[str], None] | None = None) -> FitResult:
    """Learn primitives by EM with the outer search of ``search`` (module docstring).

    Starts ``seed``, ``seed + 1``, ... each run EM to convergence (``config``); the best by
    F + log p(W) (what EM raises) is then improved by re-seeding moves. Returns the best
    :class:`FitResult`.
    """
    config = PrimitivesConfig() if config is None else config
    batch = sequences if isinstance(sequences, Batch) else Batch.of(sequences)
    runs = []
    for start in range(search.starts):
        rng = np.random.default_rng(seed + start)
        make = segment_model if search.init == "segments" else initial_model
        model = make(batch, config, rng, scale=scale, rate_hz=rate_hz, channels=channels)

        def report(it: Iteration, start=start) -> None:
            if progress is not None:
                progress(f"start {start + 1}/{search.starts} iteration {it.number:3d}: "
                         f"bound {it.bound:.6g}, {it.sweeps} sweeps")

        model = anneal(model, batch, config, search.temperatures, search.anneal_iterations)
        runs.append(fit(batch, config, model=model, progress=lambda _, it: report(it)))
    best = max(runs, key=lambda r: r.objective)
    return reseed(best, config, search, progress) if search.moves else best

