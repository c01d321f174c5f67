"""``joint_speed``: a joint faster than :data:`SPEED_TOLERANCE` times its speed limit [rad/s]
for ``watchdog_s`` in a row (the plan keeps to the limit; the tolerance is for tracking)."""

from __future__ import annotations

import numpy as np

from inkarm.control.watchdogs import WatchContext, Watched

SPEED_TOLERANCE = 1.2


class JointSpeed:
    name = "joint_speed"

    def start(self, context: WatchContext) -> None:
        self.names = context.joint_names
        self.limits = None
        if context.speed_limit is not None:
            self.limits = (SPEED_TOLERANCE * np.asarray(context.speed_limit, float)).tolist()
        self.patience = context.periods(context.config.watchdog_s)
        self.fast = 0  # periods in a row with a joint too fast

    def clear(self) -> None:
        """Every joint is below its limit this period."""
        self.fast = 0

    def check(self, watched: Watched) -> str | None:
        if self.limits is None:
            return None
        speeds = [abs(v) for v in watched.qd.tolist()]
        if all(v <= limit for v, limit in zip(speeds, self.limits)):
            self.fast = 0
            return None
        self.fast += 1
        if self.fast < self.patience:
            return None
        j = max(range(len(speeds)), key=lambda k: speeds[k] / self.limits[k])
        return (f"{self.names[j]} at {speeds[j]:.2f} rad/s, above its "
                f"{self.limits[j] / SPEED_TOLERANCE:.2f} rad/s limit")
