"""Planted-primitive recovery: EM finds known shapes and onsets (seed 004, issue 13 row 2)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from inkarm.models.primitives import PrimitivesConfig, fit

N_PLANTED, LENGTH, DIM = 3, 8, 2


def planted_shapes() -> np.ndarray:
    """(3, 8, 2) three distinct smooth velocity profiles."""
    t = np.linspace(0.0, 1.0, LENGTH)
    return 2.0 * np.stack([
        np.column_stack([np.sin(np.pi * t * (m + 1)),
                         (1 if m % 2 else -1) * np.cos(np.pi * t * (m + 1.5))])
        for m in range(N_PLANTED)])


def planted_data(rng, shapes, n=30, T=50, noise=0.2):
    """Each sequence: noise plus every primitive once, at a random onset (overlaps allowed)."""
    seqs, onsets = [], []
    for _ in range(n):
        Y = rng.normal(size=(T, DIM)) * noise
        onset = rng.integers(0, T - LENGTH, size=N_PLANTED)
        for m in range(N_PLANTED):
            Y[onset[m]: onset[m] + LENGTH] += shapes[m]
        seqs.append(Y)
        onsets.append(onset)
    return seqs, np.array(onsets)


def best_window(shape: np.ndarray, learned: np.ndarray) -> tuple[float, int]:
    """(correlation, offset): the learned primitive's window of the planted length, zero padded
    at both ends, that correlates best with ``shape``; offset = its first learned sample."""
    padded = np.vstack([np.zeros((LENGTH, DIM)), learned, np.zeros((LENGTH, DIM))])
    best = (-2.0, 0)
    for offset in range(-LENGTH + 1, len(learned)):
        window = padded[offset + LENGTH: offset + 2 * LENGTH].ravel()
        norm = np.linalg.norm(window)
        if norm > 0:
            c = float(window @ shape.ravel() / (norm * np.linalg.norm(shape)))
            best = max(best, (c, offset))
    return best


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_em_recovers_planted_shapes_and_onsets(seed):
    """Chains of K = 13 states (slack of 4 around the 8-sample primitives, so a chain that
    locks on a shifted copy still holds all of it), best of 4 random starts by the bound."""
    rng = np.random.default_rng(seed)
    shapes = planted_shapes()
    seqs, onsets = planted_data(rng, shapes)
    config = PrimitivesConfig(n_chains=3, n_states=13, self_loops=False, max_outer=15)
    result = fit(seqs, config, seed=100 * seed, restarts=4)
    learned = result.model.means()
    windows = [[best_window(shapes[i], learned[j]) for j in range(3)] for i in range(3)]
    corr = np.array([[w[0] for w in row] for row in windows])
    rows, cols = linear_sum_assignment(-corr)
    assert np.all(corr[rows, cols] >= 0.9), corr[rows, cols]
    S = result.posterior.expectations                      # (M, T, B, K)
    for i, j in zip(rows, cols):
        state = 1 + windows[i][j][1]                       # chain j's state at the onset
        assert 1 <= state < config.n_states
        found = S[j, :, :, state]
        assert np.all(found.max(axis=0) > 0.5)             # fires in every sequence
        error = np.abs(np.argmax(found, axis=0) - onsets[:, i])
        assert error.max() <= 2, error
