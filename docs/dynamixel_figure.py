"""The WidowX 250's default letter drawn three ways, side by side with the same metrics:
the simulation (the profile's joint drives), the same arm on its servos' firmware model (no bus), and
hardware in the loop (dynamixel-sdk on a pty at 1 Mbps, the emulator's servos moving the
MuJoCo twin): docs/img/dynamixel_hil.png.

    python docs/dynamixel_figure.py [--out docs/img/dynamixel_hil.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from inkarm.jobs.backends.dynamixel import hil_run, simulate_servo_arm
from inkarm.jobs.run import run
from inkarm.jobs.scenario import load_scenario
from inkarm.plots.backends import BackendPanel, backends_figure
from inkarm.plots.figure import save_figure

ROOT = Path(__file__).resolve().parents[1]


def panel(label: str, result) -> BackendPanel:
    return BackendPanel(label, result.canvas, [s.pos[:, :2] for s in result.drawing.strokes],
                        result.metrics, result.status)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "img" / "dynamixel_hil.png"))
    args = parser.parse_args()
    scenario = load_scenario(ROOT / "scenarios" / "wx250s_letter_N.toml")
    runs = [("simulation (the profile's drives)", run(scenario)),
            ("servo firmware model, no bus", simulate_servo_arm(scenario)),
            ("hardware in the loop (emulated bus)", hil_run(scenario, latency_ms=50,
                                                           watchdog_ms=500))]
    for label, result in runs:
        print(label, result.status, {k: round(v, 3) for k, v in result.metrics.items()
                                     if isinstance(v, float)})
    figure = backends_figure([("wx250s letter N", [panel(label, r) for label, r in runs])])
    print(save_figure(figure, args.out))


if __name__ == "__main__":
    main()
