"""DPPLA speed against a plain triple loop, and seed 001's density/curvature figures.

Run: ``python benchmarks/bench_dppla.py`` (``--quick`` for fewer blocks). Prints two markdown
tables:

1. Median wall time of :func:`inkarm.analysis.dppla.dppla` (exact and banded) and of a plain
   triple-loop DP (pure Python loops over segments k, end sample j and start sample i, each
   segment error in O(1) from the same prefix sums), in the same process on the same input, in
   alternating blocks (:mod:`blocks`). The slow loops run on shorter inputs (shorter still with
   ``--quick``) and their time is extrapolated by the exact count of inner-loop iterations at
   full size: their cost is linear in that count.
2. Seed 001 sec. 5 measures (Table 1 and the power-law exponent gamma) for a harmonic
   ellipse, a lemniscate and a script word from a Hershey font sampled at 200 Hz.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np
from blocks import interleave, load_line

from inkarm.analysis.density import analyse_drawing
from inkarm.analysis.dppla import dppla
from inkarm.core.trajectory import Drawing, Trajectory
from inkarm.io.trace import resample_arc_length


def smooth_curve(w: int, seed: int = 0) -> np.ndarray:
    """A smooth random planar curve of w samples in [mm] (a few sinusoids per axis)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, w)
    freq = rng.uniform(0.5, 4.0, size=(2, 4))
    amp = rng.uniform(5.0, 30.0, size=(2, 4))
    phase = rng.uniform(0, 2 * np.pi, size=(2, 4))
    return np.column_stack(
        [
            np.sum(amp[c] * np.sin(2 * np.pi * freq[c] * t[:, None] + phase[c]), axis=1)
            for c in range(2)
        ]
    )


def triple_loop(
    x: np.ndarray, k: int, band: int | None = None, window: bool = True
) -> tuple[float, int]:
    """Plain DP (seed 001 sec. 3) with Python loops over m, j, i; returns (cost, inner iterations).

    Same problem as ``dppla(x, k, banded=band is not None, band=band, window=window)``:
    interpolation error with tau = n; for the banded DP segments of at most ``band`` samples
    and, with ``window``, break point m within ``band`` of m (w-1)/k.
    """
    w = len(x)
    xs, ys = x[:, 0].tolist(), x[:, 1].tolist()
    sx, sy, snx, sny, sxx = [0.0], [0.0], [0.0], [0.0], [0.0]
    for n in range(w):
        sx.append(sx[-1] + xs[n])
        sy.append(sy[-1] + ys[n])
        snx.append(snx[-1] + n * xs[n])
        sny.append(sny[-1] + n * ys[n])
        sxx.append(sxx[-1] + xs[n] * xs[n] + ys[n] * ys[n])

    def cost(i: int, j: int) -> float:
        c, span = j - i + 1, j - i
        ax, ay, dx, dy = xs[i], ys[i], xs[j] - xs[i], ys[j] - ys[i]
        px, py = sx[j + 1] - sx[i], sy[j + 1] - sy[i]
        qx = (snx[j + 1] - snx[i] - i * px) / span
        qy = (sny[j + 1] - sny[i] - i * py) / span
        sum_s = (span + 1) / 2
        sum_ss = (span + 1) * (2 * span + 1) / (6 * span)
        return (
            sxx[j + 1]
            - sxx[i]
            - 2 * (ax * px + ay * py)
            + c * (ax * ax + ay * ay)
            - 2 * (dx * qx + dy * qy)
            + 2 * (dx * ax + dy * ay) * sum_s
            + (dx * dx + dy * dy) * sum_ss
        )

    lo, hi = _windows(w, k, band if window else None)
    inf = math.inf
    prev = [inf] * w
    prev[0] = 0.0
    iterations = 0
    for m in range(1, k + 1):
        cur = [inf] * w
        for j in range(lo[m], hi[m] + 1):
            start = max(lo[m - 1], 0 if band is None else j - band)
            best = inf
            for i in range(start, min(j, hi[m - 1] + 1)):
                iterations += 1
                v = prev[i] + cost(i, j)
                best = min(best, v)
            cur[j] = best
        prev = cur
    return prev[w - 1], iterations


