"""What starting inkarm costs: `import inkarm`, the CLI's parser (`inkarm --help`) and a
plotter's `inkarm gcode` load none of the heavy libraries they do not use (each in a fresh
process: what is imported is what a user waits for)."""

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
