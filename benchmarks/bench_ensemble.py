"""Throughput of ensembles: N plants of one scenario that differ in their random imperfections
(``plant.seed`` = 0 .. N-1), batched (:func:`inkarm.jobs.ensemble.run_ensemble`: one
``mujoco.batch`` simulation, the controller vectorised over members) against the same N runs on
a process pool of :func:`inkarm.jobs.run.run` (one process per CPU, each returning its status,
metrics and simulated time), in the same process, on the same machine.

Run: ``python benchmarks/bench_ensemble.py [--members N] [--scenario FILE] [--quick]
[--repeat R]`` (R interleaved runs of each executor, medians; default 1: the pool takes about a
minute for 64 members on two cores). Prints
one markdown table: wall time, members per second, the aggregate real-time factor (simulated
seconds of all members over the wall time) and the throughput ratio against the process pool,
for the batch on one MuJoCo thread and on one per CPU, and the CPU time per member (all threads,
and the workers with their start; on a shared machine the wall-clock ratio moves with the other
tenants' load, the CPU ratio much less); then the largest difference of a metric
between the pool and the batch, member by member. Default: 64 members
of ``scenarios/realistic_iiwa.toml`` (the default letter on the realistic plant whose
``[plant.random]`` ranges make the ensemble; ``--quick``: 8). Both sides ink every member's
canvas and compute its metrics, and keep (status, metrics, simulated time) of each member, one
page at a time (:func:`inkarm.jobs.ensemble.iter_ensemble`); the pool's time includes starting
its workers.
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

from inkarm.jobs.ensemble import iter_ensemble
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario
from inkarm.jobs.sweep_design import with_point

DEFAULT = Path(__file__).resolve().parent.parent / "scenarios" / "realistic_iiwa.toml"


def one_member(path: str, seed: int) -> tuple[str, dict, float]:
    """(status, metrics, simulated [s]) of the scenario at ``path`` with ``plant.seed``."""
    result = run(with_point(load_scenario(path), {"plant.seed": seed}))
    return result.status, result.metrics, float(result.log.time[-1] - result.log.time[0])


def cpu_seconds() -> float:
    """CPU time [s] of this process (all its threads) and of its children that ended."""
    own, children = (resource.getrusage(w) for w in (resource.RUSAGE_SELF,
                                                      resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def pooled(path: str, seeds: list[int], workers: int) -> tuple[float, float, float, list]:
    """(wall [s], CPU [s], simulated [s], per-member results) on a fresh process pool (spawned
    workers, children of this process, so that their CPU time is counted when they end)."""
    start, cpu = time.perf_counter(), cpu_seconds()
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        results = list(pool.map(one_member, [path] * len(seeds), seeds))
    wall = time.perf_counter() - start
    return wall, cpu_seconds() - cpu, sum(r[2] for r in results), results


def batched(path: str, seeds: list[int], nthread: int) -> tuple[float, float, float, list]:
    """(wall [s], CPU [s], simulated [s], per-member results) of one batched ensemble."""
    start, cpu = time.perf_counter(), cpu_seconds()
    results = [(r.status, r.metrics, float(r.log.time[-1] - r.log.time[0]))
               for r in iter_ensemble(load_scenario(path), seeds, nthread=nthread)]
    wall = time.perf_counter() - start
    return wall, cpu_seconds() - cpu, sum(r[2] for r in results), results


def _batch_chunk(path: str, seeds: list[int]) -> list:
    return batched(path, seeds, 1)[3]


def batched_processes(path: str, seeds: list[int], workers: int
                      ) -> tuple[float, float, float, list]:
    """(wall [s], CPU [s], simulated [s], per-member results) of one batched ensemble per
    worker process, the seeds split evenly (what stays per member in Python, its canvas and
    metrics, then runs on every core too)."""
    start, cpu = time.perf_counter(), cpu_seconds()
    chunks = [seeds[k::workers] for k in range(workers) if seeds[k::workers]]
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=len(chunks), mp_context=context) as pool:
        parts = list(pool.map(_batch_chunk, [path] * len(chunks), chunks))
    by_seed = {seed: r for chunk, part in zip(chunks, parts) for seed, r in zip(chunk, part)}
    results = [by_seed[seed] for seed in seeds]
    wall = time.perf_counter() - start
    return wall, cpu_seconds() - cpu, sum(r[2] for r in results), results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--members", type=int, default=None)
    parser.add_argument("--scenario", default=str(DEFAULT))
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeat", type=int, default=1, help="median of this many runs")
    args = parser.parse_args()
    n = args.members or (8 if args.quick else 64)
    seeds = list(range(n))
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    scenario = load_scenario(args.scenario)
    executors = [(f"process pool, {cpus} workers (reference)",
                  lambda: pooled(args.scenario, seeds, cpus))]
    for threads in sorted({1, cpus}):
        executors.append((f"batched (mujoco.batch, {threads} thread{'s' * (threads > 1)})",
                          lambda t=threads: batched(args.scenario, seeds, t)))
    if cpus > 1:
        executors.append((f"batched, one batch per process ({cpus} processes)",
                          lambda: batched_processes(args.scenario, seeds, cpus)))
    # Interleaved repeats, so that a busy minute on a shared machine hits every executor alike.
    walls: dict[str, list[float]] = {name: [] for name, _ in executors}
    cpus_used: dict[str, list[float]] = {name: [] for name, _ in executors}
    last = {}
    for _ in range(args.repeat):
        for name, measure in executors:
            wall, cpu, simulated, results = measure()
            walls[name].append(wall)
            cpus_used[name].append(cpu)
            last[name] = (simulated, results)
    rows = [(name, statistics.median(walls[name]), statistics.median(cpus_used[name]),
             *last[name]) for name, _ in executors]
    reference, reference_cpu = n / rows[0][1], rows[0][2] / n
    print(f"## Ensembles: {n} plants of {scenario.title!r}\n")
    print(f"Median of {args.repeat} run{'s' * (args.repeat > 1)} each.\n")
    print("| executor | wall [s] | members/s | aggregate real-time factor | throughput ratio | "
          "CPU per member [s] | CPU ratio |")
    print("|---|---|---|---|---|---|---|")
    for name, wall, cpu, simulated, _ in rows:
        print(f"| {name} | {wall:.1f} | {n / wall:.2f} | {simulated / wall:.1f} | "
              f"{n / wall / reference:.2f}x | {cpu / n:.3f} | {reference_cpu / (cpu / n):.2f}x |")
    pool, batch = rows[0][4], rows[-1][4]
    same_status = sum(a[0] == b[0] for a, b in zip(pool, batch))
    worst = max(((abs(a[1][k] - b[1][k]), k) for a, b in zip(pool, batch) for k in a[1]
                 if k != "realtime_factor" and k in b[1]), default=(0.0, "none"))
    print(f"\nSame status in {same_status} of {n} members; largest metric difference "
          f"{worst[0]:.2g} ({worst[1]}).")
    return 0


if __name__ == "__main__":
    sys.exit(main())
