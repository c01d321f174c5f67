"""A brush: the width is an inverse power of the pen speed (seed 000 sec. 4, GI sec. 5)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from inkarm.errors import InputError
from inkarm.ink.checks import WIDTH_RANGE_MM, require_opacity, require_range


@dataclass(frozen=True)
class BrushInk:
    """A brush that deposits more ink where it moves slowly: the width is an inverse power of
    the speed (GI sec. 5), clipped to the bristles' range,

        w(v) = clip(w_ref (v_ref / v)^gamma, w_min, w_max)        [mm].

    Seed 000 sec. 4 says "inversely proportional" (gamma = 1, the default) while GI sec. 5 says
    "an inverse power function" without giving the exponent; neither gives constants, and both
    diverge as v -> 0, hence the clip (a resting brush leaves a blob of width w_max).

    Attributes (each refused outside its range with an InputError keyed by the field):
        w_ref_mm: Width at the reference speed in [mm], in [0.01, 25].
        v_ref_mm_s: Reference speed in [mm/s], in [0.01, 10000].
        gamma: Exponent of the inverse power law, in [0.01, 10].
        w_min_mm, w_max_mm: Width bounds in [mm], each in [0.01, 25], w_min_mm <= w_max_mm.
        opacity: Darkness of the ink in (0, 1].
    """

    w_ref_mm: float = 1.5
    v_ref_mm_s: float = 50.0
    gamma: float = 1.0
    w_min_mm: float = 0.3
    w_max_mm: float = 4.0
    opacity: float = 0.9

    def __post_init__(self) -> None:
        for name in ("w_ref_mm", "w_min_mm", "w_max_mm"):
            require_range("BrushInk", name, getattr(self, name), WIDTH_RANGE_MM,
                           "a width [mm]")
        require_range("BrushInk", "v_ref_mm_s", self.v_ref_mm_s, (0.01, 1e4),
                       "a reference speed [mm/s]")
        require_range("BrushInk", "gamma", self.gamma, (0.01, 10.0),
                       "an exponent of the speed")
        if self.w_min_mm > self.w_max_mm:
            raise InputError(
                f"BrushInk expects w_min_mm <= w_max_mm = {self.w_max_mm}, got {self.w_min_mm}",
                key="w_min_mm", value=self.w_min_mm,
            )
        require_opacity("BrushInk", "opacity", self.opacity)

    def mark(self, force_n: float, speed_mm_s: float) -> tuple[float, float]:
        if speed_mm_s <= 0.0:
            return self.w_max_mm, self.opacity
        try:
            width = self.w_ref_mm * (self.v_ref_mm_s / speed_mm_s) ** self.gamma
        except OverflowError:  # a brush all but at rest (its low-passed speed ~1e-200 mm/s)
            width = math.inf
        return min(max(width, self.w_min_mm), self.w_max_mm), self.opacity
