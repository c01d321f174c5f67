"""The ``sensorimotor`` law (seed 001, sec. 4-5) against the LQT reference: the README's figure
and tables (:mod:`inkarm.jobs.compare_laws`).

Draws the trace-restyled signature (``scenarios/trace_signature.toml``: a trace reduced to DPPLA
targets and re-drawn by the LQT) and the default letter with the default law (position goals),
the joint PID on the same LQT reference, and the sensorimotor law (DPPLA targets of the same
plan; learnt and analytic inverse); writes the figure of the signature and prints the markdown
tables of both. Deterministic (the babbling is seeded); about 5 s.

    .venv/bin/python scripts/compare_sensorimotor.py [FIGURE.png]
"""

from __future__ import annotations

import sys
from pathlib import Path

from inkarm.jobs.compare_laws import compare_laws, comparison_figure
from inkarm.jobs.scenario import load_scenario
from inkarm.plots.figure import save_figure

ROOT = Path(__file__).resolve().parents[1]
FIGURE = ROOT / "docs" / "img" / "sensorimotor_vs_lqt.png"
SCENARIOS = (("the restyled signature", ROOT / "scenarios" / "trace_signature.toml"),
             ("the default letter", None))
IN_FIGURE = ("position", "joint_pid", "sensorimotor")
WINDOW_S = (2.0, 4.5)  # the speed panel: the signature's fastest stretch


def main(figure: Path = FIGURE) -> None:
    for n, (name, path) in enumerate(SCENARIOS):
        comparison = compare_laws(load_scenario(path))
        print(f"### {name} (DPPLA compression {comparison.compression:g}: "
              f"{len(comparison.targets)} targets, {len(comparison.interior)} inside strokes)\n")
        print(comparison.table() + "\n")
        print(comparison.overshoot_table() + "\n")
        for r in comparison.results:
            if r.run.reason:
                print(f"- {r.key}: {r.status}: {r.run.reason}")
        print()
        if n == 0:
            figure.parent.mkdir(parents=True, exist_ok=True)
            save_figure(comparison_figure(comparison, laws=IN_FIGURE, window_s=WINDOW_S), figure,
                        dpi=85)
            print(f"figure: {figure}\n")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else FIGURE)
