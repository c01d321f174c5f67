"""GRBL plotter benchmarks: G-code generation, the planner model's time estimate, and streaming
to the emulator on a pseudo-terminal with character counting.

Run: ``python benchmarks/bench_plotter.py [--quick]``. Prints a markdown section with one table.
The reference, measured in the same run, is the job itself: the machine time the planner
model says a real GRBL takes to execute it. Ratios are machine time over wall time (how many
times faster than the plotter the step runs; > 1 means faster than real time). For the
emulator, the achieved line rate (lines per wall second) is set beside GRBL's ~400 lines/s,
and the emulator's execution time beside the estimate (their relative difference).

Jobs: the 2,000-line random walk of the tests (1 mm segments at 100 mm/s) and the word
``inkarm`` of ``scenarios/text_inkarm.toml`` (servo profile, strokes reordered).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
from blocks import interleave, timed

from inkarm.hardware.plotter.emulator import EmulatorConfig, GrblEmulator
from inkarm.hardware.plotter.gcode import drawing_to_gcode
from inkarm.hardware.plotter.profiles import load_profile
from inkarm.hardware.plotter.stream import GrblStreamer
from inkarm.hardware.plotter.timing import estimate_seconds
from inkarm.jobs.backends.plotter import page_size_mm, placed_on_sheet
from inkarm.jobs.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]


def random_walk(n: int) -> list[str]:
    rng = np.random.default_rng(0)
    pts = np.clip(100 + np.cumsum(rng.normal(0, 0.8, (n, 2)), axis=0), 5, 250)
    return (["G21 G90", "F6000", "M3 S1000", "G4 P0.1"]
            + [f"G1 X{x:.3f} Y{y:.3f}" for x, y in pts] + ["M5"])


def stream_once(lines: list[str], speedup: float) -> tuple[float, float, int]:
    """Wall time [s], emulator execution time [s] and bytes lost of one streamed job."""
    with GrblEmulator(EmulatorConfig(speedup=speedup)) as emu:
        s = GrblStreamer(emu.port, time_scale=speedup)
        s.wake()
        t0 = time.perf_counter()
        state = s.stream(lines)
        s.wait_idle(600)
        wall = time.perf_counter() - t0
        s.close()
        assert not state.failure, state.failure
        return wall, emu.stats.idle_since_s - emu.stats.first_line_s, emu.stats.bytes_dropped


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer blocks")
    args = parser.parse_args()
    blocks = 2 if args.quick else 3
    scenario = load_scenario(ROOT / "scenarios" / "text_inkarm.toml")
    drawing = placed_on_sheet(scenario, page_size_mm(scenario))
    profile = load_profile("servo")
    word = drawing_to_gcode(drawing, profile, optimise=True).lines
    walk = random_walk(2000)
    jobs = {"2,000-line walk": (walk, 10.0), "word 'inkarm'": (word, 2.0)}
    streamed: dict[str, list] = {name: [] for name in jobs}
    cases = {"gcode": timed(lambda: drawing_to_gcode(drawing, profile, optimise=True))}
    for name, (lines, speedup) in jobs.items():
        cases[f"estimate {name}"] = timed(lambda lines=lines: estimate_seconds(lines))

        def stream(name=name, lines=lines, speedup=speedup):
            streamed[name].append(stream_once(lines, speedup))
            return streamed[name][-1][0]

        cases[f"stream {name}"] = stream
    result = interleave(cases, blocks=blocks, warmup=0, clock=None,
                        repeats={n: 1 if n.startswith("stream") else 3 for n in cases})
    rows = []
    for name, (lines, speedup) in jobs.items():
        machine = estimate_seconds(lines)
        if name.startswith("word"):
            rows.append((f"G-code of {name} ({len(lines)} lines)", result.median("gcode"), machine))
        rows.append((f"estimate of {name}", result.median(f"estimate {name}"), machine))
        runs = streamed[name]
        wall = result.median(f"stream {name}")
        executed = statistics.median(r[1] for r in runs)
        lost = max(r[2] for r in runs)
        rows.append(((f"stream of {name} to the emulator at speed-up {speedup:g} "
                     f"({len(lines) / wall:.0f} lines/s wall; executed {executed:.2f} s, "
                     f"{100 * (executed / machine - 1):+.2f}% vs estimate; {lost} bytes lost)"),
                     wall, machine))
    print("## plotter: G-code, planner model and streaming to the GRBL emulator\n")
    print(f"The steps run in {blocks} alternating blocks (3 calls a block, one stream); wall "
          "times are medians of the blocks' medians. The reference is each job's machine time "
          "on GRBL's planner (the estimate, computed, not timed); ratio = machine time / wall "
          "time. GRBL executes about 400 lines/s at most.\n")
    print("| step | wall [s] | job machine time [s] | ratio |")
    print("|---|---|---|---|")
    for label, wall, machine in rows:
        print(f"| {label} | {wall:.3f} | {machine:.2f} | {machine / wall:.1f} |")
    print(f"\n{result.load_line()}\n")


if __name__ == "__main__":
    main()
