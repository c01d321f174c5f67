"""EM iteration of the motor-primitive fHMM (seed 004) against a plain-loop implementation.

Run: ``python benchmarks/bench_primitives.py`` (``--quick``: one repeat, and the loops on 20 of
the 200 sequences, their time scaled by 10: the loops' cost is linear in the number of
sequences, every sequence being the same length; the models are then compared on those 20).
Prints one markdown
table: the median wall time of one EM iteration (E-step of ``--sweeps`` Gauss-Seidel sweeps over
the chains, then the M-step) for 200 sequences of 100 samples, M = 20 chains of K = 10 states,
D = 3, with :mod:`inkarm.models.primitives` (forward-backward vectorised over the sequences)
and with :func:`inkarm.models.primitives.reference.em_iteration_loops` (one sequence and one
chain at a time; the same numbers), in the same process on the same data, and their ratio.
Both start from the same model and the same all-silent posterior.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from inkarm.models.primitives import Batch, PrimitivesConfig, e_step, initial_model, m_step
from inkarm.models.primitives.generate import sample
from inkarm.models.primitives.reference import em_iteration_loops

N_SEQ, T, M, K, D = 200, 100, 20, 10, 3


def problem(seed: int = 0):
    rng = np.random.default_rng(seed)
    config = PrimitivesConfig(n_chains=M, n_states=K)
    truth = initial_model(Batch.of(rng.normal(size=(N_SEQ, T, D))), config, rng)
    seqs = [sample(truth, T, rng)[0] for _ in range(N_SEQ)]
    batch = Batch.of(seqs)
    return seqs, batch, config, initial_model(batch, config, rng)


def vectorised(model, batch, config, sweeps):
    post = e_step(model, batch, None, max_sweeps=sweeps, tol=0.0)
    return m_step(model, batch, post, config)


def loops(model, seqs, config, sweeps):
    silent = [[np.eye(K)[np.zeros(len(Y), int)] for _ in range(M)] for Y in seqs]
    return em_iteration_loops(model, seqs, silent, config, sweeps)[0]


def timed(fn, repeats):
    times, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one repeat of each")
    parser.add_argument("--sweeps", type=int, default=2, help="E-step sweeps (default 2)")
    args = parser.parse_args()
    seqs, batch, config, model = problem()
    repeats = 1 if args.quick else 3
    t_vec, new = timed(lambda: vectorised(model, batch, config, args.sweeps), repeats)
    n_loop = 20 if args.quick else N_SEQ
    t_loop, ref = timed(lambda: loops(model, seqs[:n_loop], config, args.sweeps), 1)
    t_loop *= N_SEQ / n_loop
    if n_loop < N_SEQ:
        new = vectorised(model, Batch.of(seqs[:n_loop]), config, args.sweeps)
    same = max(float(np.max(np.abs(getattr(new, n) - getattr(ref, n))))
               for n in ("W", "C", "start", "advance"))
    scaled = f" (measured on {n_loop} sequences, x {N_SEQ // n_loop})" if n_loop < N_SEQ else ""
    print(f"## Motor primitives (seed 004): one EM iteration\n\n"
          f"{N_SEQ} sequences x {T} samples, M = {M} chains x K = {K} states, D = {D}; "
          f"E-step of {args.sweeps} sweeps over the chains, then the M-step. Median of "
          f"{repeats} (vectorised), 1 (loops). Largest difference between the two models: "
          f"{same:.1e}.\n")
    print("| implementation | EM iteration [s] | per sweep [s] | ratio to loops |")
    print("|---|---:|---:|---:|")
    print(f"| plain loops (reference){scaled} | {t_loop:.2f} | {t_loop / args.sweeps:.2f} | 1.0 |")
    print(f"| inkarm.models.primitives | {t_vec:.2f} | {t_vec / args.sweeps:.2f} | "
          f"{t_loop / t_vec:.1f}x faster |")


if __name__ == "__main__":
    main()
