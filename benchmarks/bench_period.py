"""Where a control period's time goes: the evidence for moving the per-period work out of Python
(issue 22 part 2).

Run: ``python benchmarks/bench_period.py [--quick]``. The default scenario (60 mm letter N, 828
control periods of 3 physics steps) drawn by :func:`inkarm.jobs.run.run`; its executor
(:func:`inkarm.control.executor.run_drawing`: planning and the closed loop) is split by timers
put around its parts in this process only:

* planning: ``check_reachable`` and ``plan_within_speed_limits`` (the IK path and the joint
  reference), once per run;
* physics: MuJoCo's ``mj_step1``/``mj_step2`` inside the plant's step;
* canvas: the ink laid at every physics step in contact (``Canvas.touch``/``lift``);
* the plant's own Python: the rest of ``MujocoPlant.step`` (the drives' set point ramp, the pen
  force from the contacts, the divergence check);
* the member's Python: the rest of the executor's period (reading, force loop, law, watchdogs,
  log row).

The timers cost about a microsecond a call, so the parts are read as shares; the uninstrumented
executor and MuJoCo alone (the run's torques replayed open loop, ``mj_step`` three steps a
period) run in alternating blocks beside them for the totals. Then two ways MuJoCo can take a
period in one call, from the same state: ``mj_step(m, d, 3)`` and a persistent
``mujoco.rollout.Rollout`` of 3 steps (the call's overhead decides whether rollout can host a
period).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from contextlib import contextmanager

import mujoco
import numpy as np
from bench_draw import Job, bare_mujoco_s
from blocks import interleave
from mujoco import rollout

import inkarm.sim.plant as sim_plant
from inkarm.control import executor
from inkarm.ink.canvas import Canvas
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario
from inkarm.sim.cell import Cell, build_model
from inkarm.sim.plant import MujocoPlant


class _Timers:
    def __init__(self):
        self.total: dict[str, float] = {}

    def add(self, name: str, seconds: float) -> None:
        self.total[name] = self.total.get(name, 0.0) + seconds


def _timed(fn, timers: _Timers, name: str):
    def wrapper(*args, **kwargs):
        start = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            timers.add(name, time.perf_counter() - start)
    return wrapper


class _TimedMujoco:
    """The ``mujoco`` module as the plant sees it, with its two step halves timed."""

    def __init__(self, timers: _Timers):
        self._timers = timers
        self.mj_step1 = _timed(mujoco.mj_step1, timers, "physics")
        self.mj_step2 = _timed(mujoco.mj_step2, timers, "physics")

    def __getattr__(self, name):
        return getattr(mujoco, name)


@contextmanager
def instrumented(timers: _Timers):
    """Timers around the executor's parts (module docstring), removed on exit."""
    saved = [(executor, "plan_within_speed_limits"), (executor, "check_reachable"),
             (executor, "execute"), (MujocoPlant, "step"), (Canvas, "touch"), (Canvas, "lift"),
             (sim_plant, "mujoco")]
    originals = [getattr(owner, name) for owner, name in saved]
    names = ["planning", "planning", "executor", "plant step", "canvas", "canvas", None]
    try:
        for (owner, name), fn, label in zip(saved, originals, names):
            if label is not None:
                setattr(owner, name, _timed(fn, timers, label))
        sim_plant.mujoco = _TimedMujoco(timers)
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
        start = time.perf_counter()
        for tau in torques:
            data.ctrl[:] = tau
            mujoco.mj_step(model, data, substeps)
        return time.perf_counter() - start

    def rolled() -> float:
        s = start_state[None].copy()
        start = time.perf_counter()
        for control in controls:
            runner.rollout([model], [data], s, control, nstep=substeps, skip_checks=True,
                           state=out)
            s = out[:, -1]
        return time.perf_counter() - start

    timing = interleave({"mj_step": stepped, "rollout": rolled}, blocks=5, repeats=1,
                        clock=None)
    return {name: 1e6 * timing.median(name) / len(torques) for name in timing.times}


def section(quick: bool) -> str:
    scenario = load_scenario()
    cell = Cell(scenario.cell, scenario.robot)
    job = Job(scenario, cell, None, scenario.ink.px_per_mm)  # (what the replay reads: the cell)
    first = run(scenario)
    torques, periods = first.log.torque, len(first.log.time)
    shares: list[dict[str, float]] = []

    def split_run() -> float:
        timers = _Timers()
        with instrumented(timers):
            run(scenario)
        shares.append(timers.total)
        return timers.total["executor"]

    timing = interleave({"executor": lambda: run(scenario).log.wall_s, "split": split_run,
                         "mujoco": lambda: bare_mujoco_s(job, torques)},
                        blocks=3 if quick else 7, repeats=3, clock=None)
    parts = {k: statistics.median(s[k] for s in shares) for k in shares[0]}
    plant_python = parts["plant step"] - parts["physics"] - parts["canvas"]
    member = parts["executor"] - parts["planning"] - parts["plant step"]
    rows = [("planning (IK path, joint reference; once per run)", parts["planning"]),
            ("physics (mj_step1 + mj_step2, 3 a period)", parts["physics"]),
            ("canvas (ink at each physics step in contact)", parts["canvas"]),
            ("the plant's Python (drive ramp, pen force, divergence check)", plant_python),
            ("the member's Python (read, force loop, law, watchdogs, log row)", member)]
    executor_us = 1e6 * timing.median("executor") / periods
    mujoco_us = 1e6 * timing.median("mujoco") / periods
    calls = one_call_per_period(cell, torques)
    lines = [
        "## Period: where a control period's time goes (bench_period.py)",
        "",
        (f"The default scenario ({periods} control periods of 3 physics steps), one process; "
        "shares from timers around the executor's parts (instrumented runs), totals from "
        "uninstrumented runs in alternating blocks with MuJoCo alone (the run's torques "
        f"replayed open loop). {timing.load_line()}"),
        "",
        "| part | share of the executor | per period [us] |",
        "|---|---|---|",
    ]
    lines += [f"| {label} | {value / parts['executor']:.0%} | "
              f"{1e6 * value / parts['executor'] * timing.median('executor') / periods:.1f} |"
              for label, value in rows]
    lines += [
        f"| **executor, uninstrumented** | 100% | {executor_us:.1f} |",
        f"| MuJoCo alone, the same steps | | {mujoco_us:.1f} |",
        "",
        (f"Executor / MuJoCo alone: {executor_us / mujoco_us:.2f} (the issue's target: <= 2, a "
        f"real-time factor >= 0.5x MuJoCo's). MuJoCo taking a period in one call from Python: "
        f"`mj_step(m, d, 3)` {calls['mj_step']:.1f} us, a persistent `mujoco.rollout` of 3 steps "
        f"{calls['rollout']:.1f} us ({calls['rollout'] - calls['mj_step']:+.1f} us a call)."),
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
