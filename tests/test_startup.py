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
SCIPY_NOT_FOR_DRAWING = ("scipy.signal", "scipy.stats", "scipy.optimize", "scipy.interpolate",
                         "scipy.ndimage")
"""SciPy's parts that a drawing of the default does not use: speed peaks and the low-pass in
NumPy (analysis/peaks, analysis/butterworth), the minimum-jerk timing's search, the LQT's
zero-order-hold stencils and the ink's filters imported where they are used."""


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
    """`inkarm draw` of the default (report.png included) loads MuJoCo, which drawing uses,
    without its OpenGL (glfw: nothing is rendered), and none of matplotlib (report.png is
    drawn with Pillow) nor the other backends' libraries. SciPy still comes with the LQT's
    banded solves (scipy.linalg) and the ink chamfer's k-d tree (scipy.spatial), none of
    :data:`SCIPY_NOT_FOR_DRAWING`."""
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}  # as a user starts it
    loaded = loaded_after(f"""
        from inkarm.cli import main
        assert main(["draw", "--quiet", "--out", {str(tmp_path / "out")!r}]) == 0
    """, heavy=HEAVY + SCIPY_NOT_FOR_DRAWING, env=env)
    assert (tmp_path / "out" / "report.png").is_file()
    assert "mujoco" in loaded
    assert loaded <= {"mujoco", "scipy"}


def test_the_arms_planner_imports_no_scipy():
    """Splines in NumPy (inkarm.core.spline) and the IK's Cholesky solve imported on its first
    call: the planner's modules import without SciPy; so do the plans' minimum-jerk kind, the
    LQT's problem and the kinematic measures (SciPy imported where a call needs it)."""
    assert "scipy" not in loaded_after("""
        import inkarm.control.ik, inkarm.control.reference, inkarm.control.sequencing
        import inkarm.plans.kinds.minjerk, inkarm.models.lqt.problem, inkarm.analysis.humanlike
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


@pytest.mark.parametrize(("given", "expected"), [(None, "1"), ("3", "3")])
def test_the_cli_runs_blas_on_one_thread_unless_told_otherwise(given, expected):
    """OpenBLAS's thread pools cost most of NumPy's and SciPy's import CPU and buy nothing for
    inkarm's small linear algebra: the command sets one thread before NumPy loads, and keeps a
    user's own setting."""
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if given is not None:
        env["OPENBLAS_NUM_THREADS"] = given
    code = ("import sys, os, inkarm.cli; assert 'numpy' not in sys.modules; "
            "print(os.environ['OPENBLAS_NUM_THREADS'])")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == expected
