"""Figures of a pencil profile (seed 002 ch. 4): its histograms, its co-occurrence matrices,
and a line synthesized from it step by step (the thesis's Table 4.1)."""

from __future__ import annotations

import textwrap

import numpy as np

from inkarm.ink.pencil_profile import OFFSETS, PencilProfile
from inkarm.ink.pencil_synthesis import LineTexture
from inkarm.plots.figure import Figure, new_figure

_STEP_TITLES = ("1 fill", "2 repair", "3 blur")


def plot_pencil_profile(profile: PencilProfile, texture: LineTexture | None = None,
                        fig: Figure | None = None) -> Figure:
    """The profile's mid-line and full-line histograms, its four co-occurrence matrices
    (log scale, grey levels binned to L levels) and, when given, ``texture`` (a straight line
    synthesized from it) after each of the three synthesis steps; on ``fig`` (a new 12 x 6 in
    figure when None); returns the figure."""
    fig = new_figure((12, 6), layout="constrained") if fig is None else fig
    grid = fig.add_gridspec(2, 6, width_ratios=[2.2, 1, 1, 1, 1, 1.5])
    ax = fig.add_subplot(grid[0, 0])
    greys = np.arange(256)
    ax.fill_between(greys, profile.full_hist, step="mid", color="0.7", label="whole line")
    ax.step(greys, profile.mid_hist, where="mid", color="k", lw=1.0, label="mid-line")
    for value, style in zip((*profile.mid_range, *profile.full_range), ("-", "-", ":", ":")):
        ax.axvline(value, color="C3", lw=0.6, ls=style)
    ax.set_xlabel("grey level (paper = 255)")
    ax.set_ylabel("probability")
    ax.set_title(f"{profile.name}: width {profile.width_mm:.2f} mm", fontsize=9)
    ax.legend(fontsize=7)
    for k, (dr, dc) in enumerate(OFFSETS):
        ax = fig.add_subplot(grid[1 if k >= 2 else 0, 1 + 2 * (k % 2) : 3 + 2 * (k % 2)])
        ax.imshow(np.log10(profile.glcm[k] + 1e-6), cmap="magma", origin="upper",
                  vmin=-6, vmax=0)
        ax.set_title(f"GLCM offset ({dr}, {dc})" + (", along the line" if k == 0 else ""),
                     fontsize=8)
        ax.set_xlabel("level j", fontsize=7)
        ax.set_ylabel("level i", fontsize=7)
        ax.tick_params(labelsize=6)
    ax = fig.add_subplot(grid[1, 0])
    ax.axis("off")
    note = textwrap.fill(f"source: {profile.source or 'unknown'}", 48)
    ax.text(0, 1, f"{note}\nscan {profile.px_per_mm:.1f} px/mm, drawn at "
            f"{profile.reference_force_n:g} N, {profile.levels} levels", fontsize=7,
            va="top").set_in_layout(False)
    if texture is not None:
        images = (texture.filled / 255.0, texture.repaired / 255.0, 1.0 - texture.darkness)
        sub = grid[:, 5].subgridspec(1, 3)
        for k, (image, title) in enumerate(zip(images, _STEP_TITLES)):
            ax = fig.add_subplot(sub[0, k])
            ax.imshow(np.where(texture.mask | (k == 2), image, 1.0), cmap="gray", vmin=0,
                      vmax=1, aspect="auto", interpolation="nearest")
            ax.set_title(title, fontsize=7)
            ax.set_xticks([])
            ax.set_yticks([])
    return fig
