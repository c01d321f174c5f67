"""Run every benchmark script in this folder and write BENCHMARKS.md.

Each ``bench_*.py`` prints a markdown section (heading, table of medians and ratios against a
reference measured in the same run) on stdout. This script stamps the date and the machine on
top and, with ``--write``, replaces BENCHMARKS.md at the repository root.

    python benchmarks/run_all.py [--write] [--only NAME ...]
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import platform
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def machine_line() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, {platform.system()}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="write BENCHMARKS.md")
    parser.add_argument("--only", nargs="*", default=None, help="bench names, e.g. models dppla")
    args = parser.parse_args()
    scripts = sorted(HERE.glob("bench_*.py"))
    if args.only:
        scripts = [s for s in scripts if s.stem.removeprefix("bench_") in args.only]
    sections = []
    for script in scripts:
        print(f"running {script.name} ...", file=sys.stderr, flush=True)
        done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, check=False)
        if done.returncode != 0:
            sys.stderr.write(done.stderr)
            sections.append(f"## {script.stem}\n\nFAILED (exit {done.returncode})\n")
        else:
            sections.append(done.stdout.strip() + "\n")
    header = (
        "# inkarm benchmarks\n\n"
        f"Measured {dt.date.today().isoformat()} on {machine_line()}.\n"
        "Times are medians of repeated runs; every target is also checked as a ratio against a "
        "reference measured in the same run, so the ratios carry over between machines.\n"
        "Regenerate with `make bench` (or `python benchmarks/run_all.py --write`).\n\n"
        "On a shared VM, repeated runs of the same benchmark can differ by 1.6x from minute to "
        "minute (another tenant on the same physical core); minima and best runs are given "
        "beside medians for that reason.\n"
    )
    text = header + "\n" + "\n".join(sections)
    print(text)
    if args.write:
        (HERE.parent / "BENCHMARKS.md").write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
