"""``force_limit``: the low-passed pen force above ``force_limit_n`` [N]."""

from __future__ import annotations

from inkarm.control.watchdogs import WatchContext, Watched


class ForceLimit:
    name = "force_limit"

    def start(self, context: WatchContext) -> None:
        self.limit = context.config.force_limit_n

    def check(self, watched: Watched) -> str | None:
        if watched.force > self.limit:
            return f"pen force {watched.force:.2f} N above the {self.limit:g} N limit"
        return None
