"""Figures of seed 001 sec. 5 (:mod:`inkarm.analysis.density`): target density against
curvature over time (Fig. 4), and the target-based power law on log-log axes (Fig. 5)."""

from __future__ import annotations

import numpy as np

from inkarm.analysis.density import Analysis, pointwise_curvature
from inkarm.errors import InputError
from inkarm.plots.figure import Figure, figure_of, new_axes

_EPS_MM = 1e-9


def plot_density_curvature(analysis: Analysis, ax=None) -> Figure:
    """Seed 001 Fig. 4: target density and normalised curvature against time, on ``ax`` (a
    new 8 x 3.5 in figure's when None); returns the figure."""
    ax = new_axes(ax, (8, 3.5))
    traj, bp = analysis.traj, analysis.result.breakpoints
    t = traj.t - traj.t[0]
    kappa = pointwise_curvature(traj.pos)
    cap = np.percentile(kappa, 99) or 1.0
    ax.plot(
        t,
        np.minimum(kappa, cap) / cap,
        color="0.6",
        lw=0.8,
        label="pointwise curvature (clipped at 99th pct)",
    )
    seg_t = np.repeat(t[bp], 2)[1:-1]
    scale = max(analysis.curvature.max(), _EPS_MM)
    ax.plot(
        seg_t,
        np.repeat(analysis.curvature, 2) / scale,
        color="k",
        lw=1.5,
        label="segment mean curvature",
    )
    ax.plot(
        seg_t,
        np.repeat(analysis.density, 2) / analysis.density.max(),
        "--",
        color="C3",
        lw=1.5,
        label="target density",
    )
    for tb in t[bp]:
        ax.axvline(tb, color="C0", lw=0.3, alpha=0.5)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("normalised")
    ax.set_title(
        f"compression {analysis.compression:.0%}, {analysis.result.k} segments: "
        f"correlation {analysis.correlation:.2f}"
    )
    ax.legend(loc="upper right", fontsize=7)
    return figure_of(ax)


def plot_power_law(analysis: Analysis, ax=None) -> Figure:
    """Seed 001 Fig. 5 (right): V_T against 1 / D_s on log-log axes, with the fit, on ``ax``
    (a new 4.5 x 4 in figure's when None); returns the figure. Raises :class:`InputError`
    when the analysis has no fit (all segments equally long)."""
    x, v, law = 1.0 / analysis.density, analysis.velocity, analysis.power_law
    if law is None:
        raise InputError("power law plot: no fit (all segments are equally long)")
    ax = new_axes(ax, (4.5, 4))
    ax.loglog(x, v, "o", ms=3, color="C0", label="segments")
    xs = np.geomspace(x.min(), x.max(), 50)
    ax.loglog(
        xs,
        law.gain * xs**law.gamma,
        color="C3",
        label=f"gamma = {law.gamma:.2f}, R2 = {law.r2:.2f}",
    )
    ax.set_xlabel("1 / D_s = segment length [mm]")
    ax.set_ylabel("V_T [mm/s]")
    ax.legend(fontsize=8)
    return figure_of(ax)
