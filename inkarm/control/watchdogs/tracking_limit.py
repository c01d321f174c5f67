"""``tracking_limit``: the pen farther than ``tracking_limit_mm`` from its reference in the page
plane for ``watchdog_s`` in a row."""

from __future__ import annotations

from inkarm.control.watchdogs import WatchContext, Watched


class TrackingLimit:
    name = "tracking_limit"

    def start(self, context: WatchContext) -> None:
        self.limit_mm = context.config.tracking_limit_mm
        self.window_s = context.config.watchdog_s
        self.patience = context.periods(self.window_s)
        self.far = 0  # periods in a row beyond the limit

    def check(self, watched: Watched) -> str | None:
        self.far = self.far + 1 if watched.error_mm > self.limit_mm else 0
        if self.far >= self.patience:
            return (f"pen {watched.error_mm:.1f} mm from its reference for "
                    f"{self.window_s * 1000:.0f} ms (limit {self.limit_mm:g} mm)")
        return None
