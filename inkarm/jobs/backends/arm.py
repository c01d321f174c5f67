"""What every arm's session shares: the scenario's law, watchdogs, gains and limits executed on
its plant by the one executor (:func:`inkarm.control.executor.run_drawing`)."""

from __future__ import annotations

from inkarm.control.executor import run_drawing
from inkarm.core.log import DrawLog
from inkarm.jobs.backends import Progress


class ArmSession:
    """A session whose ``plant`` is an arm driven by the scenario's law (subclasses open the
    plant and set ``scenario``, ``drawing``, ``believed``, ``canvas``, ``senses``, ``notes``)."""

    interrupted = "interrupted by the user (Ctrl-C)"

    def execute(self, progress: Progress) -> DrawLog:
        s = self.scenario
        return run_drawing(self.drawing, self.plant, self.believed, s.robot.gains, s.controller,
                           progress=progress, speed_limits=s.robot.speed_limits, law=s.law,
                           watchdogs=s.watchdogs)

    def close(self) -> None:
        self.plant.close()


__all__ = ["ArmSession"]
