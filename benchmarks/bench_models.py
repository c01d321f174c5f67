"""Benchmarks of the movement models (inkarm.models): the Gaussian-target LQT of seed 000.

Prints a markdown section. Each verdict is a ratio against a reference measured in the same
run, in alternating blocks (:mod:`blocks`: subject, reference, subject, ...; a block's time is
the median of its calls, a case's the median of its blocks), with the load average beside
each table. The reference of the mean is ONE ``scipy.linalg.solveh_banded`` call (defaults,
``lower=True``) on the same banded normal matrix H (size, bandwidth) and the same right-hand
side A^T b, both built once: the banded Cholesky factorisation and solve that a plain NumPy
program of the same problem pays per stroke. The subject is ``solve(plan, config)``, the whole
public call (checks, assembly, solve, one step of refinement where the conditioning asks for
it, the Trajectory); after its first call the stroke's shape is kept
(:mod:`inkarm.models.lqt.structure`), so a call pays the back-substitutions, not the
factorisation, and (held targets, as here) A^T b straight from the means. Rows marked info have no target: a new stroke of the same shape each call, a
cold solve (nothing kept), the exact draws against their LAPACK floor, the dense oracle.

    python benchmarks/bench_models.py [--quick]
"""

from __future__ import annotations

import argparse
import sys
import tracemalloc

import numpy as np
from blocks import interleave
from scipy.linalg import lapack, solveh_banded

from inkarm.core.plan import StrokePlan
from inkarm.models.lqt import LQT, LQTConfig, sample, solve, structure
from inkarm.models.lqt.normal import normal_band, obs_band, rhs

SEGMENT, DT = 0.5, 0.01  # 50 steps per target
CFG = LQTConfig(order=4, dt=DT, d=5.0)
TARGETS = {200: 1.5, 10_000: 1.2, 100_000: 1.2}  # N -> largest ratio to one solveh_banded


def plan(n_steps: int, dim: int = 2, seed: int = 0) -> StrokePlan:
    """A random walk of targets 50-100 mm apart, variance 100 mm^2, N = n_steps."""
    rng = np.random.default_rng(seed)
    m = n_steps // round(SEGMENT / DT)
    steps = rng.normal(size=(m - 1, dim))
    steps *= rng.uniform(50, 100, (m - 1, 1)) / np.linalg.norm(steps, axis=1, keepdims=True)
    means = np.vstack([np.zeros(dim), np.cumsum(steps, axis=0)])
    return StrokePlan.from_arrays(means, 100.0, segment_time=SEGMENT)


def reference(stroke: StrokePlan, cfg: LQTConfig = CFG):
    """One solveh_banded of the stroke's normal matrix and right-hand side (built here, once)."""
    prob = LQT(stroke, cfg).problem
    band = normal_band(prob, obs_band(prob))
    b = rhs(prob).reshape(-1)
    return lambda: solveh_banded(band, b, lower=True), band, b


def cold(stroke: StrokePlan, cfg: LQTConfig = CFG):
    """solve() with nothing kept: assembly and factorisation included."""
    def run():
        structure.clear()
        return solve(stroke, cfg)
    return run


def draws_floor(band: np.ndarray, b: np.ndarray, k: int):
    """The LAPACK floor of k exact draws: the mean (one solveh_banded) and L^-T z for k
    standard normal vectors z (one banded triangular solve with k right-hand sides)."""
    chol = lapack.dpbtrf(band, lower=1)[0]
    rng = np.random.default_rng(0)

    def run():
        solveh_banded(band, b, lower=True)
        return lapack.dtbtrs(chol, rng.standard_normal((b.size, k)), uplo="L", trans="T")
    return run


def peak_memory_mb(fn) -> float:
    """Peak traced allocation of fn() in [MB] (NumPy buffers included)."""
    fn()
    tracemalloc.start()
    tracemalloc.reset_peak()
    fn()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 1e6


def _row(case: str, res, subject: str, target: float | None = None) -> str:
    ratio = res.ratio(subject, "reference")
    verdict = "info" if target is None else ("ok" if ratio <= target else "MISSED")
    goal = "" if target is None else f"<= {target:g}x"
    return (f"| {case} | {res.median(subject) * 1e3:.3f} ms | "
            f"{res.median('reference') * 1e3:.3f} ms | {ratio:.2f}x | {goal} | {verdict} |")


HEADER = ["| case | subject | reference | ratio | target | |", "|---|---|---|---|---|---|"]


