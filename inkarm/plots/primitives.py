"""Figures of the motor-primitive fHMM (seed 004 Fig. 4, 5 and 8).

* :func:`plot_primitives` (Fig. 4): chosen primitives in velocity space (each channel against
  the state), in pen space (integrated from (0, 0), line width showing pressure from a
  mid-level), and the
  distribution of their onsets over the training sequences.
* :func:`plot_timing` (Fig. 5): one sequence's timing code (when each primitive is active, onsets
  marked) beside the sequence and its reconstruction from that code, in pen space.
* :func:`plot_scribble` (Fig. 8): a path drawn by the model run generatively, width = pressure.

Positions in [mm]; onset times in [s]. Every function draws on ``ax``/``fig`` when given one
and returns the Figure.
"""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection

from inkarm.core.trajectory import Trajectory
from inkarm.models.primitives.generate import pen_path, reconstruct
from inkarm.models.primitives.model import PrimitiveModel
from inkarm.plots.figure import Figure, figure_of, new_axes, new_figure


def _pressure_line(ax, path: Trajectory, color="k", width: float = 2.5, **kw) -> None:
    pos = path.pos
    if len(pos) < 2:
        return
    segments = np.stack([pos[:-1], pos[1:]], axis=1)
    p = np.ones(len(pos)) if path.pressure is None else path.pressure
    widths = 0.3 + width * 0.5 * (p[:-1] + p[1:])
    ax.add_collection(LineCollection(segments, linewidths=widths, colors=color, **kw))
    ax.update_datalim(pos)
    ax.autoscale_view()


def onset_times(expectations: np.ndarray, mask: np.ndarray, rate_hz: float) -> list[np.ndarray]:
    """Per chain, the most likely onset time [s] of each sequence where it fires (the sample
    with the largest posterior of state 1, where that exceeds 0.5), from (M, T, B, K)."""
    first = expectations[..., 1] * mask[None]
    best = first.argmax(axis=1)                      # (M, B)
    fired = first.max(axis=1) > 0.5
    return [best[m, fired[m]] / rate_hz for m in range(len(first))]


def most_used(expectations: np.ndarray, n: int) -> np.ndarray:
    """Indices of the ``n`` chains with the most expected time active."""
    active = expectations[..., 1:].sum(axis=(1, 2, 3))
    return np.argsort(-active)[:n]


def plot_primitives(model: PrimitiveModel, expectations: np.ndarray | None = None,
                    mask: np.ndarray | None = None, chains=None, fig=None) -> Figure:
    """Fig. 4: columns are primitives (``chains``, default the 6 most used, or the first 6);
    rows: velocity space, pen space from (0, 0), onset histogram (with ``expectations``
    (M, T, B, K) and ``mask`` (T, B) of the training data)."""
    if chains is None:
        chains = (most_used(expectations, 6) if expectations is not None
                  else np.arange(min(6, model.n_chains)))
    chains = list(chains)
    rows = 3 if expectations is not None else 2
    fig = fig if fig is not None else new_figure((2.4 * len(chains) + 0.6, 2.2 * rows),
                                                 layout="constrained")
    axes = np.array(fig.subplots(rows, len(chains), squeeze=False))
    onsets = onset_times(expectations, mask, model.rate_hz) if expectations is not None else None
    for col, m in enumerate(chains):
        ax = axes[0, col]
        for d, name in enumerate(model.channels):
            ax.plot(np.arange(1, model.n_states), model.W[m, 1:, d], marker=".", label=name)
        ax.axhline(0.0, color="0.7", lw=0.5)
        ax.set_title(f"primitive {m}")
        ax.set_xlabel("state")
        if col == 0:
            ax.set_ylabel("normalised velocity")
            ax.legend(fontsize=7)
        path = pen_path(model, model.W[m, 1:], pressure0=0.5)  # a change of pressure shows
        ax = axes[1, col]
        _pressure_line(ax, path)
        ax.plot(0.0, 0.0, "o", color="tab:red", ms=3)
        ax.set_aspect("equal", adjustable="datalim")
        if col == 0:
            ax.set_ylabel("pen space [mm]")
        if onsets is not None:
            ax = axes[2, col]
            if len(onsets[m]):
                ax.hist(onsets[m], bins=20, color="tab:blue")
            ax.set_xlabel("onset [s]")
            if col == 0:
                ax.set_ylabel("sequences")
    return fig


def plot_timing(model: PrimitiveModel, Y: np.ndarray, expectations: np.ndarray,
                fig=None, title: str = "") -> Figure:
    """Fig. 5 for one sequence: ``Y`` (T, D) and its posterior ``expectations`` (M, T, K).

    Left: the timing code, P(primitive m active) against time, onsets (where state 1 becomes
    the likely one) marked with triangles. Right: the sequence (grey) and its reconstruction sum_m W^m <S^m>
    (black) in pen space, each primitive's onset marked on the reconstruction."""
    fig = fig if fig is not None else new_figure((11.0, 4.0), layout="constrained")
    left, right = fig.subplots(1, 2, width_ratios=(1.3, 1.0))
    T = len(Y)
    t = np.arange(T) / model.rate_hz
    active = 1.0 - expectations[:, :T, 0]
    left.imshow(active, aspect="auto", origin="lower", cmap="Greys", vmin=0, vmax=1,
                interpolation="nearest",
                extent=(0, T / model.rate_hz, -0.5, model.n_chains - 0.5))
    onsets = []
    for m in range(model.n_chains):
        first = expectations[m, :T, 1]
        entered = (first > 0.5) & ~(np.concatenate([[0.0], first[:-1]]) > 0.5)
        for k in np.flatnonzero(entered):
            left.plot(t[k], m, "v", color="tab:red", ms=5)
            onsets.append((k, m))
    left.set_xlabel("time [s]")
    left.set_ylabel("primitive")
    left.set_title("timing code: P(active), onsets")
    data_path = pen_path(model, Y)
    recon_path = pen_path(model, reconstruct(model, expectations[:, :T, None])[:, 0])
    right.plot(*data_path.pos.T, color="0.7", lw=4, label="sample")
    _pressure_line(right, recon_path, width=1.2)
    for k, m in onsets:
        right.annotate(str(m), recon_path.pos[k], fontsize=7, color="tab:red")
    right.set_aspect("equal", adjustable="datalim")
    right.set_xlabel("x [mm]")
    right.set_ylabel("y [mm]")
    right.legend(fontsize=7, loc="best")
    right.set_title(title or "sample and reconstruction")
    return fig


def plot_scribble(path: Trajectory, ax=None, title: str = "") -> Figure:
    """Fig. 8: a generated path from (0, 0) [mm], line width showing pressure."""
    ax = new_axes(ax, (5.0, 5.0))
    _pressure_line(ax, path)
    ax.plot(*path.pos[0], "o", color="tab:red", ms=4)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(title or f"scribble, {path.duration:.1f} s")
    return figure_of(ax)