def _windows(w: int, k: int, band: int | None) -> tuple[list[int], list[int]]:
    lo = list(range(k + 1))
    hi = [w - 1 - (k - m) for m in range(k + 1)]
    if band is not None:
        lo = [max(lo[m], math.ceil(m * (w - 1) / k - band)) for m in range(k + 1)]
        hi = [min(hi[m], math.floor(m * (w - 1) / k + band)) for m in range(k + 1)]
    return lo, hi


def inner_iterations(w: int, k: int, band: int | None, window: bool = True) -> int:
    """The triple loop's inner-iteration count, without running it."""
    lo, hi = _windows(w, k, band if window else None)
    total = 0
    for m in range(1, k + 1):
        for j in range(lo[m], hi[m] + 1):
            start = max(lo[m - 1], 0 if band is None else j - band)
            total += max(min(j, hi[m - 1] + 1) - start, 0)
    return total


def timing_table(blocks: int, repeats: int, quick: bool) -> str:
    """Print the timing table; returns the load line of its blocks."""
    cases = [  # (label, w, k, banded, window, w of the triple loop (full, quick), budget [s])
        ("banded (window around uniform)", 2000, 100, True, True, (2000, 2000), 0.5),
        ("banded (paper's lb only)", 2000, 100, True, False, (1000, 500), None),
        ("exact", 1000, 30, False, True, (500, 250), 2.0),
    ]
    print(
        "| DPPLA | w | k | band | inkarm [s] (median) | budget [s] | triple loop [s] "
        "| triple loop run at w | ratio | costs agree | cost / exact optimum |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    first = last = None
    for label, w, k, banded, window, w_loops, budget in cases:
        w_loop = w_loops[quick]
        x = smooth_curve(w)
        band = math.ceil(2 * w / k) if banded else None

        def run(x=x, k=k, banded=banded, window=window):
            return dppla(x, k, banded=banded, window=window, verify=False)

        quality = run().cost / dppla(x, k).cost  # untimed: what the band costs
        # The band scales with w / k: keep k w_loop / w segments on the shorter run.
        k_loop = max(1, round(k * w_loop / w))
        x_loop = smooth_curve(w_loop)
        band_loop = math.ceil(2 * w_loop / k_loop) if banded else None
        scale = inner_iterations(w, k, band, window) / inner_iterations(
            w_loop, k_loop, band_loop, window)
        loop_costs = []

        def loop(x_loop=x_loop, k_loop=k_loop, band_loop=band_loop, window=window,
                 loop_costs=loop_costs):
            loop_costs.append(triple_loop(x_loop, k_loop, band_loop, window)[0])

        result = interleave({"inkarm": run, "loop": loop}, blocks=blocks,
                            repeats={"inkarm": repeats, "loop": 1}, warmup=0)
        first = first or result
        last = result
        t_fast, t_loop = result.median("inkarm"), scale * result.median("loop")
        reference = dppla(
            x_loop, k_loop, banded=banded, band=band_loop, window=window, verify=False
        ).cost
        agree = all(abs(c - reference) <= 1e-6 * max(reference, 1.0) for c in loop_costs)
        extrapolated = "" if w_loop == w else " (extrapolated)"
        print(
            f"| {label} | {w} | {k} | {band or '-'} | {t_fast:.3f} | {budget or '-'} | "
            f"{t_loop:.2f}{extrapolated} | {w_loop} (k={k_loop}) | {t_loop / t_fast:.0f}x | "
            f"{agree} | {quality:.4f} |"
        )
    return load_line(first.load_before, last.load_after)


def harmonic_ellipse(rate: float) -> Trajectory:
    t = np.arange(0.0, 3.0, 1.0 / rate)
    w = 2 * np.pi / 3.0
    return Trajectory(t, np.column_stack([60 * np.cos(w * t), 20 * np.sin(w * t)]))


def lemniscate(rate: float) -> Trajectory:
    t = np.arange(0.0, 3.0, 1.0 / rate)
    s, c = np.sin(2 * np.pi * t / 3.0), np.cos(2 * np.pi * t / 3.0)
    return Trajectory(t, np.column_stack([50 * c / (1 + s * s), 50 * s * c / (1 + s * s)]))


def hershey_word(
    word: str = "minimum", height: float = 20.0, speed: float = 40.0, rate: float = 200.0
) -> Drawing:
    """A word of the Hershey ``scripts`` font, drawn at constant ``speed`` [mm/s] and sampled at
    ``rate`` [Hz]; glyph strokes that meet end to start are joined into one stroke."""
    from HersheyFonts import HersheyFonts

    font = HersheyFonts()
    font.load_default_font("scripts")
    scale = height / 21.0  # the font's cap-to-bottom span is 21 units
    polylines: list[np.ndarray] = []
    for stroke in font.strokes_for_text(word):
        pts = np.array(stroke, dtype=float) * [scale, -scale]  # Hershey y points down
        if polylines and np.allclose(polylines[-1][-1], pts[0]):
            polylines[-1] = np.vstack([polylines[-1], pts[1:]])
        else:
            polylines.append(pts)
    strokes = []
    for poly in polylines:
        pos = resample_arc_length(poly, speed / rate)
        if pos is not None and len(pos) > 2:
            t = (
                np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pos, axis=0), axis=1))])
                / speed
            )
            strokes.append(Trajectory(t, pos))
    return Drawing(strokes)


