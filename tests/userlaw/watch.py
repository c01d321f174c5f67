"""A user's own watchdog."""


class PenOffPath:
    """Stops the run when the pen is more than ``limit_mm`` from its path in the page plane."""

    name = "pen_off_path"

    def __init__(self, limit_mm: float = 1.0):
        self.limit_mm = limit_mm

    def start(self, context):
        """Once, before the first period (``context.dt``, the joint limits, ...)."""

    def check(self, watched):
        """Every period: None while all is well, else a sentence with the numbers."""
        if watched.error_mm > self.limit_mm:
            return f"the pen is {watched.error_mm:.2f} mm off its path (limit {self.limit_mm} mm)"
        return None
