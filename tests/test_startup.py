"""What starting inkarm costs: `import inkarm`, the CLI's parser (`inkarm --help`), a
plotter's `inkarm gcode` and the arm's `inkarm draw` load none of the heavy libraries they do
not use (each in a fresh process: what is imported is what a user waits for)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("scipy", "matplotlib", "mujoco", "pyarrow", "ray", "glfw", "dynamixel_sdk", "skimage")


def loaded_after(code: str) -> set[str]:
    """The modules of :data:`HEAVY` that a fresh interpreter has loaded after ``code``."""
    probe = textwrap.dedent(code) + textwrap.dedent(f"""
        import sys
        print(" ".join(m for m in {HEAVY!r} if m in sys.modules))
    """)
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          cwd=ROOT, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    return set(done.stdout.split())


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
def test_draw_writes_its_report_without_matplotlib(tmp_path):
    """`inkarm draw` (report.png included) loads MuJoCo, which drawing uses, and none of
    matplotlib (report.png is drawn with Pillow) nor the other backends' libraries."""
    loaded = loaded_after(f"""
        from inkarm.cli import main
        assert main(["draw", "scenarios/quick_stroke.toml", "--quiet", "--out",
                     {str(tmp_path / "out")!r}]) == 0
    """)
    assert (tmp_path / "out" / "report.png").is_file()
    assert "mujoco" in loaded
    assert not loaded & {"matplotlib", "pyarrow", "ray", "dynamixel_sdk", "skimage"}
