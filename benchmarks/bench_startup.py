"""Start-up: the CPU that `inkarm --help` costs against a bare `python -c "import numpy"`.

Run: ``python benchmarks/bench_startup.py [--blocks N]``. Each block starts both commands in
fresh processes, alternately (the order swapped every block), and reads their CPU time (user +
system, from ``resource.getrusage(RUSAGE_CHILDREN)``: what the process itself burnt, not the
wall time another tenant stretches); the verdict is the ratio of the medians over the blocks,
with the load average beside. Target (the performance issue): ``inkarm --help`` at most 3x the
reference.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
from pathlib import Path

BIN = Path(sys.executable).parent
TARGET = 3.0
COMMANDS = {
    "inkarm --help": [str(BIN / "inkarm"), "--help"],
    'python -c "import numpy" (reference)': [sys.executable, "-c", "import numpy"],
}


def cpu_seconds(command: list[str]) -> float:
    """User + system CPU [s] of one run of ``command``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blocks", type=int, default=15)
    args = parser.parse_args()
    cpu: dict[str, list[float]] = {name: [] for name in COMMANDS}
    loads = []
    for block in range(args.blocks):
        order = list(COMMANDS.items())
        for name, command in order if block % 2 == 0 else order[::-1]:
            cpu[name].append(cpu_seconds(command))
        loads.append(os.getloadavg()[0])
    (subject, reference) = (statistics.median(v) for v in cpu.values())
    ratio = subject / reference
    print("## Start-up: `inkarm --help` against a bare interpreter (bench_startup.py)\n")
    print(f"CPU time (user + system) of fresh processes, {args.blocks} alternating blocks; load "
          f"average {min(loads):.1f}..{max(loads):.1f}.\n")
    print("| command | median CPU [ms] | least [ms] |")
    print("|---|---|---|")
    for name, values in cpu.items():
        print(f"| {name} | {1000 * statistics.median(values):.0f} | {1000 * min(values):.0f} |")
    verdict = "meets" if ratio <= TARGET else "misses"
    print(f"\nTarget: `inkarm --help` at most {TARGET:g}x the reference: {ratio:.2f}x, {verdict} "
          "it.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
