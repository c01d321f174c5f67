"""A regression's ink side by side: the baseline's page, the new page and their difference
(black where both inked, red where the new page lacks the baseline's ink, blue where it has
ink the baseline lacks), cropped to the ink of both and drawn in page [mm]."""

from __future__ import annotations

import numpy as np

from inkarm.plots.figure import Figure, new_figure

INK_GREY = 230  # grey levels below this are ink (inkarm.jobs.regress.ink.INK_DARKNESS)
MISSING_RGB = (0.85, 0.1, 0.1)
EXTRA_RGB = (0.1, 0.3, 0.9)


def ink_crop(base_grey, new_grey, px_per_mm: float, margin_mm: float = 2.0):
    """The pixel box (r0, r1, c0, c1) of the ink of both pages grown by ``margin_mm``; the
    whole page when neither has ink."""
    ink = (np.asarray(base_grey) < INK_GREY) | (np.asarray(new_grey) < INK_GREY)
    rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    if rows.size == 0:
        return 0, ink.shape[0], 0, ink.shape[1]
    m = int(np.ceil(margin_mm * px_per_mm))
    return (max(rows[0] - m, 0), min(rows[-1] + 1 + m, ink.shape[0]),
            max(cols[0] - m, 0), min(cols[-1] + 1 + m, ink.shape[1]))


def difference_rgb(base_grey, new_grey) -> np.ndarray:
    """RGB image in [0, 1]: white paper, black common ink, :data:`MISSING_RGB` ink only in the
    baseline, :data:`EXTRA_RGB` ink only in the new page."""
    base, new = np.asarray(base_grey) < INK_GREY, np.asarray(new_grey) < INK_GREY
    rgb = np.ones((*base.shape, 3))
    rgb[base & new] = 0.0
    rgb[base & ~new] = MISSING_RGB
    rgb[new & ~base] = EXTRA_RGB
    return rgb


def plot_ink_comparison(base_grey, new_grey, px_per_mm: float, title: str = "",
                        fig: Figure | None = None) -> Figure:
    """Baseline, new page and difference side by side (8-bit grey pages, 255 white, of the same
    shape at ``px_per_mm``; row 0 at the top of the page). Returns the figure."""
    base_grey, new_grey = np.asarray(base_grey), np.asarray(new_grey)
    r0, r1, c0, c1 = ink_crop(base_grey, new_grey, px_per_mm)
    height_px = base_grey.shape[0]
    extent = (c0 / px_per_mm, c1 / px_per_mm, (height_px - r1) / px_per_mm,
              (height_px - r0) / px_per_mm)
    aspect = (r1 - r0) / max(c1 - c0, 1)
    fig = fig if fig is not None else new_figure((12.0, 1.2 + 3.6 * min(max(aspect, 0.3), 2.0)))
    axes = fig.subplots(1, 3, sharex=True, sharey=True)
    panels = [("baseline", base_grey[r0:r1, c0:c1]), ("new", new_grey[r0:r1, c0:c1]),
              ("difference: red missing, blue extra",
               difference_rgb(base_grey[r0:r1, c0:c1], new_grey[r0:r1, c0:c1]))]
    for ax, (name, image) in zip(axes, panels):
        if image.ndim == 2:
            ax.imshow(image, cmap="gray", vmin=0, vmax=255, extent=extent,
                      interpolation="nearest")
        else:
            ax.imshow(image, extent=extent, interpolation="nearest")
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("x [mm]")
    axes[0].set_ylabel("y [mm]")
    if title:
        fig.suptitle(title)
    return fig