def small_table(quick: bool) -> list[str]:
    """N = 200: the mean against one solveh_banded (its own blocks), then the informative
    cases (blocks of their own, against the same reference)."""
    stroke = plan(200)
    ref, band, b = reference(stroke)
    blocks, repeats = (5, 20) if quick else (11, 100)
    verdict = interleave({"mean": lambda: solve(stroke, CFG), "reference": ref},
                         blocks=blocks, repeats=repeats, warmup=20)
    others = [plan(200, seed=s) for s in range(1, 9)]  # same shape, other means
    turn = iter(range(10**9))
    cases = {
        "reference": ref,
        "new stroke": lambda: solve(others[next(turn) % len(others)], CFG),
        "cold": cold(stroke),
        "draws": lambda: sample(stroke, CFG, k=100, seed=0),
        "draws floor": draws_floor(band, b, 100),
    }
    for name, cfg in (("order 6", LQTConfig(order=6, dt=DT, d=5.0)),
                      ("order 7", LQTConfig(order=7, dt=DT, d=5.0)),
                      ("zoh", LQTConfig(order=4, dt=DT, d=5.0, discretisation="zoh"))):
        cases[name] = lambda c=cfg: solve(stroke, c)
    info = interleave(cases, blocks=blocks, repeats=repeats // 4, warmup=5)
    well = LQTConfig(order=4, dt=DT, d=1000.0)  # loss < 1e-9: no refinement
    res_well = interleave({"well": lambda: solve(stroke, well),
                           "reference": reference(stroke, well)[0]},
                          blocks=blocks, repeats=repeats, warmup=20)
    draws = info.ratio("draws", "draws floor")
    return [
        "N = 200 (4 targets), order 4, D 2: " + verdict.load_line(), "", *HEADER,
        _row("mean, `solve(plan, config)`, refined (loss 7e-6)", verdict, "mean", TARGETS[200]),
        _row("info: d = 1000 mm, no refinement asked (loss < 1e-9)", res_well, "well"),
        _row("info: a new stroke of the same shape each call", info, "new stroke"),
        _row("info: cold (nothing kept: assembly + factorisation)", info, "cold"),
        _row("info: order 6 (augmented system)", info, "order 6"),
        _row("info: order 7 (augmented system)", info, "order 7"),
        _row("info: zero-order hold (augmented: no bound on its conditioning)", info, "zoh"),
        (f"| info: 100 exact draws, `sample(plan, config, k=100)` | "
         f"{info.median('draws') * 1e3:.3f} ms | {info.median('draws floor') * 1e3:.3f} ms "
         f"(LAPACK floor: mean + L^-T z) | {draws:.2f}x | | info |"),
        "", "Info rows: " + info.load_line(),
    ]


def large_table(quick: bool) -> list[str]:
    """N = 1,000 (info), 10,000 and 100,000: the mean against one solveh_banded."""
    lines = []
    for n_steps in (1_000, 10_000, 100_000):
        stroke = plan(n_steps)
        ref = reference(stroke)[0]
        cases = {"mean": lambda s=stroke: solve(s, CFG), "reference": ref}
        big = n_steps > 10_000
        repeats = 50 if n_steps < 10_000 else 10  # blocks of ~5-10 ms
        res = interleave(cases, blocks=5 if quick or big else 9,
                         repeats=3 if quick or big else repeats, warmup=2)
        case = f"mean, N {n_steps:,}" if n_steps in TARGETS else f"info: mean, N {n_steps:,}"
        lines += ["", f"N = {n_steps:,}, order 4, D 2: " + res.load_line(), "", *HEADER,
                  _row(case, res, "mean", TARGETS.get(n_steps))]
    structure.clear()
    mem = peak_memory_mb(cold(plan(10_000)))
    verdict = "ok" if mem <= 50 else "MISSED"
    lines += ["", f"Peak traced memory of a cold solve, N 10,000: {mem:.1f} MB (target <= 50 MB: "
              + f"{verdict})."]
    return lines


def oracle_line(quick: bool) -> str:
    """The dense oracle (eq. 13, O(N^3)): informative only, it slows many times more than the
    banded solvers under load, so it is no reference."""
    stroke = plan(200)
    batch = LQTConfig(order=4, dt=DT, d=5.0, solver="batch")
    res = interleave({"batch": lambda: solve(stroke, batch), "mean": lambda: solve(stroke, CFG)},
                     blocks=1 if quick else 3, repeats={"batch": 1, "mean": 20}, warmup=0)
    return (f"Info: the dense oracle (`solver=\"batch\"`, eq. 13) of the same N = 200 plan takes "
            f"{res.median('batch') * 1e3:.1f} ms, {res.ratio('batch', 'mean'):.0f}x the mean "
            f"(no verdict: it suffers from load far more than the banded solve).")


def lqt_section(quick: bool = False) -> str:
    lines = [
        "## models: Gaussian-target LQT (seed 000)",
        "",
        ("Random walks of spherical targets 50-100 mm apart, variance 100 mm^2, d = 5 mm, "
         "segments of 0.5 s, dt = 0.01 s (50 steps per target). Subject: `solve(plan, config)`; "
         "reference: ONE `scipy.linalg.solveh_banded` of the same banded normal matrix and "
         "right-hand side (built once). Alternating blocks, ratios of the medians of blocks."),
        "",
        *small_table(quick),
        *large_table(quick),
        "",
        oracle_line(quick),
    ]
    return "\n".join(lines) + "\n"


SECTIONS = [lqt_section]  # one function per model, each returning a markdown section


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer blocks and repeats")
    args = parser.parse_args()
    print("\n".join(make(args.quick) for make in SECTIONS))
    return 0


if __name__ == "__main__":
    sys.exit(main())
