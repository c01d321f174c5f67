"""Figures of a pencil profile (seed 002 ch. 4): its histograms, its co-occurrence matrices,
and, beside the scanned line it was extracted from (the target texture), a line synthesized
from it step by step (the thesis's Table 4.1), each step with its co-occurrence distance to the
profile."""

from __future__ import annotations

import textwrap

import numpy as np

from inkarm.ink.pencil_profile import OFFSETS, PencilProfile
from inkarm.ink.pencil_synthesis import LineTexture, glcm_distance, strip_glcm
from inkarm.plots.figure import Figure, new_figure

_STEP_TITLES = ("1 fill", "2 repair", "3 smooth")


def plot_pencil_profile(profile: PencilProfile, texture: LineTexture | None = None,
                        fig: Figure | None = None, target: np.ndarray | None = None) -> Figure:
    """The profile's mid-line and full-line histograms, its four co-occurrence matrices
    (log scale, grey levels binned to L levels) and, when given, ``texture`` (a straight line
    synthesized from it) after each of the three synthesis steps, titled with the L1
    co-occurrence distance d to the profile, beside ``target`` (an 8-bit grey image of a piece
    of the scanned line as long and as wide as the texture's strip, :func:`crop_line`); on
    ``fig`` (a new 13 x 6 in figure when None); returns the figure."""
    fig = new_figure((13, 6), layout="constrained") if fig is None else fig
    grid = fig.add_gridspec(2, 6, width_ratios=[2.2, 1, 1, 1, 1, 2.0])
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
        greys = (texture.filled, texture.repaired,
                 np.round(255.0 * (1.0 - texture.darkness)).astype(np.uint8))
        panels = []
        for grey, title in zip(greys, _STEP_TITLES):
            d = glcm_distance(strip_glcm(grey, texture.mask, profile.levels), profile.glcm)
            panels.append((np.where(texture.mask, grey, 255) / 255.0, f"{title}\nd = {d:.2f}"))
        if target is not None:
            panels.insert(0, (np.asarray(target) / 255.0, "scan\n(target)"))
        sub = grid[:, 5].subgridspec(1, len(panels))
        for k, (image, title) in enumerate(panels):
            ax = fig.add_subplot(sub[0, k])
            ax.imshow(image, cmap="gray", vmin=0, vmax=1, aspect="auto",
                      interpolation="nearest")
            ax.set_title(title, fontsize=7)
            ax.set_xticks([])
            ax.set_yticks([])
    return fig


def crop_line(scan: np.ndarray, length_mm: float, width_mm: float,
              px_per_mm: float) -> np.ndarray:
    """The middle ``length_mm`` x ``width_mm`` [mm] of the upright scanned line ``scan``
    (8-bit grey at ``px_per_mm`` [px/mm]), centred on the line's darkness-weighted centre
    column (paper beyond the scan's edges)."""
    scan = np.asarray(scan, dtype=np.uint8)
    rows = max(1, min(round(length_mm * px_per_mm), scan.shape[0]))
    half = max(1, round(width_mm * px_per_mm / 2.0))
    ink = 255.0 - scan.astype(float)
    centre = round(float(ink.sum(axis=0) @ np.arange(scan.shape[1])
                             / max(float(ink.sum()), 1e-12)))
    top = (scan.shape[0] - rows) // 2
    padded = np.pad(scan, ((0, 0), (half, half)), constant_values=255)
    return padded[top : top + rows, centre : centre + 2 * half + 1]
