"""The default scenario and a written word, drawn by the simulated arm and by the emulated
GRBL plotter, side by side with the same metrics: docs/img/arm_vs_plotter.png.

    python docs/plotter_figure.py [--speedup 1] [--out docs/img/arm_vs_plotter.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from inkarm.jobs.backends.plotter import arm_and_plotter
from inkarm.jobs.scenario import load_scenario
from inkarm.plots.backends import BackendPanel, backends_figure
from inkarm.plots.figure import save_figure

ROOT = Path(__file__).resolve().parents[1]
JOBS = [(None, "default letter N"), (ROOT / "scenarios" / "text_inkarm.toml", "word 'inkarm'")]


def panel(label: str, run) -> BackendPanel:
    return BackendPanel(label, run.canvas, [s.pos[:, :2] for s in run.drawing.strokes],
                        run.metrics, run.status)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--speedup", type=float, default=1.0)
    parser.add_argument("--out", default=str(ROOT / "docs" / "img" / "arm_vs_plotter.png"))
    args = parser.parse_args()
    rows = []
    for path, title in JOBS:
        arm, plotter = arm_and_plotter(load_scenario(path), args.speedup)
        rows.append((title, [panel("simulated arm (MuJoCo)", arm),
                             panel("GRBL plotter (emulated)", plotter)]))
        for name, run in (("arm", arm), ("plotter", plotter)):
            print(title, name, run.status, {k: round(v, 3) for k, v in run.metrics.items()})
    print(save_figure(backends_figure(rows), args.out))


if __name__ == "__main__":
    main()
