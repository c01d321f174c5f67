"""The long hostile-input campaign: every fuzz test with N generated cases each, then a count
of the cases run and of the failures (tracebacks, hangs, memory blow-ups, failures reported as
success: each is a failing test with its reproducer printed by hypothesis).

    python scripts/fuzz_campaign.py --examples 100 [-k surfaces] [--seed S]

Writes nothing but pytest's and hypothesis's caches; prints one line per test and the total.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PASSING = re.compile(r"^(tests/fuzz/\S+::\S+):\s*$|^\s+- (\d+) passing, (\d+) failing",
                     re.MULTILINE)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=100, help="cases per test")
    parser.add_argument("-k", dest="select", default=None, help="pytest -k expression")
    parser.add_argument("--seed", type=int, default=None, help="hypothesis seed")
    args = parser.parse_args(argv)
    if args.examples < 1:
        parser.error("--examples must be >= 1")
    env = os.environ | {"INKARM_FUZZ_EXAMPLES": str(args.examples)}
    command = [sys.executable, "-m", "pytest", "tests/fuzz", "-p", "no:cacheprovider",
               "--hypothesis-show-statistics", "-m", "fuzz"]
    command += ["-k", args.select] if args.select else []
    command += [f"--hypothesis-seed={args.seed}"] if args.seed is not None else []
    start = time.monotonic()
    result = subprocess.run(command, check=False, cwd=ROOT, env=env, capture_output=True, text=True)
    cases, test = {}, None
    for match in PASSING.finditer(result.stdout):
        if match.group(1):
            test = match.group(1)
        elif test is not None:
            cases[test] = cases.get(test, 0) + int(match.group(2)) + int(match.group(3))
    for name, count in sorted(cases.items()):
        print(f"{count:6d}  {name}")
    summary = next((line for line in reversed(result.stdout.splitlines())
                    if re.search(r"\d+ (passed|failed)", line)), "no summary")
    print(f"{sum(cases.values()):6d}  cases in {time.monotonic() - start:.0f} s; pytest: "
          f"{summary}")
    if result.returncode != 0:
        print(result.stdout[-6000:], file=sys.stderr)
    return result.returncode


if __name__ == "__main__":
    sys.exit(main())
