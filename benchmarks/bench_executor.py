"""The one executor against the loop it replaced: the single run must not get slower.

Run: ``python benchmarks/bench_executor.py [--reference COMMIT] [--blocks N] [--cpu N]``.

The default scenario's drawing (the letter N: 828 control periods, planning included) is drawn
by ``run_drawing`` on :class:`inkarm.sim.plant.MujocoPlant` in fresh processes pinned to one
core, alternately with this tree and with the reference commit (default: the last commit with
``inkarm/control/loop.py``, the loop before the executor), exported with ``git archive`` into a
temporary folder and imported from there. Each process draws it three times and reports its
fastest (on a shared machine other processes only add time); the verdict is the ratio of the
medians over the blocks (this tree / the reference), with the load average beside. The target:
within 5 % (a ratio <= 1.05). The ensemble's cost per member is measured as well: 16 members of
``scenarios/realistic_iiwa.toml`` batched in one process, against 16 single runs, in the same
alternation.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TARGET = 1.05

# Imports only what both trees have; ``run_drawing`` moved from control.loop to control.executor.
DRAW = r"""
import os, sys, time
os.sched_setaffinity(0, {__CPU__})
from inkarm.jobs.scenario import load_scenario, place, source_drawing
from inkarm.sim.cell import Cell, kinematic_model
from inkarm.sim.perturb import plant_model
from inkarm.sim.plant import MujocoPlant
try:
    from inkarm.control.executor import run_drawing
except ImportError:
    from inkarm.control.loop import run_drawing
s = load_scenario()
cell = Cell(s.cell, s.robot)
drawing = place(source_drawing(s), s.placement, cell.paper_size_mm)
believed = kinematic_model(cell)
times = []
for _ in range(3):
    truth = s.plant.realised()
    plant = MujocoPlant(plant_model(cell, truth), cell=cell, canvas=s.ink.canvas(cell.paper_size_mm),
                        substeps=3, truth=truth, drive_gains=s.robot.drive)
    t0 = time.perf_counter()
    log = run_drawing(drawing, plant, believed, s.robot.gains, s.controller,
                      speed_limits=s.robot.speed_limits)
    times.append(time.perf_counter() - t0)
print(min(times), len(log))
"""

ENSEMBLE = r"""
import os, sys, time
os.sched_setaffinity(0, {__CPU__})
from inkarm.jobs.ensemble import run_ensemble
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario
s = load_scenario("__ROOT__/scenarios/realistic_iiwa.toml")
seeds = list(range(16))
t0 = time.perf_counter()
batched = run_ensemble(s, seeds, processes=1, nthread=1)
t1 = time.perf_counter()
alone = [run(s.with_overrides({"plant.seed": k})) for k in seeds]
t2 = time.perf_counter()
print((t1 - t0) / len(seeds), (t2 - t1) / len(seeds))
"""


def reference_tree(commit: str, into: Path) -> Path:
    """``commit``'s inkarm package and scenarios exported into ``into`` (nothing in this
    checkout changes)."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit, "inkarm", "scenarios"],
                             capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def timed(code: str, tree: Path) -> list[float]:
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         check=True, cwd=tempfile.gettempdir()).stdout.split()
    return [float(x) for x in out]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", default="9a621d3", help="commit of the old loop")
    parser.add_argument("--blocks", type=int, default=9, help="A/B blocks (fresh processes)")
    parser.add_argument("--cpu", type=int, default=0, help="core to pin to")
    parser.add_argument("--no-ensemble", action="store_true", help="skip the ensemble rows")
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="inkarm-bench-"))
    try:
        trees = {"this tree": ROOT, f"reference {args.reference}":
                 reference_tree(args.reference, work)}
        draw = DRAW.replace("__CPU__", str(args.cpu))
        runs: dict[str, list[float]] = {name: [] for name in trees}
        loads = []
        for block in range(args.blocks):
            order = list(trees.items()) if block % 2 == 0 else list(trees.items())[::-1]
            for name, tree in order:
                runs[name].append(timed(draw, tree)[0])
            loads.append(os.getloadavg()[0])
        ensemble = {}
        if not args.no_ensemble:
            code = ENSEMBLE.replace("__CPU__", str(args.cpu))
            for name, tree in trees.items():  # (each tree's own scenario file)
                ensemble[name] = timed(code.replace("__ROOT__", str(tree)), tree)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    (new, old) = (statistics.median(v) for v in runs.values())
    ratio = new / old
    print("## executor: the one executor against the loop it replaced (bench_executor.py)\n")
    print(f"The default letter (828 control periods, planning included), `run_drawing` on one "
          f"core in fresh processes, {args.blocks} alternating blocks (fastest of 3 draws per "
          f"process); load average {min(loads):.1f}..{max(loads):.1f}.\n")
    print("| tree | median [ms] | fastest [ms] | ratio to the reference |")
    print("|---|---|---|---|")
    for name, values in runs.items():
        print(f"| {name} | {1000 * statistics.median(values):.1f} | {1000 * min(values):.1f} | "
              f"{statistics.median(values) / old:.3f} |")
    verdict = "meets" if ratio <= TARGET else "misses"
    print(f"\nTarget: this tree within {100 * (TARGET - 1):.0f} % of the reference: "
          f"ratio {ratio:.3f}, {verdict} it.")
    if ensemble:
        print("\nEnsemble of 16 members of `realistic_iiwa.toml` in one process (one MuJoCo "
              "thread), wall time per member [ms]:\n")
        print("| tree | batched | one run each | batched / one run each |")
        print("|---|---|---|---|")
        for name, (batched, alone) in ensemble.items():
            print(f"| {name} | {1000 * batched:.1f} | {1000 * alone:.1f} | "
                  f"{batched / alone:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
