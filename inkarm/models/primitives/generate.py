"""Running the primitive fHMM generatively (seed 004 sec. 4, Fig. 8) and back to pen space.

:func:`sample_states` runs each chain from its prior (eq. 4) on its own, with no timing code:
the primitives fire at the learned onset rate and progress through their states, and the output
is their superposition (eq. 1 and 3), optionally with the output noise C (eq. 2).
:func:`pen_path` integrates the (de-normalised) first differences back to the pen: position
[mm] from the x, y channels, and a pressure level in [0, 1] from the pressure channel when the
model has one. The paper's scribbles (Fig. 6b, 8) are such paths from (0, 0), line thickness
showing pressure.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from inkarm.core.budget import STEPS, require
from inkarm.core.trajectory import Trajectory
from inkarm.errors import InputError
from inkarm.models.primitives.model import PrimitiveModel

SHIPPED_MODEL = Path(__file__).resolve().parents[2] / "data" / "primitives_a.npz"
"""A model shipped with inkarm: 12 primitives of 15 samples (no self loops) learned from 200 LQT
samples of the letter a in five handstyles (``inkarm primitives learn letter:a --chains 12
--states 16 --iterations 25 --no-self-loops``)."""


def sample_states(model: PrimitiveModel, n_samples: int, rng: np.random.Generator) -> np.ndarray:
    """(T, M) state of each chain, each drawn from its own Markov chain (eq. 4)."""
    if isinstance(n_samples, bool) or not isinstance(n_samples, (int, np.integer)) or n_samples < 1:
        raise InputError(f"expected a positive number of samples, got {n_samples!r}",
                         key="n_samples", value=n_samples)
    M, K = model.n_chains, model.n_states
    states = np.empty((n_samples, M), dtype=int)
    cumulative = np.cumsum(model.start, axis=1)
    states[0] = np.minimum((rng.random((M, 1)) > cumulative).sum(axis=1), K - 1)
    for t in range(1, n_samples):
        prev = states[t - 1]
        moves = rng.random(M) < model.advance[np.arange(M), prev]
        states[t] = np.where(moves, (prev + 1) % K, prev)
    return states


def outputs(model: PrimitiveModel, states: np.ndarray, rng: np.random.Generator | None = None
            ) -> np.ndarray:
    """(T, D) the output means sum_m W^m[s_t^m] (eq. 3), plus N(0, C) noise when ``rng``."""
    mean = model.W[np.arange(model.n_chains), states].sum(axis=1)
    if rng is None:
        return mean
    return mean + rng.multivariate_normal(np.zeros(model.dim), model.C, size=len(states))


def sample(model: PrimitiveModel, n_samples: int, rng: np.random.Generator,
           noise: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """(Y (T, D), states (T, M)) drawn from the model."""
    states = sample_states(model, n_samples, rng)
    return outputs(model, states, rng if noise else None), states


def pen_path(model: PrimitiveModel, Y: np.ndarray, start=(0.0, 0.0),
             pressure0: float = 0.0) -> Trajectory:
    """The pen path [mm, s] whose normalised first differences are ``Y`` (T, D).

    Channels named ``dx``, ``dy`` give the position (the first two channels otherwise); a
    ``dp`` channel gives the pressure, its level integrated from ``pressure0`` (pen up: 0) and
    clipped to [0, 1].
    """
    Y = np.asarray(Y, dtype=float)
    names = list(model.channels)
    steps = Y * model.scale
    pos = np.vstack([np.zeros(2), np.cumsum(steps[:, _xy_channels(model)], axis=0)]) + start
    t = np.arange(len(pos)) / model.rate_hz
    pressure = None
    if "dp" in names:
        level = pressure0 + np.concatenate([[0.0], np.cumsum(steps[:, names.index("dp")])])
        pressure = np.clip(level, 0.0, 1.0)
    return Trajectory(t=t, pos=pos, pressure=pressure)


def _xy_channels(model: PrimitiveModel) -> list[int]:
    """Indices of the x and y channels: those named ``dx``, ``dy``, else the first two."""
    names = model.channels
    return [names.index("dx") if "dx" in names else 0,
            names.index("dy") if "dy" in names else min(1, model.dim - 1)]


def scribble(model: PrimitiveModel, duration_s: float, seed: int = 0,
             noise: bool = False) -> tuple[Trajectory, np.ndarray]:
    """A generative scribble (Fig. 8): ``duration_s`` [s] of the model run without timing code,
    integrated to the pen from (0, 0) [mm]; returns (path, states (T, M))."""
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise InputError(f"expected a positive duration in s, got {duration_s}",
                         key="duration_s", value=duration_s)
    n = max(round(duration_s * model.rate_hz), 1)
    require(n, STEPS, f"samples of a {duration_s:g} s scribble at {model.rate_hz:g} Hz",
            key="duration_s", value=duration_s)
    rng = np.random.default_rng(seed)
    Y, states = sample(model, n, rng, noise=noise)
    return pen_path(model, Y), states


def reconstruct(model: PrimitiveModel, expectations: np.ndarray) -> np.ndarray:
    """(T, B, D) the expected output sum_m W^m <S_t^m> (eq. 3) under a posterior's (M, T, B, K)
    expectations: the reconstruction of the data from the timing code."""
    return np.einsum("mtbk,mkd->tbd", expectations, model.W)


def path_drift_mm(model: PrimitiveModel, Y: np.ndarray, mask: np.ndarray,
                  expectations: np.ndarray) -> np.ndarray:
    """(T, B, 2) the pen path minus its reconstruction's [mm], both integrated from the same
    start (channels ``dx``, ``dy``), zero past each sequence's end."""
    ix = _xy_channels(model)
    steps = (Y - reconstruct(model, expectations))[..., ix] * model.scale[ix] * mask[..., None]
    return np.cumsum(steps, axis=0)


def reconstruction_error_mm(model: PrimitiveModel, Y: np.ndarray, mask: np.ndarray,
                            expectations: np.ndarray) -> np.ndarray:
    """(B,) mean distance [mm] between each sequence's pen path and its reconstruction's
    (:func:`path_drift_mm`)."""
    drift = np.linalg.norm(path_drift_mm(model, Y, mask, expectations), axis=-1)  # (T, B)
    return (drift * mask).sum(axis=0) / mask.sum(axis=0)
