"""Where a control period's time goes, with the executor's and the plant's periods in C and in
Python (issue 22 part 2).

Run: ``python benchmarks/bench_period.py [--quick]``. The default scenario (60 mm letter N, 828
control periods of 3 physics steps) drawn by :func:`inkarm.jobs.run.run`, twice per block:
compiled (``inkarm/sim/_period.c``: the drives' set point ramp, the physics steps, the pen
force, the tip on the page and the divergence test in one call; ``inkarm/control/_law.c`` and
``_member.c``: the member's steps, law, force loop, watchdogs' common case and log row in one
call; and whole periods, the plant's included, in C through the plant's port between two of
the executor's own periods) and in Python (``INKARM_COMPILED=0``); both give the same bits.
Its executor (:func:`inkarm.control.executor.run_drawing`: planning and the closed loop) is
split by timers put around its parts in this process only:

* planning: ``check_reachable`` and ``plan_within_speed_limits`` (the IK path and the joint
  reference), once per run;
* physics: MuJoCo's ``mj_step1``/``mj_step2`` inside the plant's step; with the compiled period,
  its calls (MuJoCo is called from C: the period's other work is counted here too);
* canvas: the ink laid at every physics step in contact (``Canvas.touch``/``lift``/
  ``touch_many``, wherever they are called from);
* the plant's Python: the rest of ``MujocoPlant.step`` (the new set point from the drives: with
  the compiled period its arithmetic in one C call, ``compiled.set_point``; in the Python
  period the set point ramp, the pen force from the contacts, the divergence check; with the
  compiled one the canvas's feed);
* whole periods in C: ``Lane.run`` (its canvas counted as the canvas's);
* the member's Python: the rest of the executor's period (reading, force loop, law,
  watchdogs, log row: compiled, one C call).

The timers cost about a microsecond a call, so the parts are read as shares; the uninstrumented
executors (compiled and Python periods) and MuJoCo alone (the run's own physics replayed: its
controls at every physics step from its start state, the pen pressed as in the run, ``mj_step``;
:mod:`pressed`) run in alternating blocks beside them for the totals, timed on
this thread's CPU clock (``time.thread_time``: on a loaded machine wall time also counts the
other processes' turns). Then two
ways MuJoCo can take a period in one call, from the same state: ``mj_step(m, d, 3)`` and a
persistent ``mujoco.rollout.Rollout`` of 3 steps.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from contextlib import contextmanager

import mujoco
import numpy as np
from bench_draw import bare_mujoco_s
from blocks import interleave
from mujoco import rollout
from pressed import period, recorded_physics, replay_s

import inkarm.sim.plant as sim_plant
from inkarm.control import executor
from inkarm.control.compiled import position_law
from inkarm.control.member_lane import Lane
from inkarm.ink.canvas import Canvas
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario
from inkarm.sim import compiled
from inkarm.sim.cell import Cell, build_model
from inkarm.sim.plant import MujocoPlant


class _Timers:
    def __init__(self):
        self.total: dict[str, float] = {}
        self.inside: set[str] = set()

    def add(self, name: str, seconds: float) -> None:
        self.total[name] = self.total.get(name, 0.0) + seconds


def _timed(fn, timers: _Timers, name: str, inner: str | None = None):
    """``fn`` with its time added to ``name`` (less what ``inner``'s timers add meanwhile; a
    call inside another of ``name``'s, as ``lift`` inside ``touch_many``, counted once)."""
    def wrapper(*args, **kwargs):
        if name in timers.inside:
            return fn(*args, **kwargs)
        timers.inside.add(name)
        nested = timers.total.get(inner, 0.0)
        start = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            timers.inside.discard(name)
            spent, nested = time.perf_counter() - start, timers.total.get(inner, 0.0) - nested
            timers.add(name, spent - nested)
            if inner is not None:
                timers.add(f"{inner} in {name}", nested)
    return wrapper


class _TimedMujoco:
    """The ``mujoco`` module as the plant sees it, with its two step halves timed."""

    def __init__(self, timers: _Timers):
        self._timers = timers
        self.mj_step1 = _timed(mujoco.mj_step1, timers, "physics")
        self.mj_step2 = _timed(mujoco.mj_step2, timers, "physics")

    def __getattr__(self, name):
        return getattr(mujoco, name)


class _TimedPeriod:
    """A compiled period (:mod:`inkarm.sim.compiled`) with its steps timed as physics (its new
    set points stay the plant's own work)."""

    def __init__(self, period, timers: _Timers):
        self._period = period
        self.step = _timed(period.step, timers, "physics")
        self.command = period.command

    def __getattr__(self, name):  # (enter, leave, port: the member's whole periods in C)
        return getattr(self._period, name)


@contextmanager
def instrumented(timers: _Timers):
    """Timers around the executor's parts (module docstring), removed on exit."""
    saved = [(executor, "plan_within_speed_limits"), (executor, "check_reachable"),
             (executor, "execute"), (MujocoPlant, "step"), (Canvas, "touch"), (Canvas, "lift"),
             (Canvas, "touch_many"), (Lane, "run"), (sim_plant, "mujoco"),
             (sim_plant, "period_for")]
    originals = [getattr(owner, name) for owner, name in saved]
    names = ["planning", "planning", "executor", "plant step", "canvas", "canvas", "canvas",
             "whole", None, None]
    period_for = sim_plant.period_for
    try:
        for (owner, name), fn, label in zip(saved, originals, names):
            if label is not None:  # (whole periods in C: their canvas counted as the canvas)
                setattr(owner, name, _timed(fn, timers, label,
                                            "canvas" if label == "whole" else None))
        sim_plant.mujoco = _TimedMujoco(timers)
        sim_plant.period_for = lambda plant: (None if (p := period_for(plant)) is None else
                                              _TimedPeriod(p, timers))
        yield
    finally:
        for (owner, name), fn in zip(saved, originals):
            setattr(owner, name, fn)


def one_call_per_period(cell: Cell, torques: np.ndarray, substeps: int = 3
                        ) -> dict[str, float]:
    """Per period [us]: ``mj_step(m, d, substeps)``, and a persistent rollout of ``substeps``
    steps (state in, state out), on the same torques from the same state."""
    model = build_model(cell)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    start_state = state.copy()
    controls = np.repeat(torques[:, None, :], substeps, axis=1)[:, None]  # (periods, 1, 3, nu)
    out = np.empty((1, substeps, len(state)))
    runner = rollout.Rollout(nthread=0)

    def stepped() -> float:
        mujoco.mj_setState(model, data, start_state, spec)
        start = time.thread_time()
        for tau in torques:
            data.ctrl[:] = tau
            mujoco.mj_step(model, data, substeps)
        return time.thread_time() - start

    def rolled() -> float:
        s = start_state[None].copy()
        start = time.thread_time()
        for control in controls:
            runner.rollout([model], [data], s, control, nstep=substeps, skip_checks=True,
                           state=out)
            s = out[:, -1]
        return time.thread_time() - start

    timing = interleave({"mj_step": stepped, "rollout": rolled}, blocks=5, repeats=1,
                        clock=None)
    return {name: 1e6 * timing.median(name) / len(torques) for name in timing.times}


def executor_cpu_s(scenario) -> float:
    """CPU time [s] of this thread in the executor (``execute``) while ``scenario`` runs: under
    load, wall time counts the other processes' turns too."""
    spent = []
    execute = executor.execute

    def timed(*args, **kwargs):
        start = time.thread_time()
        try:
            return execute(*args, **kwargs)
        finally:
            spent.append(time.thread_time() - start)

    executor.execute = timed
    try:
        run(scenario)
    finally:
        executor.execute = execute
    return sum(spent)


def mujoco_cpu_s(cell: Cell, torques: np.ndarray, substeps: int = 3) -> float:
    """CPU time [s] of MuJoCo alone on this thread's clock (:func:`bench_draw.bare_mujoco_s`)."""
    return bare_mujoco_s(cell, torques, substeps, clock=time.thread_time)


def _parts(shares: list[dict[str, float]]) -> dict[str, float]:
    """Median seconds per part over the instrumented runs; the plant's own work and the
    member's Python as the differences (module docstring)."""
    parts = {k: statistics.median(s.get(k, 0.0) for s in shares)
             for k in ("planning", "physics", "canvas", "plant step", "executor", "whole",
                       "canvas in whole")}
    parts["plant"] = parts["plant step"] - parts["physics"] - (parts["canvas"]
                                                              - parts["canvas in whole"])
    parts["member"] = (parts["executor"] - parts["planning"] - parts["plant step"]
                       - parts["whole"] - parts["canvas in whole"])
    return parts


def section(quick: bool) -> str:
    scenario = load_scenario()
    cell = Cell(scenario.cell, scenario.robot)
    physics = recorded_physics(scenario)  # (its run's torques: the same bits compiled or not)
    torques = physics.torques
    periods = len(torques)
    kinds = ("compiled", "python")
    shares: dict[str, list[dict[str, float]]] = {kind: [] for kind in kinds}

    def executor_s(kind: str) -> float:
        with period(kind):
            return executor_cpu_s(scenario)

    def split_run(kind: str) -> float:
        timers = _Timers()
        with period(kind), instrumented(timers):
            run(scenario)
        shares[kind].append(timers.total)
        return timers.total["executor"]

    cases = {f"executor {kind}": lambda kind=kind: executor_s(kind) for kind in kinds}
    cases |= {f"split {kind}": lambda kind=kind: split_run(kind) for kind in kinds}
    cases["mujoco"] = lambda: replay_s(physics)
    cases["open loop"] = lambda: mujoco_cpu_s(cell, torques)
    timing = interleave(cases, blocks=3 if quick else 9, repeats=3, clock=None)
    mujoco_us = 1e6 * timing.median("mujoco") / periods
    open_loop_us = 1e6 * timing.median("open loop") / periods
    total_us = {kind: 1e6 * timing.median(f"executor {kind}") / periods for kind in kinds}
    parts = {kind: _parts(shares[kind]) for kind in kinds}

    def cell_of(kind: str, key: str) -> str:
        share = parts[kind][key] / parts[kind]["executor"]
        return f"{share:.0%} | {share * total_us[kind]:.1f}"

    rows = [("planning (IK path, joint reference; once per run)", "planning"),
            (("physics (Python: mj_step1 + mj_step2, 3 a period; compiled: the whole C "
              "period, its ramp, pen force, tip and divergence test included)"), "physics"),
            ("canvas (ink at each physics step in contact)", "canvas"),
            (("the plant's Python (the new set point, compiled: its arithmetic in C; Python "
              "period: drive ramp, pen force, divergence check; compiled: the canvas's feed)"),
             "plant"),
            (("whole periods in C (compiled: `Lane.run`, the member's steps, the plant's "
              "period, physics and all, between two periods of the executor's loop)"), "whole"),
            (("the member's Python (read, force loop, law: compiled, its steps in one C call; "
              "watchdogs, log row)"), "member")]
    calls = one_call_per_period(cell, torques)
    usable = compiled.period_module() is not None and position_law() is not None
    note = "" if usable else (" **The compiled period or law is not usable here: both columns "
                              "are Python** (see inkarm.sim.compiled's and "
                              "inkarm.control.compiled's debug logs).")
    ratio = {kind: total_us[kind] / mujoco_us for kind in kinds}
    lines = [
        "## Period: where a control period's time goes (bench_period.py)",
        "",
        (f"The default scenario ({periods} control periods of 3 physics steps), one process, "
         "compiled (the plant's period, `inkarm/sim/_period.c`; the member's steps, "
         "`inkarm/control/_law.c` and `_member.c`; whole periods in C through the plant's port "
         "between two of the executor's own) and in Python (`INKARM_COMPILED=0`), "
         "bit-identical logs and canvas; shares from timers around the executor's parts "
         "(instrumented runs), totals from uninstrumented runs in alternating blocks with MuJoCo "
         "alone (the run's own physics replayed: its controls at every physics step, the pen "
         f"pressed in {physics.in_contact} of its {physics.steps} steps as in the run, the "
         "same final state bit for bit), on this thread's CPU clock. "
         f"{timing.load_line()}{note}"),
        "",
        "| part | compiled: share | per period [us] | Python: share | per period [us] |",
        "|---|---|---|---|---|",
    ]
    lines += [f"| {label} | {cell_of('compiled', key)} | {cell_of('python', key)} |"
              for label, key in rows]
    lines += [
        (f"| **executor, uninstrumented** | 100% | {total_us['compiled']:.1f} | 100% | "
         f"{total_us['python']:.1f} |"),
        f"| MuJoCo alone, the run's physics | | {mujoco_us:.1f} | | {mujoco_us:.1f} |",
        "",
        (f"Executor / MuJoCo alone: {ratio['compiled']:.2f} compiled, "
         f"{ratio['python']:.2f} in Python (the issue's target: <= 2, a real-time "
         f"factor >= 0.5x MuJoCo's); compiled, they save "
         f"{1 - total_us['compiled'] / total_us['python']:.0%} of the executor's time. "
         f"MuJoCo taking a period in one call from Python: `mj_step(m, d, 3)` "
         f"{calls['mj_step']:.1f} us, a persistent `mujoco.rollout` of 3 steps "
         f"{calls['rollout']:.1f} us ({calls['rollout'] - calls['mj_step']:+.1f} us a call)."),
        "",
        (f"The reference of sessions 29-31, the run's logged torques held over each period's "
         f"steps open loop, takes {open_loop_us:.1f} us a period: it drifts off the letter and "
         f"its pen never touches the paper (the run's: {physics.in_contact} steps in contact), "
         f"so it left the contacts out; against it the compiled executor reads "
         f"{total_us['compiled'] / open_loop_us:.2f}."),
    ]
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer blocks")
    args = parser.parse_args()
    print(section(args.quick))
    return 0


if __name__ == "__main__":
    sys.exit(main())
