"""Ink compared as ink: how far the missing and the extra ink lie from the other drawing.

Two pages of the same size and resolution, each reduced to its ink mask M (pixels at least
:data:`INK_DARKNESS` dark). With D_A the Euclidean distance transform of the complement of M_A
(distance of every pixel to the nearest ink of A, ``scipy.ndimage.distance_transform_edt``):

    missing = max over p in M_base of D_new(p)      (baseline ink the new page lacks) [mm]
    extra   = max over p in M_new  of D_base(p)     (new ink the baseline lacks)      [mm]
    IoU     = |M_base & M_new| / |M_base | M_new|

A missing stroke on a white page changes a mean pixel difference by a fraction of a percent, but
``missing`` by the stroke's distance to the nearest remaining ink. The transforms run on the
union box of the two masks only: every ink pixel, and so every nearest ink pixel, lies in it, so
the distances are those of the whole page.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from inkarm.analysis.metrics import ink_box
from inkarm.errors import InputError

# Darkness (0 white .. 1 black) from which a pixel counts as ink: any visible mark, pencil too.
INK_DARKNESS = 0.1
_INK_GREY = 255.0 * (1.0 - INK_DARKNESS)  # the same threshold on 8-bit grey (255 white)


@dataclass(frozen=True)
class InkDifference:
    """Missing and extra ink in [mm] (see the module docstring), their overlap, and how many
    ink pixels each page has."""

    missing_mm: float
    extra_mm: float
    iou: float
    base_pixels: int
    new_pixels: int

    def metrics(self) -> dict[str, float]:
        return {"ink_missing_mm": self.missing_mm, "ink_extra_mm": self.extra_mm,
                "ink_iou": self.iou}


def ink_mask(grey) -> np.ndarray:
    """The ink mask of an 8-bit grey page (255 white, 0 black), as ``canvas.png`` stores it."""
    grey = np.asarray(grey)
    if grey.ndim != 2:
        raise InputError(f"ink_mask: expected a 2-D grey image, got shape {grey.shape}")
    return grey < _INK_GREY


def compare_ink(base_grey, new_grey, px_per_mm: float) -> InkDifference:
    """Missing ink, extra ink [mm] and IoU of ``new_grey`` against ``base_grey`` (8-bit grey
    pages of the same shape at ``px_per_mm``). A page without ink lies a page diagonal away
    from any ink of the other; two blank pages are identical (0 mm, IoU 1)."""
    base, new = ink_mask(base_grey), ink_mask(new_grey)
    if base.shape != new.shape:
        raise InputError(f"compare_ink: the pages differ in size: baseline {base.shape} px, "
                         f"new {new.shape} px (was the paper or px_per_mm changed?)")
    box = ink_box(base | new, True)
    n_base, n_new = int(base.sum()), int(new.sum())
    if box is None:
        return InkDifference(0.0, 0.0, 1.0, 0, 0)
    r0, r1, c0, c1 = box
    base, new = base[r0:r1, c0:c1], new[r0:r1, c0:c1]
    diagonal_mm = float(np.hypot(*base_grey.shape)) / px_per_mm
    missing = _farthest(base, new, px_per_mm, diagonal_mm)
    extra = _farthest(new, base, px_per_mm, diagonal_mm)
    iou = float(np.logical_and(base, new).sum() / np.logical_or(base, new).sum())
    return InkDifference(missing, extra, iou, n_base, n_new)


def _farthest(ink: np.ndarray, other: np.ndarray, px_per_mm: float, blank_mm: float) -> float:
    """Largest distance [mm] from a pixel of ``ink`` to the nearest pixel of ``other``."""
    if not ink.any():
        return 0.0
    if not other.any():
        return blank_mm
    distance = ndimage.distance_transform_edt(~other)
    return float(distance[ink].max()) / px_per_mm
