"""A watchdog: stops the run once the plant's clock passes ``after_s``."""


class StopAfter:
    name = "stop_after"

    def __init__(self, after_s: float = 1e9):
        self.after_s = after_s

    def start(self, context):
        pass

    def check(self, watched):
        if watched.time > self.after_s:
            return f"the demo plug-in stops runs after {self.after_s:g} s"
        return None
