"""``torque_saturated``: a joint torque within 1 % of its limit [N m] for ``saturation_s`` in a
row (the arm no longer follows its commands: it is braked at once, not lifted)."""

from __future__ import annotations

import numpy as np

from inkarm.control.watchdogs import WatchContext, Watched

SATURATION = 0.99


class TorqueSaturated:
    name = "torque_saturated"

    def start(self, context: WatchContext) -> None:
        self.names = context.joint_names
        self.window_s = context.config.saturation_s
        self.patience = context.periods(self.window_s)
        self.limits = None
        if context.torque_limit is not None:
            self.limits = (SATURATION * np.asarray(context.torque_limit, float)).tolist()
        self.saturated = [0] * len(self.names)  # periods in a row at the limit, per joint
        self.any_saturated = False

    def clear(self) -> None:
        """Every joint torque is below its limit this period."""
        if self.any_saturated:
            self.saturated = [0] * len(self.names)
            self.any_saturated = False

    def check(self, watched: Watched) -> str | None:
        if self.limits is None or watched.torque is None:
            return None
        efforts = watched.torque.tolist()
        if all(abs(t) < limit for t, limit in zip(efforts, self.limits)):
            if self.any_saturated:
                self.saturated = [0] * len(self.names)
                self.any_saturated = False
            return None
        self.any_saturated = True
        self.saturated = [c + 1 if abs(t) >= limit else 0
                          for c, t, limit in zip(self.saturated, efforts, self.limits)]
        j = max(range(len(self.saturated)), key=self.saturated.__getitem__)
        if self.saturated[j] >= self.patience:
            return (f"{self.names[j]} torque at its {self.limits[j] / SATURATION:g} N m limit "
                    f"for {self.window_s * 1000:.0f} ms")
        return None
