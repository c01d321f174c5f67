"""Motor primitives (seed 004): one E-step sweep against the scaled forward-backward floor.

Run: ``python benchmarks/bench_primitives.py`` (``--quick``: 2 blocks of 1 call, the plain loops
on 5 sequences). Prints one markdown section. The problem has the README's training sizes: 200
sequences of 260 samples, M = 12 chains of K = 16 states, D = 3, no self loops, data drawn
from a random model of that size; the model is the paper's initialisation, warmed by two sweeps.

* subject: one Gauss-Seidel sweep of :func:`inkarm.models.primitives.e_step` (for each chain:
  its residual and responsibilities, eq. 7-9, its scaled forward-backward, the residual update
  and the convergence test);
* reference, the floor: for each chain, the textbook scaled forward-backward
  (:func:`inkarm.models.primitives.reference.scaled_forward_backward`, Rabiner's, vectorised
  over the sequences) on that chain's responsibilities (eq. 7-9 given the warm posterior),
  giving the same posteriors: the E-step cannot cost less than its forward-backward passes;
* info, in the same blocks: inkarm's own scaled forward-backward of each chain alone, and the
  log-domain one (inkarm's before, now its fallback where the scaled one underflows;
  :func:`inkarm.models.primitives.inference.log_forward_backward`);
* info: one EM iteration of one sweep as plain loops (one sequence and one chain at a time,
  log-domain; :func:`inkarm.models.primitives.reference.em_iteration_loops`) on a few sequences,
  its time scaled to all 200 (the cost is linear in the sequences, all the same length).

Subject and reference run in alternating blocks (``benchmarks/blocks.py``); each row is the
median of the block medians; the load average is printed beside the table.

Then the README's training (issue 22: <= 5 minutes on 2 cores, the same learned model to 1e-6):
:data:`TRAINING`, the command that made ``inkarm/data/primitives_a.npz``, run once as a child
process (wall and CPU time, load average before and after), and the largest difference of its
model to the shipped one. ``--quick`` skips it (it takes minutes).
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from blocks import interleave, load_average, load_line

from inkarm.models.primitives import (
    Batch,
    PrimitiveModel,
    PrimitivesConfig,
    e_step,
    initial_model,
)
from inkarm.models.primitives.generate import sample
from inkarm.models.primitives.inference import (
    forward_backward,
    log_forward_backward,
    log_responsibility,
)
from inkarm.models.primitives.reference import em_iteration_loops, scaled_forward_backward

N_SEQ, T, M, K, D = 200, 260, 12, 16, 3
TRAINING = ("primitives learn letter:a --chains 12 --states 16 --iterations 25 "
            "--no-self-loops")
"""The README's training command (after ``inkarm``), which made the shipped model."""
SHIPPED = Path(__file__).resolve().parents[1] / "inkarm" / "data" / "primitives_a.npz"


def problem(seed: int = 0):
    """(sequences, batch, config, model, warm posterior) of the README's training sizes."""
    rng = np.random.default_rng(seed)
    config = PrimitivesConfig(n_chains=M, n_states=K, self_loops=False)
    truth = initial_model(Batch.of(rng.normal(size=(N_SEQ, T, D))), config, rng)
    seqs = [sample(truth, T, rng)[0] for _ in range(N_SEQ)]
    batch = Batch.of(seqs)
    model = initial_model(batch, config, rng)
    return seqs, batch, config, model, e_step(model, batch, max_sweeps=2, tol=0.0)


