"""An ink: a stamp of constant width and opacity wherever the pen presses."""

from dataclasses import dataclass

from inkarm.errors import InputError


@dataclass(frozen=True)
class StampInk:
    width_mm: float = 0.8
    opacity: float = 0.4
    threshold_n: float = 0.05

    def __post_init__(self):
        if not 0.0 < self.opacity <= 1.0:
            raise InputError(f"expected an opacity in (0, 1], got {self.opacity}", key="opacity",
                             value=self.opacity)

    def mark(self, force_n, speed_mm_s):
        return self.width_mm, (self.opacity if force_n >= self.threshold_n else 0.0)
