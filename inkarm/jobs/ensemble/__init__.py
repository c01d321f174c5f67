"""``run_ensemble(scenario, seeds) -> list[Run]``: one scenario on an ensemble of plants, as
batched MuJoCo simulations, one share of the members per CPU.

Member k is the scenario with ``plant.seed = seeds[k]``: its plant truth realised from that seed
(the ``[plant.random]`` ranges), exactly what :func:`inkarm.jobs.run.run` would simulate for
``scenario.with_overrides({"plant.seed": seeds[k]})``. Every member is a member of one
execution of :func:`inkarm.control.executor.execute`, the executor of every run: the plan and
the feed-forward along it depend only on the nominal model, so they are computed once, and each
member runs the scenario's law, watchdogs and force loop on its own plant. Where the members can
share one batched simulation (:func:`batch_refusal`: a law that sends position goals, robots
driven by the profile's ``[drive]`` gains, plant truths whose run-time part is the same in every
member and has no series elasticity or backlash), their models step together in
:class:`inkarm.sim.batch.BatchPlant` (``mujoco.batch``); otherwise (a torque law, servo
firmware, transmissions) each member is executed as a batch of one
(:func:`inkarm.jobs.run.run`). The controller, the inking and the metrics are Python on one
core, so the members are split into one contiguous share per CPU (``processes``), each share in
a kept worker process (:mod:`inkarm.jobs.ensemble.workers`), its Runs streamed back in member
order; ``processes=1`` runs one share in this process, on ``nthread`` MuJoCo threads (as
does a daemonic process, such as a pool's worker, which may not start processes).

The Runs equal those of :func:`run` member by member: same status, reason, log rows, metrics
and ink (bit for bit in the tests), whatever the shares (a member's simulation does not depend
on the others', and its controller is the same code on the same numbers). ``log.wall_s`` of a
batched member is its share's wall time divided by the number of members (the shares run at
once, so each Run's real-time factor is about the ensemble's aggregate one). Ctrl-C stops the
whole ensemble, every share (a plain KeyboardInterrupt: no partial Runs are kept). A page that
nothing kept of a member's Run (``keep`` returned a summary) is blanked in its inked box and
inked again for the next member of the share, instead of a new one (:func:`_blank_again`).
"""

from __future__ import annotations

import dataclasses
import pickle
import sys
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import numpy as np

from inkarm.control.executor import execute
from inkarm.core.budget import require_memory
from inkarm.core.trajectory import Drawing
from inkarm.errors import InkarmError, InputError, RunFault
from inkarm.ink.canvas import Canvas, require_raster_memory
from inkarm.jobs.calibration import believed_model
from inkarm.jobs.ensemble.workers import available_cpus, may_start_workers, stream_shares
from inkarm.jobs.outcome import Run, failed_run, finished_run
from inkarm.jobs.preflight import placed_within_budget, simulated_seconds, substeps
from inkarm.jobs.run import run
from inkarm.jobs.scenario import Scenario
from inkarm.sim.batch import BatchPlant, check_batchable, member_model
from inkarm.sim.batch_members import BatchMembers
from inkarm.sim.cell import Cell


def run_ensemble(scenario: Scenario, seeds: Sequence[int], nthread: int = 0,
                 progress: Callable[[float, str], None] | None = None,
                 processes: int = 0, keep: Callable[[Run], Any] | None = None) -> list:
    """Draw ``scenario`` on the plants of ``plant.seed`` = each of ``seeds``, batched; return
    one :class:`Run` per seed, in order (failed members are Runs with status "failed", the
    others go on). ``processes``: shares of the members, each one batch in its own worker
    process (0: one per CPU; 1: one batch in this process); ``nthread``: MuJoCo threads in all
    (0: one per CPU), shared among the processes; ``progress(fraction, phase)`` as for
    :func:`inkarm.jobs.run.run`, for the member furthest behind; ``keep(run)``: what to keep of
    each Run, computed in the process that made it (only that travels back, not the page; a
    module-level function, sent to the workers by name), returned instead of the Runs. Every
    Run holds its page: :func:`iter_ensemble` yields them one at a time instead."""
    return list(iter_ensemble(scenario, seeds, nthread, progress, processes, keep))


