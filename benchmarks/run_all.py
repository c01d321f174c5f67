"""Run every benchmark script in this folder and write BENCHMARKS.md.

Each ``bench_*.py`` prints a markdown section (heading, table of medians and ratios against a
reference measured in the same run, in alternating blocks, with the load average beside it) on
stdout. This script runs them one after another in fresh processes, reports progress on stderr
(each script's time and the load average before and after), stamps the date and the machine on
top and, with ``--write``, replaces BENCHMARKS.md at the repository root.

A script that fails (non-zero exit, or still running after 30 minutes) gets a section saying FAILED with the tail of its stderr,
the others still run, and this script exits with 1 at the end (BENCHMARKS.md is still written,
so that the failure is seen there too).

    python benchmarks/run_all.py [--write] [--quick] [--only NAME ...]
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
STDERR_TAIL = 20  # lines of a failed script's stderr kept in its section
TIMEOUT_S = 1800  # a script still running after this long has failed (hung) [s]


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


def command(script: Path, quick: bool) -> list[str]:
    """The script's command line; ``--quick`` only where the script knows the flag."""
    wants = quick and "--quick" in script.read_text()
    return [sys.executable, str(script), *(["--quick"] if wants else [])]


def run_one(script: Path, quick: bool) -> tuple[str, bool]:
    """(markdown section, succeeded) of one script, with its progress on stderr."""
    load = os.getloadavg()[0]
    print(f"running {script.name} ... (load {load:.1f})", file=sys.stderr, flush=True)
    start = time.perf_counter()
    try:
        done = subprocess.run(command(script, quick), capture_output=True, text=True,
                              check=False, timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired as e:
        stderr = e.stderr.decode(errors="replace") if isinstance(e.stderr, bytes) else e.stderr
        done = subprocess.CompletedProcess(e.cmd, f"timed out after {TIMEOUT_S} s", "",
                                           (stderr or "") + f"\nkilled after {TIMEOUT_S} s")
    seconds = time.perf_counter() - start
    ok = done.returncode == 0
    print(f"  {script.name}: {'ok' if ok else f'FAILED (exit {done.returncode})'} in "
          f"{seconds:.0f} s (load {load:.1f} -> {os.getloadavg()[0]:.1f})",
          file=sys.stderr, flush=True)
    if ok:
        return done.stdout.strip() + "\n", True
    sys.stderr.write(done.stderr)
    tail = "\n".join(done.stderr.strip().splitlines()[-STDERR_TAIL:])
    return (f"## {script.stem}: FAILED\n\n**FAILED** (exit {done.returncode}) after "
            f"{seconds:.0f} s; the end of its stderr:\n\n```\n{tail}\n```\n"), False


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="write BENCHMARKS.md")
    parser.add_argument("--quick", action="store_true",
                        help="pass --quick to every script that has it (a smoke run)")
    parser.add_argument("--only", nargs="*", default=None, help="bench names, e.g. models dppla")
    args = parser.parse_args()
    scripts = sorted(HERE.glob("bench_*.py"))
    if args.only:
        unknown = set(args.only) - {s.stem.removeprefix("bench_") for s in scripts}
        if unknown:
            parser.error(f"--only: no benchmarks/bench_NAME.py for {sorted(unknown)}")
        scripts = [s for s in scripts if s.stem.removeprefix("bench_") in args.only]
    start = time.perf_counter()
    results = [run_one(script, args.quick) for script in scripts]
    minutes = (time.perf_counter() - start) / 60
    failed = [s.name for s, (_, ok) in zip(scripts, results) if not ok]
    print(f"{len(scripts)} benchmarks in {minutes:.1f} min; "
          + (f"FAILED: {', '.join(failed)}" if failed else "all ok"), file=sys.stderr)
    header = (
        "# inkarm benchmarks\n\n"
        f"Measured {dt.date.today().isoformat()} on {machine_line()}"
        + (", with `--quick`" if args.quick else "") + f"; {len(scripts)} scripts in "
        f"{minutes:.0f} min.\n"
        "Every target is a ratio against a reference measured in the same run: subject and "
        "reference run in alternating blocks (several repeats a block), each side's time is "
        "the median of its blocks' medians, and the ratio is taken on those medians, so that a "
        "burst of load on a shared machine spoils a block, not the ratio. The load average "
        "before and after is written beside each table.\n"
        "Regenerate with `make bench` (or `python benchmarks/run_all.py --write`).\n"
        + (f"\n**FAILED: {', '.join(failed)}** (sections below).\n" if failed else "")
    )
    text = header + "\n" + "\n".join(section for section, _ in results)
    print(text)
    if args.write:
        (HERE.parent / "BENCHMARKS.md").write_text(text)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
