"""Fast EM against the log-domain reference, iteration by iteration, on the README's training.

Run: ``python scripts/compare_primitives_em.py [--samples 200] [--iterations 25]`` (defaults:
``inkarm primitives learn letter:a --chains 12 --states 16 --iterations 25 --no-self-loops``).
Both start from the same initial model (seed 0) and run
:func:`inkarm.models.primitives.learning.em_iterations` in lockstep, one with the scaled
forward-backward (inkarm's), one with the log-domain one
(:func:`inkarm.models.primitives.inference.log_domain_pass`). Each line prints the largest
differences of W, C, the advance probabilities and the bound F, and both E-steps' sweeps.
``--save FILE.npz`` writes the fast run's last model (to compare with a shipped one).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from inkarm.commands.primitives import load_training_set
from inkarm.models.primitives import Batch, PrimitivesConfig, initial_model
from inkarm.models.primitives.inference import log_domain_pass
from inkarm.models.primitives.learning import em_iterations


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=200)
    parser.add_argument("--chains", type=int, default=12)
    parser.add_argument("--states", type=int, default=16)
    parser.add_argument("--iterations", type=int, default=25)
    parser.add_argument("--sweeps", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--save", default="")
    args = parser.parse_args()
    data = load_training_set("letter:a", args.samples, "faithful,cursive,loose,italic,hurried",
                             args.seed)
    config = PrimitivesConfig(n_chains=args.chains, n_states=args.states,
                              max_outer=args.iterations, max_inner=args.sweeps,
                              self_loops=False)
    batch = Batch.of(data.sequences)
    model = initial_model(batch, config, np.random.default_rng(args.seed), scale=data.scale,
                          rate_hz=data.rate_hz, channels=data.channels)
    start = time.perf_counter()
    print("| it | max dW | max dC | max d advance | dF | sweeps fast/ref | s |")
    print("|---:|---:|---:|---:|---:|---|---:|")
    last = None
    for (fast, a, _), (ref, b, _) in zip(em_iterations(model, batch, config),
                                         em_iterations(model, batch, config, log_domain_pass)):
        print(f"| {fast.number} | {np.abs(a.W - b.W).max():.2e} | {np.abs(a.C - b.C).max():.2e}"
              f" | {np.abs(a.advance - b.advance).max():.2e} | {abs(fast.bound - ref.bound):.2e}"
              f" | {fast.sweeps}/{ref.sweeps} | {time.perf_counter() - start:.0f} |", flush=True)
        last = a
    if args.save and last is not None:
        last.save(args.save)


if __name__ == "__main__":
    main()
