"""Judging a primitive model on sequences it was not trained on (seed 004 sec. 4, Fig. 5-6).

The timing code of each held-out sequence is inferred by the E-step (eq. 7-9, from all chains
silent, as the paper's pseudo-code starts), the model's mean output under it

    Y^_t = sum_m W^mT <S_t^m>                                                          (eq. 3)

is de-normalised and integrated to a pen path from the sequence's own start, as the data are,
and the error is the root mean square distance between the two paths [mm]:

    e = sqrt( (1/T) sum_t || sum_{u <= t} (Y_u - Y^_u) * scale ||^2 ).

This is what ``docs/primitives_figures.py`` shows as a reconstruction; drift of the integrated
velocity counts in full.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inkarm.models.primitives.generate import path_drift_mm, reconstruct
from inkarm.models.primitives.inference import Batch, Posterior, e_step
from inkarm.models.primitives.model import PrimitiveModel


@dataclass(frozen=True, eq=False)
class Reconstruction:
    """Held-out sequences, their inferred timing and the error of each.

    Attributes:
        batch: The sequences (normalised first differences).
        posterior: The E-step's timing code.
        rms_mm: (B,) RMS distance [mm] between each pen path and its reconstruction.
        residual: Velocity-space residual, ||Y - Y^|| / ||Y|| over every sample.
    """

    batch: Batch
    posterior: Posterior
    rms_mm: np.ndarray
    residual: float


def reconstruction_rms_mm(model: PrimitiveModel, Y: np.ndarray, mask: np.ndarray,
                          expectations: np.ndarray) -> np.ndarray:
    """(B,) the RMS distance [mm] of the module docstring, from (T, B, D) data, (T, B) mask and
    (M, T, B, K) expectations."""
    drift = (path_drift_mm(model, Y, mask, expectations) ** 2).sum(axis=-1)  # (T, B)
    return np.sqrt((drift * mask).sum(axis=0) / mask.sum(axis=0))


def reconstruct_heldout(model: PrimitiveModel, sequences, max_sweeps: int = 20,
                        tol: float = 1e-4) -> Reconstruction:
    """Infer the timing of ``sequences`` ((T_n, D) arrays normalised with ``model.scale``) and
    measure each reconstruction (module docstring)."""
    batch = sequences if isinstance(sequences, Batch) else Batch.of(sequences)
    post = e_step(model, batch, None, max_sweeps, tol)
    S = post.expectations
    rms = reconstruction_rms_mm(model, batch.Y, batch.mask, S)
    r = (batch.Y - reconstruct(model, S))[batch.mask]
    residual = float(np.sqrt((r ** 2).sum() / max((batch.Y[batch.mask] ** 2).sum(), 1e-300)))
    return Reconstruction(batch, post, rms, residual)
