"""The README's motor-primitive results (seed 004 Fig. 4, 5, 8) from the shipped model.

    python docs/primitives_figures.py [--model inkarm/data/primitives_a.npz]

Rebuilds the model's training set (200 LQT samples of the letter a in five handstyles, seed 0:
what ``inkarm primitives learn letter:a`` trains on), infers each sample's timing code with the
model, prints the reconstruction error and writes docs/img/primitives_{fig4,fig5,fig8}.png.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from inkarm.models.primitives import Batch, PrimitiveModel, e_step
from inkarm.models.primitives.generate import (
    SHIPPED_MODEL,
    reconstruct,
    reconstruction_error_mm,
    scribble,
)
from inkarm.plans.primitives_data import letter_training_set
from inkarm.plots.figure import new_figure, save_figure
from inkarm.plots.primitives import plot_primitives, plot_scribble, plot_timing

IMG = Path(__file__).resolve().parent / "img"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=SHIPPED_MODEL)
    args = parser.parse_args()
    model = PrimitiveModel.load(args.model)
    data = letter_training_set("a", 200, seed=0)
    batch = Batch.of(data.sequences)
    start = time.perf_counter()
    post = e_step(model, batch)
    S = post.expectations
    error = reconstruction_error_mm(model, batch.Y, batch.mask, S)
    recon = reconstruct(model, S)
    residual = np.sqrt(((batch.Y - recon) ** 2)[batch.mask].sum()
                       / (batch.Y ** 2)[batch.mask].sum())
    extent = np.mean([np.ptp(np.cumsum(s[:, :2] * data.scale[:2], axis=0), axis=0).max()
                      for s in data.sequences])
    print(f"E-step {time.perf_counter() - start:.1f} s; reconstruction error in pen space "
          f"{error.mean():.3f} mm mean ({np.median(error):.3f} median, {error.max():.3f} worst) "
          f"for letters {extent:.1f} mm across; velocity-space residual {residual:.3f} of the "
          f"data's RMS")
    IMG.mkdir(exist_ok=True)
    save_figure(plot_primitives(model, S, batch.mask), IMG / "primitives_fig4.png", dpi=80)
    fig = new_figure((11.0, 8.0), layout="constrained")
    for sub, b in zip(fig.subfigures(2, 1), (0, 120)):
        n = batch.lengths[b]
        plot_timing(model, data.sequences[b], S[:, :n, b], fig=sub,
                    title=f"{data.labels[b]}: error {error[b]:.2f} mm")
    save_figure(fig, IMG / "primitives_fig5.png", dpi=80)
    fig = new_figure((10.0, 5.0))
    for ax, seed in zip(fig.subplots(1, 2), (2, 3)):
        path, _ = scribble(model, 3.0, seed=seed)
        plot_scribble(path, ax=ax, title=f"scribble, 3 s, seed {seed}")
    save_figure(fig, IMG / "primitives_fig8.png", dpi=80)


if __name__ == "__main__":
    main()
