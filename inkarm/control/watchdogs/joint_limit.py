"""``joint_limit``: a joint outside its range (the robot profile's, [rad])."""

from __future__ import annotations

import numpy as np

from inkarm.control.watchdogs import WatchContext, Watched


class JointLimit:
    name = "joint_limit"

    def start(self, context: WatchContext) -> None:
        self.names = context.joint_names
        self.bounds = None
        if context.joint_range is not None:
            lower, upper = np.asarray(context.joint_range, dtype=float).T
            # (Python floats: on 7 joints cheaper than numpy's per-call cost, every period)
            self.bounds = tuple(zip(lower.tolist(), upper.tolist()))

    def clear(self) -> None:
        """Every joint is strictly inside its range this period (nothing to count)."""

    def check(self, watched: Watched) -> str | None:
        if self.bounds is None:
            return None
        for j, (a, (lo, hi)) in enumerate(zip(watched.q.tolist(), self.bounds)):
            if not lo <= a <= hi:
                return (f"{self.names[j]} at {np.rad2deg(a):.1f} deg, outside its range "
                        f"[{np.rad2deg(lo):g}, {np.rad2deg(hi):g}] deg")
        return None
