"""Throughput of sweeps: N runs of a scenario one after another in this process, against the
same N runs on the local process pool of :func:`inkarm.jobs.sweep.run_sweep` (and on a local
Ray cluster when Ray is installed), in the same process, on the same machine.

Run: ``python benchmarks/bench_sweep.py [--runs N] [--scenario FILE] [--quick]``. Prints one
markdown table: wall time, runs per second, the aggregate real-time factor (simulated seconds
of all runs over the wall time) and the throughput ratio against the serial loop. The pool's
time includes starting its workers and writing the table (what a user waits for); the serial
loop only runs. The executors run in alternating blocks (:mod:`blocks`), one sweep a block;
times are the medians of the blocks. Default: 32 runs of the embedded default letter, 3 blocks
(``--quick``: 8 runs, 2 blocks).
"""

from __future__ import annotations

import argparse
import functools
import statistics
import sys
import tempfile
import time
from pathlib import Path

from blocks import interleave

from inkarm.jobs.ensemble.workers import available_cpus
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario
from inkarm.jobs.sweep import run_sweep
from inkarm.jobs.sweep.design import make_points, with_point
from inkarm.jobs.sweep.table import read_results


def serial(scenario, points) -> tuple[float, float]:
    """(wall [s], simulated [s]) of running the points one after another here."""
    start, simulated = time.perf_counter(), 0.0
    for p in points:
        result = run(with_point(scenario, p.overrides()))
        simulated += float(result.log.time[-1] - result.log.time[0])
    return time.perf_counter() - start, simulated


def pooled(scenario, points, executor: str, workers: int) -> tuple[float, float]:
    """(wall [s], simulated [s]) of a fresh sweep of the points."""
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        if executor == "ray":
            import ray

            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
            try:
                run_sweep(scenario, points, Path(tmp) / "s", executor="ray")
            finally:
                ray.shutdown()
        else:
            run_sweep(scenario, points, Path(tmp) / "s", workers=workers)
        wall = time.perf_counter() - start
        simulated = sum(read_results(Path(tmp) / "s").column("sim_s").to_pylist())
    return wall, simulated


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=None)
    parser.add_argument("--scenario", default=None, help="default: the embedded letter")
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    n = args.runs or (8 if args.quick else 32)
    scenario = load_scenario(args.scenario)
    points = make_points([{}], tuple(range(n)))
    workers = available_cpus()
    blocks = 2 if args.quick else 3
    runners = {"serial loop (reference)": lambda: serial(scenario, points),
               f"process pool, {workers} workers": lambda: pooled(scenario, points, "process",
                                                                  workers)}
    try:
        import ray  # noqa: F401

        runners[f"Ray, local, {workers} CPUs"] = lambda: pooled(scenario, points, "ray", workers)
    except ImportError:
        print("(Ray not installed: its row left out)", file=sys.stderr)
    simulated: dict[str, list[float]] = {name: [] for name in runners}

    def case(name):
        wall, sim = runners[name]()
        simulated[name].append(sim)
        return wall

    result = interleave({name: functools.partial(case, name) for name in runners},
                        blocks=blocks, repeats=1, warmup=0, clock=None)
    reference = next(iter(runners))
    print(f"## Sweeps: {n} runs of {scenario.title!r}\n")
    print(f"The executors in {blocks} alternating blocks of one sweep each; wall times are the "
          "medians of the blocks.\n")
    print("| executor | wall [s] | runs/s | aggregate real-time factor | throughput ratio |")
    print("|---|---|---|---|---|")
    for name in runners:
        wall = result.median(name)
        sim = statistics.median(simulated[name])
        print(f"| {name} | {wall:.1f} | {n / wall:.2f} | {sim / wall:.1f} | "
              f"{1 / result.ratio(name, reference):.2f}x |")
    print(f"\n{result.load_line()}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
