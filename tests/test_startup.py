"""What starting inkarm costs: `import inkarm`, the CLI's parser (`inkarm --help`), a
plotter's `inkarm gcode` and the arm's `inkarm draw` load none of the heavy libraries they do
not use (each in a fresh process: what is imported is what a user waits for), and a command
parses with its own parser only."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("scipy", "matplotlib", "mujoco", "pyarrow", "ray", "glfw", "dynamixel_sdk", "skimage")


def loaded_after(code: str, heavy: tuple[str, ...] = HEAVY, env=None) -> set[str]:
    """The modules of ``heavy`` that a fresh interpreter (environment ``env``, else this
    one's) has loaded after ``code``."""
    probe = textwrap.dedent(code) + textwrap.dedent(f"""
        import sys
        print(" ".join(m for m in {heavy!r} if m in sys.modules))
    """)
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          cwd=ROOT, timeout=120, check=False, env=env)
    assert done.returncode == 0, done.stderr
    return set(done.stdout.splitlines()[-1].split()) if done.stdout.strip() else set()


def test_import_inkarm_loads_no_heavy_library():
    assert loaded_after("import inkarm") == set()


def test_the_report_module_loads_no_matplotlib():
    assert "matplotlib" not in loaded_after("import inkarm.plots.report, inkarm.jobs.outputs")


def test_the_clis_help_loads_no_heavy_library():
    assert loaded_after("""
        from inkarm.cli import build_parser
        build_parser().format_help()
        for action in build_parser()._subparsers._group_actions:
            for parser in action.choices.values():
                parser.format_help()
    """) == set()


@pytest.mark.sim
def test_gcode_for_a_plotter_loads_no_simulator_and_no_figures(tmp_path):
    loaded = loaded_after(f"""
        from inkarm.cli import main
        assert main(["gcode", "scenarios/quick_stroke.toml", "--out",
                     {str(tmp_path / "job.gcode")!r}]) == 0
    """)
    assert not loaded & {"mujoco", "matplotlib", "pyarrow", "ray", "glfw", "dynamixel_sdk"}


@pytest.mark.sim
def test_draw_writes_its_report_without_matplotlib_nor_glfw(tmp_path):
    """`inkarm draw` (report.png included) loads MuJoCo, which drawing uses, without its
    OpenGL (glfw: nothing is rendered), and none of matplotlib (report.png is drawn with
    Pillow) nor the other backends' libraries. SciPy still comes with the default's LQT
    (models/lqt) and the metrics (analysis/metrics, analysis/kinematics), not the planner."""
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}  # as a user starts it
    loaded = loaded_after(f"""
        from inkarm.cli import main
        assert main(["draw", "scenarios/quick_stroke.toml", "--quiet", "--out",
                     {str(tmp_path / "out")!r}]) == 0
    """, env=env)
    assert (tmp_path / "out" / "report.png").is_file()
    assert "mujoco" in loaded
    assert loaded <= {"mujoco", "scipy"}


def test_the_arms_planner_imports_no_scipy():
    """Splines in NumPy (inkarm.core.spline) and the IK's Cholesky solve imported on its first
    call: the planner's modules import without SciPy."""
    assert "scipy" not in loaded_after("""
        import inkarm.control.ik, inkarm.control.reference, inkarm.control.sequencing
    """)


def test_a_command_parses_with_its_own_parser_only():
    from inkarm.cli import build_parser, command_names

    choices = build_parser()._subparsers._group_actions[0].choices
    assert sorted(choices) == sorted(command_names())  # one command per module, named alike
    assert "fit-style" in command_names()
    commands = loaded_after("""
        from inkarm.cli import build_parser
        build_parser("draw").parse_args(["draw", "--quiet"])
    """, heavy=tuple(command_names().values()))
    assert commands == {"inkarm.commands.draw"}
