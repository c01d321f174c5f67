"""A felt-tip marker: no ink below a threshold force, then a line whose width grows with the
force and saturates (issue 9, "ink laid only above a force threshold, with marker width that
grows with force").

    a(F) = 0                                          for F < F_th,
    w(F) = w0 + k (1 - exp(-(F - F_th) / F0))  [mm],  a(F) = opacity   for F >= F_th.

Why a threshold: a fibre-tip nib is a compliant porous felt; ink leaves it by capillarity only
where the felt is pressed onto the paper's fibres. At a few grams-force the nib grazes the
surface and leaves a broken trace or none. People write with about 0.5 to 2.5 N at the tip, so
the default F_th = 0.08 N (about 8 grams-force) sits well below a writing force and well above
the millinewton touches of a pen settling on the page. It is a modelling choice within the
0.05 to 0.1 N that a light touch of such a marker needs, not a measured constant of one pen.

Why this width law: the width is the nib's contact patch. At the threshold the felt touches with
its tip only (width w0); more force flattens it, until the patch covers the nib's whole
chisel or bullet (w0 + k), hence a saturating law. The exponential keeps w(F) smooth and
monotone with w'(F_th) = k / F0; w(F_th) = w0, so the width is continuous where ink starts.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from inkarm.ink.checks import (
    FORCE_SCALE_RANGE_N,
    THRESHOLD_RANGE_N,
    WIDTH_RANGE_MM,
    require_opacity,
    require_range,
)


@dataclass(frozen=True)
class MarkerInk:
    """A felt-tip marker (see the module docstring for the law and why).

    Attributes (each refused outside its range with an InputError keyed by the field):
        w0_mm: Width at the threshold force in [mm], in [0.01, 25].
        k_mm: Extra width at full load in [mm], in [0, 25].
        f0_n: Force scale of the saturation in [N], in [0.001, 1000].
        opacity: Darkness of the ink in (0, 1].
        threshold_n: Least force that lays ink in [N], in [0, 100] (0: any touch inks).
    """

    w0_mm: float = 0.3
    k_mm: float = 0.5
    f0_n: float = 1.0
    opacity: float = 1.0
    threshold_n: float = 0.08

    def __post_init__(self) -> None:
        for name in ("w0_mm", "k_mm", "f0_n", "opacity", "threshold_n"):  # (Python floats: the
            value = getattr(self, name)  # pen's arithmetic in float64, whatever was given)
            if isinstance(value, numbers.Real) and not isinstance(value, bool):
                object.__setattr__(self, name, float(value))
        require_range("MarkerInk", "w0_mm", self.w0_mm, WIDTH_RANGE_MM, "a width [mm]")
        require_range("MarkerInk", "k_mm", self.k_mm, (0.0, WIDTH_RANGE_MM[1]),
                      "an extra width [mm]")
        require_range("MarkerInk", "f0_n", self.f0_n, FORCE_SCALE_RANGE_N, "a force scale [N]")
        require_opacity("MarkerInk", "opacity", self.opacity)
        require_range("MarkerInk", "threshold_n", self.threshold_n, THRESHOLD_RANGE_N,
                      "a threshold force [N]")

    def width_mm(self, force_n: float) -> float:
        """Line width in [mm] at ``force_n`` [N] >= threshold (the nib's contact patch)."""
        return self.w0_mm + self.k_mm * (1.0 - math.exp(-(force_n - self.threshold_n) / self.f0_n))

    def mark(self, force_n: float, speed_mm_s: float) -> tuple[float, float]:
        if force_n < self.threshold_n:
            return self.w0_mm, 0.0
        # width_mm inlined: called at every physics step
        return (self.w0_mm + self.k_mm * (1.0 - math.exp(-(force_n - self.threshold_n)
                                                         / self.f0_n)), self.opacity)
