"""`inkarm write` of 10,000 characters: CPU time and peak memory of the whole command.

Run: ``python benchmarks/bench_write.py [--quick]``. The text is a pangram paragraph repeated
to 10,000 characters (8,024 letters), written in the default handstyle at a 1.5 mm letter
height (what fits one A4 page), to a temporary folder: drawing.csv, drawing.svg, write.png.
Each run is a fresh process, started with ``posix_spawn`` and reaped with ``os.wait4``, whose
rusage gives that child's CPU time (user + system) and peak resident memory (ru_maxrss).
The reference, ``python -c "import numpy"`` in a fresh process, runs in alternating blocks
with it (:mod:`blocks`), so the ratio carries from one machine to another; the absolute
figures stand beside the targets of the performance issue: at most 6 s of CPU and 300 MB.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
from pathlib import Path

from blocks import interleave

BIN = Path(sys.executable).parent
CHARACTERS = 10_000
HEIGHT_MM = 1.5
TARGET_CPU_S = 6.0
TARGET_RSS_MB = 300.0
PARAGRAPH = ("The quick brown fox jumps over the lazy dog. "
             "Pack my box with five dozen liquor jugs. ")


def text(characters: int = CHARACTERS) -> str:
    """The paragraph repeated and cut to ``characters`` characters."""
    return (PARAGRAPH * (characters // len(PARAGRAPH) + 1))[:characters]


def child(argv: list[str], err: Path) -> tuple[float, float]:
    """(CPU [s], peak RSS [MB]) of one run of ``argv`` in a fresh process: stdout discarded,
    stderr to ``err`` (its tail is shown if the run fails)."""
    files = [(os.POSIX_SPAWN_OPEN, 1, os.devnull, os.O_WRONLY, 0),
             (os.POSIX_SPAWN_OPEN, 2, str(err), os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)]
    pid = os.posix_spawn(argv[0], argv, os.environ, file_actions=files)
    _, status, usage = os.wait4(pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        tail = err.read_text(errors="replace")[-2000:]
        raise SystemExit(f"{' '.join(argv[:2])} ... exited with "
                         f"{os.waitstatus_to_exitcode(status)}:\n{tail}")
    return usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="two blocks instead of four")
    args = parser.parse_args()
    blocks = 2 if args.quick else 4
    rss: dict[str, list[float]] = {"write": [], "numpy": []}
    with tempfile.TemporaryDirectory() as tmp:
        write = [str(BIN / "inkarm"), "write", text(), "--out", str(Path(tmp) / "out"),
                 "--height", str(HEIGHT_MM)]
        numpy = [sys.executable, "-c", "import numpy"]

        def case(name: str, argv: list[str]):
            def run() -> float:
                cpu, peak = child(argv, Path(tmp) / "stderr.txt")
                rss[name].append(peak)
                return cpu
            return run

        result = interleave({"write": case("write", write), "numpy": case("numpy", numpy)},
                            blocks=blocks, repeats={"write": 1, "numpy": 3},
                            warmup=0 if args.quick else 1, clock=None)
    cpu, ref = result.median("write"), result.median("numpy")
    peak = statistics.median(rss["write"])
    print(f"## `inkarm write` of {CHARACTERS:,} characters (bench_write.py)\n")
    print(f"A pangram paragraph repeated to {CHARACTERS:,} characters, default handstyle, "
          f"{HEIGHT_MM} mm letters; fresh processes, CPU time (user + system) and peak RSS "
          f"from os.wait4; {blocks} alternating blocks against `python -c \"import numpy\"`, "
          "ratio of the medians of the blocks. " + result.load_line() + "\n")
    print("| command | median CPU [s] | CPU / reference | peak RSS [MB] | spread of blocks |")
    print("|---|---|---|---|---|")
    print(f"| `inkarm write` | {cpu:.2f} | {cpu / ref:.0f}x | {peak:.0f} | "
          f"{result.spread('write'):.2f} |")
    print(f"| `python -c \"import numpy\"` (reference) | {ref:.3f} | 1x | "
          f"{statistics.median(rss['numpy']):.0f} | {result.spread('numpy'):.2f} |")
    verdicts = [("CPU", cpu, TARGET_CPU_S, "s"), ("peak RSS", peak, TARGET_RSS_MB, "MB")]
    print("\nTargets (the performance issue): " + "; ".join(
        f"{what} at most {target:g} {unit}: {value:.3g} {unit}, "
        f"{'meets' if value <= target else 'misses'} it"
        for what, value, target, unit in verdicts) + f" (6 s is {TARGET_CPU_S / ref:.0f}x the "
        "reference on this machine).")
    return 0


if __name__ == "__main__":
    sys.exit(main())
