"""Benchmarks of the movement models (inkarm.models): the Gaussian-target LQT of seed 000.

Prints a markdown section: median wall times (time.perf_counter), peak memory (tracemalloc) and
ratios against the dense batch solver (eq. 13) measured in the same run, each checked against the
issue's target.

    python benchmarks/bench_models.py [--quick] [--append]

--append adds the section, stamped with the date and the machine, to BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import datetime as dt
import statistics
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

from inkarm.core.plan import StrokePlan
from inkarm.models.lqt import LQTConfig, sample, solve

HERE = Path(__file__).resolve().parent
SEGMENT, DT = 0.5, 0.01  # 50 steps per target


def median_time(fn, repeat: int, warmup: int = 10) -> float:
    """Median wall time of fn() in [s]."""
    return timings(fn, repeat, warmup)[0]


def timings(fn, repeat: int, warmup: int = 10) -> tuple[float, float]:
    """(median, minimum) wall time of fn() in [s]."""
    for _ in range(warmup):
        fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), min(times)


def peak_memory(fn) -> float:
    """Peak traced allocation of fn() in [MB] (numpy buffers included)."""
    fn()
    tracemalloc.start()
    tracemalloc.reset_peak()
    fn()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 1e6


def plan(n_steps: int, dim: int = 2, seed: int = 0) -> StrokePlan:
    """A random walk of targets 50-100 mm apart, variance 100 mm^2, N = n_steps."""
    rng = np.random.default_rng(seed)
    m = n_steps // round(SEGMENT / DT)
    steps = rng.normal(size=(m - 1, dim))
    steps *= rng.uniform(50, 100, (m - 1, 1)) / np.linalg.norm(steps, axis=1, keepdims=True)
    means = np.vstack([np.zeros(dim), np.cumsum(steps, axis=0)])
    return StrokePlan.from_arrays(means, 100.0, segment_time=SEGMENT)


def lqt_rows(quick: bool) -> list[tuple[str, str, str, str]]:
    """(case, measured, target, verdict) rows."""
    rep = 30 if quick else 200
    rows = []
    small, large = plan(200), plan(10_000)
    cfg = LQTConfig(order=4, dt=DT, d=5.0)

    fast, fastest = timings(lambda: solve(small, cfg), rep * 5)
    batch_cfg = LQTConfig(order=4, dt=DT, d=5.0, solver="batch")
    batch = median_time(lambda: solve(small, batch_cfg), 3 if quick else 7, warmup=1)
    ratio = batch / fast
    rows.append(
        (
            "mean, order 4, D 2, N 200 (median; min)",
            f"{fast * 1e3:.3f} ms; {fastest * 1e3:.3f} ms",
            "<= 0.25 ms",
            _ok(fast <= 0.25e-3),
        )
    )
    rows.append(("batch eq. 13 (lstsq), same plan", f"{batch * 1e3:.1f} ms", "reference", ""))
    rows.append(("speed-up fast / batch", f"{ratio:.0f}x", ">= 300x", _ok(ratio >= 300)))

    big = median_time(lambda: solve(large, cfg), 5 if quick else 30)
    mem = peak_memory(lambda: solve(large, cfg))
    rows.append(
        ("mean, order 4, D 2, N 10,000", f"{big * 1e3:.2f} ms", "<= 15 ms", _ok(big <= 15e-3))
    )
    rows.append(("peak memory, N 10,000", f"{mem:.1f} MB", "<= 50 MB", _ok(mem <= 50)))
    rows.append(
        (
            "time per step, N 10,000 / N 200",
            f"{(big / 10_000) / (fast / 200):.2f}",
            "~1 (linear)",
            "",
        )
    )

    draws = median_time(lambda: sample(small, cfg, k=100, seed=0), 10 if quick else 50)
    rows.append(
        ("100 exact samples, N 200", f"{draws * 1e3:.2f} ms", "<= 5 ms", _ok(draws <= 5e-3))
    )

    for order in (6, 7):
        high = LQTConfig(order=order, dt=DT, d=5.0)
        t_small = median_time(lambda high=high: solve(small, high), rep // 2)
        t_large = median_time(lambda high=high: solve(large, high), 3 if quick else 10)
        rows.append(
            (
                f"mean, order {order} (augmented), N 200 / 10,000",
                f"{t_small * 1e3:.3f} / {t_large * 1e3:.1f} ms",
                "info",
                "",
            )
        )
    for solver in ("cholesky", "augmented"):
        c = LQTConfig(order=4, dt=DT, d=5.0, solver=solver)
        t = median_time(lambda c=c: solve(small, c), rep)
        rows.append((f"mean, order 4, solver={solver}, N 200", f"{t * 1e3:.3f} ms", "info", ""))
    zoh = LQTConfig(order=4, dt=DT, d=5.0, discretisation="zoh")
    t = median_time(lambda: solve(small, zoh), rep)
    rows.append(("mean, order 4, zero-order hold, N 200", f"{t * 1e3:.3f} ms", "info", ""))
    return rows


def _ok(passed: bool) -> str:
    return "ok" if passed else "MISSED"


def lqt_section(quick: bool = False) -> str:
    lines = [
        "## models: Gaussian-target LQT (seed 000)",
        "",
        (
            "Random walks of spherical targets 50-100 mm apart, variance 100 mm^2, d = 5 mm, "
            "segments of 0.5 s, dt = 0.01 s (50 steps per target). Medians of repeated runs."
        ),
        "",
        "| case | measured | target | |",
        "|---|---|---|---|",
    ]
    lines += [f"| {a} | {b} | {c} | {d} |" for a, b, c, d in lqt_rows(quick)]
    return "\n".join(lines) + "\n"


SECTIONS = [lqt_section]  # one function per model, each returning a markdown section


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repetitions")
    parser.add_argument(
        "--append", action="store_true", help="append to BENCHMARKS.md with date and machine"
    )
    args = parser.parse_args()
    text = "\n".join(make(args.quick) for make in SECTIONS)
    print(text)
    if args.append:
        sys.path.insert(0, str(HERE))
        from run_all import machine_line

        stamp = f"\nMeasured {dt.date.today().isoformat()} on {machine_line()}.\n\n"
        with open(HERE.parent / "BENCHMARKS.md", "a") as f:
            f.write(stamp + text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
