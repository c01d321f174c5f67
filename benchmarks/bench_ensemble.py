"""Throughput of ensembles: N plants of one scenario that differ in their random imperfections
(``plant.seed`` = 0 .. N-1), batched (:func:`inkarm.jobs.ensemble.iter_ensemble`: the members
in one share per CPU, each share one ``mujoco.batch`` simulation driven by the vectorised
controller in its own worker process) against the same N runs on a process pool of
:func:`inkarm.jobs.run.run` (the reference: one spawned process per CPU, each returning its
status, metrics and simulated time), in the same process, on the same machine.

Run: ``python benchmarks/bench_ensemble.py [--members N] [--scenario FILE] [--quick]
[--repeat R]`` (R blocks, each running every executor once and then the physics floors, so
that a busy minute on a shared machine hits subject and reference alike; medians of the blocks;
default 3: a block takes about 10 s for 64 members on two cores). Prints one markdown table:
wall time, members per second, the aggregate real-time factor (simulated seconds of all members
over the wall time), the
throughput ratio against the process pool, the CPU time per member (all processes and threads:
the pool's workers with their start, the ensemble's workers from their fork) and its ratio; then
the largest difference of a metric between the pool and the batch, member by member. On a
shared machine the wall-clock ratio moves with the other tenants' load, the CPU ratio much less:
the load average is printed with the table.

Executors: the pool (reference); the batch in this process (one share, MuJoCo on every CPU:
the controller, inking and metrics on one core); one share per CPU with the workers started in
the measurement (``shutdown_workers`` first: the fork of each worker is counted, as the pool's
start is); and one share per CPU on the workers kept from the previous ensemble (what each
ensemble of a sweep after the first costs). Default: 64 members of
``scenarios/realistic_iiwa.toml`` (the default letter on the realistic plant whose
``[plant.random]`` ranges make the ensemble; ``--quick``: 8). Every executor inks every
member's canvas and computes its metrics, and keeps (status, metrics, simulated time) of each
member (:func:`summary`), computed where the member was drawn: the pool's workers return it,
the ensemble's get it as ``keep``; pages do not travel on either side.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import resource
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import mujoco
import numpy as np
from mujoco import rollout

from inkarm.control.executor import execute
from inkarm.jobs.backends.sim import SimSession
from inkarm.jobs.calibration import believed_model
from inkarm.jobs.ensemble import iter_ensemble
from inkarm.jobs.ensemble.workers import available_cpus, shutdown_workers, worker_cpu_seconds
from inkarm.jobs.preflight import placed_within_budget, substeps
from inkarm.jobs.run import Run, run
from inkarm.jobs.scenario import load_scenario
from inkarm.jobs.sweep.design import with_point
from inkarm.sim.batch import BatchPlant, member_model
from inkarm.sim.batch_members import BatchMembers
from inkarm.sim.cell import HOME_KEY, Cell

DEFAULT = Path(__file__).resolve().parent.parent / "scenarios" / "realistic_iiwa.toml"


def summary(result: Run) -> tuple[str, dict, float]:
    """What both sides keep of a member: (status, metrics, simulated [s])."""
    return result.status, result.metrics, float(result.log.time[-1] - result.log.time[0])


def one_member(path: str, seed: int) -> tuple[str, dict, float]:
    """The summary of the scenario at ``path`` with ``plant.seed``."""
    return summary(run(with_point(load_scenario(path), {"plant.seed": seed})))


def cpu_seconds() -> float:
    """CPU time [s] of this process (all its threads), of its children that ended and of the
    kept ensemble workers (children that have not ended)."""
    own, children = (resource.getrusage(w) for w in (resource.RUSAGE_SELF,
                                                      resource.RUSAGE_CHILDREN))
    return (own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime
            + worker_cpu_seconds())


def pooled(path: str, seeds: list[int], workers: int) -> tuple[float, float, float, list]:
    """(wall [s], CPU [s], simulated [s], per-member results) on a fresh process pool (spawned
    workers, children of this process, so that their CPU time is counted when they end)."""
    start, cpu = time.perf_counter(), cpu_seconds()
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        results = list(pool.map(one_member, [path] * len(seeds), seeds))
    wall = time.perf_counter() - start
    return wall, cpu_seconds() - cpu, sum(r[2] for r in results), results


def batched(path: str, seeds: list[int], processes: int, nthread: int = 0, cold: bool = False
            ) -> tuple[float, float, float, list]:
    """(wall [s], CPU [s], simulated [s], per-member results) of one batched ensemble in
    ``processes`` shares (1: in this process, on ``nthread`` MuJoCo threads); ``cold``: the
    kept workers are ended first, so that starting them is measured."""
    if cold:
        shutdown_workers()
    start, cpu = time.perf_counter(), cpu_seconds()
    results = list(iter_ensemble(load_scenario(path), seeds, nthread=nthread,
                                 processes=processes, keep=summary))
    wall = time.perf_counter() - start
    return wall, cpu_seconds() - cpu, sum(r[2] for r in results), results


def trajectory_cases(path: str, seeds: list[int]) -> list:
    """The cases of the physics floor (:func:`rollout_cpu_s`): each member's plant model from
    its start state with the controls its drives applied at each physics step of its batched
    run (the run's own trajectory, pen contacts included, without any controller: the floor of
    a member's cost). Helper B, session 32."""
    scenario = load_scenario(path)
    cell = Cell(scenario.cell, scenario.robot)
    drawing = placed_within_budget(scenario, cell)
    believed, _ = believed_model(scenario, cell)
    truths = [scenario.plant.realised(s) for s in seeds]
    models = [member_model(cell, t) for t in truths]
    plant = BatchPlant(models, cell, truths[0], seeds, drive_gains=scenario.robot.drive,
                       substeps=substeps(scenario.robot.control_period_s,
                                         scenario.cell.timestep), nthread=1)
    applied, step = [], plant.batch.step

    def recording_step(ids=None, nstep=1, stage=0):
        applied.append((None if ids is None else set(np.asarray(ids).tolist()),
                        plant._ctrl.copy()))
        step(ids, nstep, stage)

    plant.batch.step = recording_step
    execute(drawing, BatchMembers(plant), believed, scenario.robot.gains, scenario.controller,
            law=scenario.law, watchdogs=scenario.watchdogs,
            speed_limits=scenario.robot.speed_limits)
    key = mujoco.mj_name2id(models[0], mujoco.mjtObj.mjOBJ_KEY, HOME_KEY)
    cases = []
    for k, model in enumerate(models):
        data = mujoco.MjData(model)
        mujoco.mj_resetDataKeyframe(model, data, key)
        mujoco.mj_forward(model, data)
        state = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
        mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        control = np.array([c[k] for ids, c in applied if ids is None or k in ids])
        cases.append((model, data, state, control))
    return cases


def rollout_cpu_s(cases: list) -> float:
    """CPU [s] of ``mujoco.rollout`` of each (model, data, state, controls) of ``cases``."""
    runner = rollout.Rollout(nthread=0)
    cpu = time.process_time()
    for model, data, state, control in cases:
        runner.rollout(model, data, state[None], control[None], skip_checks=False)
    return time.process_time() - cpu


def open_loop_cases(path: str, seeds: list[int]) -> list:
    """The cases of the open-loop floor (:func:`rollout_cpu_s`): each member's own plant model
    from its start state, for as many physics steps as its run took, its logged torques held
    over each control period open loop (the floor of sessions 29-31: the arm drifts off the
    letter and the pen touches the paper in a few steps, so it leaves out most of the contact
    solving)."""
    cases = []
    for seed in seeds:
        scenario = with_point(load_scenario(path), {"plant.seed": seed})
        plant = SimSession(scenario).plant
        plant = getattr(plant, "plant", plant)  # (the MujocoPlant inside a servo wrapper)
        model, data = plant.model, plant.data
        state = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
        mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        torques = run(scenario).log.torque
        control = np.zeros((len(torques) * plant.substeps, model.nu))
        control[:, plant._arm_ctrl] = np.repeat(np.nan_to_num(torques), plant.substeps, axis=0)
        cases.append((model, data, state, control))
    return cases


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--members", type=int, default=None)
    parser.add_argument("--scenario", default=str(DEFAULT))
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeat", type=int, default=3,
                        help="median of this many alternating blocks")
    args = parser.parse_args()
    n = args.members or (8 if args.quick else 64)
    seeds = list(range(n))
    cpus = available_cpus()
    scenario = load_scenario(args.scenario)
    executors = [(f"process pool, {cpus} workers (reference)",
                  lambda: pooled(args.scenario, seeds, cpus)),
                  (f"batched, one process (mujoco.batch, {cpus} threads)",
                   lambda: batched(args.scenario, seeds, 1, cpus))]
    if cpus > 1:
        executors += [(f"batched, {cpus} worker processes, started in the run",
                       lambda: batched(args.scenario, seeds, cpus, cold=True)),
                      (f"batched, {cpus} worker processes, kept from the previous ensemble",
                       lambda: batched(args.scenario, seeds, cpus))]
    # Interleaved repeats, so that a busy minute on a shared machine hits every executor and
    # the physics floors alike (a block: each executor once, then each floor).
    walls: dict[str, list[float]] = {name: [] for name, _ in executors}
    cpus_used: dict[str, list[float]] = {name: [] for name, _ in executors}
    # (the floors' controls recorded once; only their rollouts are timed in each block)
    trajectory, open_loop = (cases(args.scenario, seeds[:8])
                             for cases in (trajectory_cases, open_loop_cases))
    floors: list[float] = []
    open_loops: list[float] = []
    last = {}
    for _ in range(args.repeat):
        for name, measure in executors:
            wall, cpu, simulated, results = measure()
            walls[name].append(wall)
            cpus_used[name].append(cpu)
            last[name] = (simulated, results)
        floors.append(rollout_cpu_s(trajectory) / len(trajectory))
        open_loops.append(rollout_cpu_s(open_loop) / len(open_loop))
    rows = [(name, statistics.median(walls[name]), statistics.median(cpus_used[name]),
             *last[name]) for name, _ in executors]
    reference, reference_cpu = n / rows[0][1], rows[0][2] / n
    print(f"## Ensembles: {n} plants of {scenario.title!r}\n")
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"Median of {args.repeat} block{'s' * (args.repeat > 1)} each, {cpus} CPUs; load "
          f"average after the runs (1, 5, 15 min): {load}.\n")
    print("| executor | wall [s] | members/s | aggregate real-time factor | throughput ratio | "
          "CPU per member [s] | CPU ratio |")
    print("|---|---|---|---|---|---|---|")
    for name, wall, cpu, simulated, _ in rows:
        print(f"| {name} | {wall:.1f} | {n / wall:.2f} | {simulated / wall:.1f} | "
              f"{n / wall / reference:.2f}x | {cpu / n:.3f} | {reference_cpu / (cpu / n):.2f}x |")
    floor, open_loop = statistics.median(floors), statistics.median(open_loops)
    kept = rows[-1][2] / n
    print(f"\nPhysics floor: `mujoco.rollout` of each member's plant model through the controls "
          f"its drives applied at each physics step (its own trajectory, the pen pressed; "
          f"{len(trajectory)} members, one thread): {floor:.3f} s of CPU per member; the last "
          f"executor above takes {kept / floor:.1f}x that (target <= 2x: "
          f"{'ok' if kept / floor <= 2.0 else 'MISSED'}). The floor of sessions 29-31 (the "
          f"logged torques open loop: the pen touches in a few steps) was {open_loop:.3f} s "
          f"({kept / open_loop:.1f}x).")
    pool, batch = rows[0][4], rows[-1][4]
    shutdown_workers()
    same_status = sum(a[0] == b[0] for a, b in zip(pool, batch))
    worst = max(((abs(a[1][k] - b[1][k]), k) for a, b in zip(pool, batch) for k in a[1]
                 if k != "realtime_factor" and k in b[1]), default=(0.0, "none"))
    print(f"\nSame status in {same_status} of {n} members; largest metric difference "
          f"{worst[0]:.2g} ({worst[1]}).")
    return 0


if __name__ == "__main__":
    sys.exit(main())