def iter_ensemble(scenario: Scenario, seeds: Sequence[int], nthread: int = 0,
                  progress: Callable[[float, str], None] | None = None,
                  processes: int = 0, keep: Callable[[Run], Any] | None = None) -> Iterator:
    """:func:`run_ensemble` as a generator: the members are yielded in order as their shares
    deliver them (in one process: the whole ensemble is simulated at the first ``next``, then
    each member's canvas is inked and its metrics computed as it is yielded), so a caller that
    keeps only what it needs of each Run holds one page at a time."""
    seeds = [int(s) for s in seeds]
    if not seeds:
        raise InputError("an ensemble needs at least one seed", key="seeds", value=seeds)
    if len(set(seeds)) != len(seeds):
        raise InputError(f"the seeds repeat: {seeds}", key="seeds", value=seeds)
    for key, value in (("processes", processes), ("nthread", nthread)):
        if value < 0:
            raise InputError(f"processes and nthread count CPUs (0: all); got processes = "
                             f"{processes}, nthread = {nthread}", key=key, value=value)
    cell = Cell(scenario.cell, scenario.robot)
    try:
        drawing = placed_within_budget(scenario, cell)
        steps = substeps(scenario.robot.control_period_s, scenario.cell.timestep)
        periods = simulated_seconds(drawing, scenario, cell) / scenario.robot.control_period_s
        # per member and period: the log (3 n + 5 doubles, its plan row and blend) and, per
        # physics step, the touches kept for the canvas (4 doubles)
        require_memory(len(seeds) * periods * (3 * scenario.robot.n + 7 + 4 * steps) * 8.0,
                       f"the logs and touches of {len(seeds)} members over {periods:.3g} "
                       f"control periods", key="seeds")
        require_raster_memory(cell.paper_size_mm, scenario.ink.px_per_mm)
        for seed in seeds:
            scenario.plant.realised(seed)
    except InkarmError as e:
        raise e.within(file=scenario.path) from None
    if keep is not None:
        try:
            pickle.dumps(keep)
        except (pickle.PicklingError, AttributeError, TypeError) as e:
            raise InputError(f"keep must be a module-level function (the worker processes get "
                             f"it by name), not {keep!r} ({e})", key="keep",
                             value=keep) from None
    cpus = available_cpus()
    if not may_start_workers():  # in a daemonic process (a pool's worker): one share, here
        processes = 1
    shares = [part.tolist() for part in np.array_split(seeds, min(processes or cpus, len(seeds)))]
    threads = max(1, (nthread or cpus) // len(shares))
    if len(shares) == 1:
        yield from share_runs(scenario, drawing, seeds, nthread, len(seeds), keep,
                              progress=progress)
        return
    # With keep, only summaries travel: the shares all go to workers (malloc tuned for pages,
    # see inkarm.jobs.ensemble.workers) and this process stays free; without, the first share is drawn
    # here, so that half the pages need not travel.
    yield from stream_shares(share_runs, [(scenario, drawing, share, threads, len(seeds), keep)
                                          for share in shares], progress, here=keep is None)


def share_runs(scenario: Scenario, drawing: Drawing, seeds: list[int], nthread: int,
               members: int, keep: Callable[[Run], Any] | None = None,
               progress: Callable[[float, str], None] | None = None) -> Iterator:
    """The Runs of ``seeds`` (or ``keep`` of each), one share of an ensemble of ``members``
    drawing the placed ``drawing``, as one batch on ``nthread`` MuJoCo threads (0: all CPUs).
    Each log's wall time is the share's over ``members``: the shares run at once, so that is
    the ensemble's."""
    keep = keep or _whole
    if batch_refusal(scenario, seeds) is not None:  # each member a batch of one
        for seed in seeds:
            yield keep(run(member_scenario(scenario, seed)))
        return
    cell = Cell(scenario.cell, scenario.robot)
    believed, notes = believed_model(scenario, cell)
    try:
        steps = substeps(scenario.robot.control_period_s, scenario.cell.timestep)
        truths = [scenario.plant.realised(s) for s in seeds]
        plant = BatchPlant([member_model(cell, t) for t in truths], cell, truths[0], seeds,
                           substeps=steps,
                           drive_gains=scenario.robot.drive, nthread=nthread)
        results = execute(drawing, BatchMembers(plant), believed, scenario.robot.gains,
                          scenario.controller, law=scenario.law, watchdogs=scenario.watchdogs,
                          speed_limits=scenario.robot.speed_limits, progress=progress)
    except InkarmError as e:
        raise e.within(file=scenario.path) from None
    canvas = None
    for k, (seed, result) in enumerate(zip(seeds, results)):
        member = member_scenario(scenario, seed)
        canvas = _blank_again(canvas, scenario) or scenario.ink.canvas(cell.paper_size_mm)
        plant.feed(k, canvas)
        log = result.log if isinstance(result, RunFault) else result
        log.wall_s *= len(seeds) / members
        said = (*notes, *log.notes) if notes else None  # (the calibration it believed)
        if isinstance(result, RunFault):
            yield keep(failed_run(member, drawing, result, canvas, believed, notes=said))
        else:
            yield keep(finished_run(member, drawing, result, canvas, believed, notes=said))


def member_scenario(scenario: Scenario, seed: int) -> Scenario:
    """The member of ``seed``: ``scenario`` with ``plant.seed = seed``, equal to
    ``scenario.with_overrides({"plant.seed": seed})`` (the tests compare their tables) without
    parsing the scenario again (its parts are frozen, so the member shares them). ``seed`` is
    an int the caller has checked (:func:`iter_ensemble` realises every member's truth first)."""
    return dataclasses.replace(scenario, path=f"{scenario.path} (with overrides)",
                               plant=dataclasses.replace(scenario.plant, seed=seed))


def batch_refusal(scenario: Scenario, seeds: Sequence[int]) -> str | None:
    """Why the members of ``seeds`` cannot share one batched simulation
    (:class:`inkarm.sim.batch.BatchPlant`: position goals to the profile's drives, run-time
    truths alike), or None when they can. Members that cannot are executed one by one, each a
    batch of one of the same executor (:func:`inkarm.jobs.run.run`)."""
    if not scenario.law.commands <= BatchPlant.commands:
        return f"law {scenario.law.name!r} sends {', '.join(sorted(scenario.law.commands))}"
    if scenario.robot.servo_firmware:
        return f"{scenario.robot.name!r} runs its servos' firmware"
    try:
        check_batchable([scenario.plant.realised(s) for s in seeds])
    except InputError as e:
        return str(e)
    return None


_COUNTS_EVERY_REFERENCE = (sys.implementation.name == "cpython"
                           and sys.version_info < (3, 14))


def _blank_again(canvas: Canvas | None, scenario: Scenario) -> Canvas | None:
    """The previous member's ``canvas`` blanked for the next, with a fresh ink of
    ``scenario``, when nothing but the caller holds it or its rasters (what ``keep`` kept holds
    neither the canvas, nor its Run, nor a view of its image: CPython's reference counts say
    so); else None. Blanking writes the ink's box only, where a new page's zeros cost a write
    of the whole page (2 x 25 MB at A4 and 10 px/mm) or a page fault per page touched."""
    # (references: the caller's name, this argument and getrefcount's own; a raster's: the
    # canvas's attribute and getrefcount's. CPython 3.14 borrows some of them, so the counts
    # would say less than is held: a new page there, as on other interpreters)
    if canvas is None or not _COUNTS_EVERY_REFERENCE or sys.getrefcount(canvas) > 3:
        return None
    for name in ("_stroke", "_image", "_base"):
        if getattr(canvas, name) is not None and sys.getrefcount(getattr(canvas, name)) > 2:
            return None
    canvas.clear(ink=scenario.ink.make())
    return canvas


def _whole(run: Run) -> Run:
    return run


__all__ = ["iter_ensemble", "member_scenario", "run_ensemble", "share_runs"]
