"""Memory of a drawing run against the page raster: peak RSS and wall time of the default
scenario (60 mm letter N, marker, A4) drawn and written (``inkarm.run`` + ``inkarm.write_run``,
report included) at several raster resolutions, each in a fresh process.

Run: ``python benchmarks/bench_memory.py [--quick] [--ppm 10 20 40]``. Prints a markdown section:
a table of px/mm, page pixels, peak RSS (``ru_maxrss`` of the child, from ``os.wait4``) and
wall time (run, write; the resolutions in ``--repeats`` alternating blocks, medians, the load
average beside), then the least-squares line peak RSS = constant + bytes/px x page pixels, set
beside :data:`inkarm.ink.canvas.RASTER_BYTES_PER_PX`, the bytes per page pixel
that the memory budget (``INKARM_MAX_MEMORY_MB``) charges a job for its raster. The fitted
slope must stay below it (the target). A fresh process that only imports what a run imports
(inkarm, MuJoCo, matplotlib) gives the baseline the constant is compared with.

The children run with ``INKARM_MAX_MEMORY_MB`` raised, so that the budget check (an estimate)
does not stop the measurement of what it estimates.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
from blocks import interleave

DEFAULT_PPM = (10.0, 20.0, 40.0)

CHILD = r"""
import json, sys, time
import inkarm
ppm, out = float(sys.argv[1]), sys.argv[2]
scenario = inkarm.load_scenario().with_overrides({"ink.px_per_mm": ppm})
t0 = time.perf_counter()
run = inkarm.run(scenario)
t1 = time.perf_counter()
inkarm.write_run(run, out)
t2 = time.perf_counter()
print(json.dumps({"pixels": int(run.canvas.shape[0]) * int(run.canvas.shape[1]),
                  "status": run.status, "run_s": t1 - t0, "write_s": t2 - t1}))
"""

IMPORT_ONLY = "import inkarm, inkarm.jobs.run, inkarm.plots.report, inkarm.sim.plant, mujoco"


def measure_child(code: str, *args: str) -> tuple[dict, float, float]:
    """Run ``python -c code args`` in a fresh process: (its last stdout line as JSON, or {};
    its peak RSS [bytes], from ``os.wait4`` on that very child; wall time [s])."""
    env = {**os.environ, "INKARM_MAX_MEMORY_MB": "1000000"}
    with tempfile.TemporaryDirectory() as tmp, tempfile.TemporaryFile("w+") as out, \
            tempfile.TemporaryFile("w+") as err:
        start = time.perf_counter()
        child = subprocess.Popen([sys.executable, "-c", code, *args], cwd=tmp, env=env,
                                 stdout=out, stderr=err, text=True)
        _, status, usage = os.wait4(child.pid, 0)
        wall = time.perf_counter() - start
        child.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
    if child.returncode != 0:
        raise RuntimeError(f"child failed ({child.returncode}):\n{stderr}")
    lines = stdout.strip().splitlines()
    return (json.loads(lines[-1]) if lines else {}), usage.ru_maxrss * 1024.0, wall


def section(ppms, repeats: int) -> str:
    try:
        from inkarm.ink.canvas import RASTER_BYTES_PER_PX as budget
    except ImportError:  # an inkarm from before the budget
        budget = float("nan")
    children: dict[str, list] = {"import": [], **{f"{ppm:g}": [] for ppm in ppms}}

    def child(name: str, code: str, *args: str) -> float:
        children[name].append(measure_child(code, *args))
        return children[name][-1][2]

    cases = {"import": functools.partial(child, "import", IMPORT_ONLY),
             **{f"{ppm:g}": functools.partial(child, f"{ppm:g}", CHILD, str(ppm), "out")
                for ppm in ppms}}
    result = interleave(cases, blocks=repeats, repeats=1, warmup=0, clock=None)
    base_rss = min(r[1] for r in children["import"])
    rows, pixels, peaks = [], [], []
    for ppm in ppms:
        runs = children[f"{ppm:g}"]
        info = runs[0][0]
        peak = min(r[1] for r in runs)
        wall = result.median(f"{ppm:g}")
        run_s = statistics.median(r[0]["run_s"] for r in runs)
        write_s = statistics.median(r[0]["write_s"] for r in runs)
        pixels.append(info["pixels"])
        peaks.append(peak)
        rows.append(f"| {ppm:g} | {info['pixels'] / 1e6:.1f} M | {peak / 2**20:.0f} MB | "
                    f"{(peak - base_rss) / info['pixels']:.1f} | {wall:.1f} s | {run_s:.1f} s | "
                    f"{write_s:.1f} s | {info['status']} |")
    slope, constant = np.polyfit(np.asarray(pixels, float), np.asarray(peaks, float), 1) \
        if len(pixels) > 1 else (float("nan"), float("nan"))
    ok = slope <= budget
    lines = [
        "## Memory of a run against the page raster (bench_memory.py)",
        "",
        "The default scenario (60 mm letter N, marker, A4) drawn and written, report included, "
        "in a fresh process per resolution; peak RSS is the child's `ru_maxrss`"
        + (f" (least of {repeats}; the resolutions and the import-only process in {repeats} "
           "alternating blocks, wall times their medians)" if repeats > 1 else "") + ". "
        f"A process that only imports what a run imports peaks at {base_rss / 2**20:.0f} MB "
        f"({result.median('import'):.1f} s).",
        "",
        "| px/mm | page pixels | peak RSS | bytes/px above import | wall | run | write | status |",
        "|---|---|---|---|---|---|---|---|",
        *rows,
        "",
        f"Least-squares fit: peak RSS = {constant / 2**20:.0f} MB + {slope:.1f} bytes x page "
        f"pixels. The memory budget charges {budget:g} bytes per page pixel "
        f"(`inkarm.ink.canvas.RASTER_BYTES_PER_PX`): "
        + ("**met**" if ok else "**NOT met**") + " (fitted slope <= charged bytes/px).",
        "",
        result.load_line(),
    ]
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="10 and 20 px/mm only, once each")
    parser.add_argument("--ppm", type=float, nargs="*", default=None, help="resolutions [px/mm]")
    parser.add_argument("--repeats", type=int, default=3,
                        help="alternating blocks (runs per resolution)")
    args = parser.parse_args()
    ppms = args.ppm or ((10.0, 20.0) if args.quick else DEFAULT_PPM)
    print(section(ppms, 1 if args.quick else args.repeats))
    return 0


if __name__ == "__main__":
    sys.exit(main())