def lqt_word(word: Drawing, rate: float = 200.0) -> Drawing:
    """The Hershey word re-drawn by the LQT through its glyph vertices (human-like speed: slow
    at cusps), sampled at ``rate`` [Hz]."""
    from inkarm.core.plan import StrokePlan
    from inkarm.models.lqt import LQTConfig, solve

    strokes = []
    for s in word.strokes:
        targets = s.pos[:: max(1, s.n // max(4, round(s.length / 1.5)))]
        plan = StrokePlan.from_arrays(targets, 0.05, segment_time=0.06)
        strokes.append(solve(plan, LQTConfig(order=4, dt=1.0 / rate, d=2.0)))
    return Drawing(strokes)


def analysis_table() -> None:
    word = hershey_word()
    traces = [
        ("harmonic ellipse 120 x 40 mm, 110 Hz", Drawing([harmonic_ellipse(110.0)])),
        ("lemniscate a = 50 mm, 110 Hz", Drawing([lemniscate(110.0)])),
        ("Hershey 'minimum' (scripts), constant 40 mm/s, 200 Hz", word),
        ("Hershey 'minimum', LQT-drawn (order 4), 200 Hz", lqt_word(word)),
    ]
    print("| trace | samples | compression | segments | correlation density-curvature | gamma |")
    print("|---|---|---|---|---|---|")
    for label, drawing in traces:
        samples = sum(s.n for s in drawing.strokes)
        for rho in (0.65, 0.75, 0.85):
            res = analyse_drawing(drawing, rho)
            k = sum(a.result.k for a in res.strokes)
            print(
                f"| {label} | {samples} | {rho:.2f} | {k} | {res.correlation:.3f} | {res.power_law.gamma:.2f} |"
            )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="two blocks instead of five; slow triple loops on shorter inputs")
    args = parser.parse_args(argv)
    print("## dppla: adaptive sampling of traces (seed 001)\n")
    blocks, repeats = (2, 2) if args.quick else (5, 3)
    print(f"The reference is a plain triple-loop DPPLA with the same O(1) segment costs, in the "
          f"same process on the same curve; the two run in {blocks} alternating blocks ("
          f"{repeats} calls of inkarm's, one triple loop a block), times are the medians of the "
          "blocks' medians. The triple loop runs on a shorter input where it says so, its time "
          "scaled by the exact count of inner-loop iterations at full size (its cost is linear "
          "in that count). Below: density-curvature correlation and gamma of seed 001 sec. 5. "
          f"python {sys.version.split()[0]}, numpy {np.__version__}.\n")
    load = timing_table(blocks, repeats, args.quick)
    print(f"\n{load}\n")
    analysis_table()
    return 0


if __name__ == "__main__":
    sys.exit(main())