def responsibilities(model, batch, post) -> list[np.ndarray]:
    """Each chain's (T, B, K) log h (eq. 7-9) given the other chains' <S> in ``post``."""
    P = np.linalg.inv(model.C)
    own = [c.gamma @ model.W[m] for m, c in enumerate(post.chains)]
    residual = batch.Y - sum(own)
    mask = batch.mask[..., None].astype(float)
    return [log_responsibility(model, m, np.concatenate([residual + own[m], mask], axis=-1), P)
            for m in range(model.n_chains)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 blocks of 1 call")
    args = parser.parse_args()
    seqs, batch, config, model, warm = problem()
    transitions = [model.transition_matrix(m) for m in range(M)]
    log_h = responsibilities(model, batch, warm)

    def sweep():
        e_step(model, batch, warm, max_sweeps=1, tol=0.0)

    def floor():
        for m in range(M):
            scaled_forward_backward(log_h[m], transitions[m], model.start[m], batch.mask)

    def ours():
        for m in range(M):
            forward_backward(log_h[m], transitions[m], model.start[m], batch.mask)

    log_stay, log_advance = model.log_transitions()
    with np.errstate(divide="ignore"):
        log_start = np.log(model.start)

    def in_logs():
        for m in range(M):
            log_forward_backward(log_h[m], log_stay[m], log_advance[m], log_start[m],
                                 batch.mask)

    same = 0.0
    for m in range(M):
        gamma, log_z, _ = scaled_forward_backward(log_h[m], transitions[m], model.start[m],
                                                  batch.mask)
        post = forward_backward(log_h[m], transitions[m], model.start[m], batch.mask)
        same = max(same, float(np.max(np.abs(gamma - post.gamma))),
                   float(np.max(np.abs(log_z - post.log_z) / np.abs(log_z))))
    blocks, repeats = (2, 1) if args.quick else (7, 3)
    result = interleave({"sweep": sweep, "floor": floor, "ours": ours, "logs": in_logs},
                        blocks=blocks,
                        repeats={"sweep": repeats, "floor": repeats, "ours": 1, "logs": 1})
    n_loop = 5 if args.quick else 20
    silent = [[np.eye(K)[np.zeros(len(Y), int)] for _ in range(M)] for Y in seqs[:n_loop]]
    start = time.perf_counter()
    em_iteration_loops(model, seqs[:n_loop], silent, config, 1)
    t_loop = (time.perf_counter() - start) * N_SEQ / n_loop
    t_sweep, t_floor = result.median("sweep"), result.median("floor")
    print(f"## Motor primitives (seed 004): one E-step sweep against the forward-backward "
          f"floor\n\n"
          f"{N_SEQ} sequences x {T} samples, M = {M} chains x K = {K} states, D = {D}, no self "
          f"loops (the README's training sizes). {blocks} alternating blocks of {repeats} "
          f"call(s) (1 for the info rows), median of the block medians. The floor is the textbook scaled "
          f"forward-backward of every chain on the same responsibilities; its posteriors equal "
          f"the E-step's to {same:.0e} (largest difference of <S>, relative of log Z). "
          f"{result.load_line()}\n")
    print("| implementation | one sweep [s] | ratio to the floor |")
    print("|---|---:|---:|")
    print(f"| inkarm E-step sweep (responsibilities, scaled forward-backward, residual) | "
          f"{t_sweep:.3f} | {t_sweep / t_floor:.2f} |")
    print(f"| scaled forward-backward of each chain (reference, the floor) | {t_floor:.3f} | "
          f"1.00 |")
    print(f"| inkarm's scaled forward-backward of each chain alone (info) | "
          f"{result.median('ours'):.3f} | {result.median('ours') / t_floor:.2f} |")
    print(f"| log-domain forward-backward of each chain (info: the fallback) | "
          f"{result.median('logs'):.3f} | {result.median('logs') / t_floor:.2f} |")
    print(f"| plain loops, log domain, one sequence at a time (info; {n_loop} sequences x "
          f"{N_SEQ // n_loop}, with the M-step) | {t_loop:.2f} | {t_loop / t_floor:.0f} |")
    if not args.quick:
        training()


def training() -> None:
    """Run :data:`TRAINING` once; print its times and its model's distance to the shipped."""
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "a.npz"
        before, cpu0 = load_average(), resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        subprocess.run([str(Path(sys.executable).parent / "inkarm"), *TRAINING.split(),
                        "--out", str(out), "--quiet"], check=True, stdout=subprocess.DEVNULL)
        wall = time.perf_counter() - start
        cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime
        after = load_average()
        new, shipped = PrimitiveModel.load(out), PrimitiveModel.load(SHIPPED)
    diff = {name: float(np.max(np.abs(getattr(new, name) - getattr(shipped, name))))
            for name in ("W", "C", "advance", "start")}
    print(f"\n**The README's training** (`inkarm {TRAINING}`, one run): {wall / 60:.1f} min "
          f"wall, {cpu / 60:.1f} CPU-min (target <= 5 min on 2 cores). Its model against the "
          f"shipped `inkarm/data/primitives_a.npz`: largest difference "
          + ", ".join(f"{name} {d:.1e}" for name, d in diff.items())
          + f" (target <= 1e-6). {load_line(before, after)}")


if __name__ == "__main__":
    main()
