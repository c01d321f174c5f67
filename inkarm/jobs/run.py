"""``run(scenario) -> Run``: draw a scenario with the simulated robot, in memory, as a pure
function.

Nothing is written: :func:`inkarm.jobs.outputs.write_run` writes the files. A Run pickles, so
regression suites and sweeps can map :func:`run` over processes or machines. It is the ``sim``
backend of the one assembly (:func:`inkarm.jobs.backends.run_backend`), which every backend
shares: place and check, open the plant, execute, catch the fault, measure, judge.
"""

from __future__ import annotations

from inkarm.jobs.backends import Progress, run_backend
from inkarm.jobs.outcome import DEGRADED, FAILED, INTERRUPTED, OK, Run, RunInterrupted
from inkarm.jobs.preflight import check
from inkarm.jobs.scenario import Scenario


def run(scenario: Scenario, progress: Progress = None) -> Run:
    """Draw ``scenario`` with the simulated robot; return the :class:`Run`, writing nothing.

    Bad settings and unreachable drawings raise before anything moves (their errors name the
    scenario file and key); a watchdog or a diverged simulation returns a Run with status
    "failed", its reason, and the partial log and canvas; a finished drawing is "ok" or
    "degraded" by the scenario's ``[judge]``; Ctrl-C raises :class:`RunInterrupted` carrying the
    partial run. ``progress(fraction, phase)`` is called during the simulation.
    """
    return run_backend("sim", scenario, progress=progress)


__all__ = ["DEGRADED", "FAILED", "INTERRUPTED", "OK", "Run", "RunInterrupted", "check", "run"]
