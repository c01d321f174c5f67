"""Pen paths as the fHMM's observations: normalised first differences at 200 Hz (seed 004 sec. 3).

The paper records x, y, pressure (and two tilt angles) at 200 Hz and trains on "the normalised
first differential", whose mean is close to zero, as the silent state 0 needs. inkarm uses x, y
and pressure:

* the path is resampled to ``rate_hz`` (linear interpolation of t [s], x, y [mm], pressure);
* pressure is the recording's own (in [0, 1]) when it has one, else the pen-down indicator
  (1 while the pen writes). The sequence is taken to start and end with the pen up (pressure 0
  before the first sample and after the last), so its pressure channel marks the pen going
  down (+1) and up (-1): every sequence has one more difference than it has samples;
* each channel is divided by its root mean square over the whole training set (``scale``
  [mm or pressure per sample], stored in the model to map generated output back to the pen).
"""

from __future__ import annotations

import numpy as np

from inkarm.core.budget import STEPS, require
from inkarm.errors import InputError

CHANNELS = ("dx", "dy", "dp")
RATE_HZ = 200.0


def first_differences(t, pos, pressure=None, rate_hz: float = RATE_HZ) -> np.ndarray:
    """(n + 1, 3) raw differences dx, dy [mm/sample] and dp [1/sample] of a path resampled to
    ``rate_hz`` [Hz] (n samples), pen up before and after (module docstring).

    Args:
        t: (N,) strictly increasing times [s].
        pos: (N, 2) positions [mm].
        pressure: (N,) in [0, 1], or None for the pen-down indicator.
    """
    t = np.asarray(t, dtype=float)
    pos = np.asarray(pos, dtype=float)
    if t.ndim != 1 or pos.shape != (len(t), 2) or len(t) < 1:
        raise InputError(f"expected t (N,) and pos (N, 2), got {t.shape} and {pos.shape}",
                         key="pos")
    if len(t) > 1 and np.any(np.diff(t) <= 0):
        raise InputError("times must increase strictly", key="t")
    n = int(np.floor((t[-1] - t[0]) * rate_hz + 1e-9)) + 1
    require(n, STEPS, f"samples of a {t[-1] - t[0]:g} s path at {rate_hz:g} Hz", key="t",
            value=float(t[-1] - t[0]))
    grid = t[0] + np.arange(n) / rate_hz
    xy = np.column_stack([np.interp(grid, t, pos[:, 0]), np.interp(grid, t, pos[:, 1])])
    if pressure is None:
        p = np.ones(len(grid))
    else:
        p = np.interp(grid, t, np.asarray(pressure, dtype=float))
    xy = np.vstack([xy[:1], xy, xy[-1:]])
    p = np.concatenate([[0.0], p, [0.0]])
    return np.column_stack([np.diff(xy, axis=0), np.diff(p)])


def normalise(sequences: list[np.ndarray]) -> tuple[list[np.ndarray], np.ndarray]:
    """(sequences / scale, scale): ``scale`` (D,) is each channel's root mean square over all
    samples (1 for a channel that is zero throughout)."""
    if not sequences:
        raise InputError("no sequences", key="sequences")
    stacked = np.vstack(sequences)
    scale = np.sqrt(np.mean(stacked ** 2, axis=0))
    scale[~(scale > 0)] = 1.0
    return [s / scale for s in sequences], scale
