"""Offscreen OpenGL backend selection."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from inkarm.sim import gl

pytestmark = pytest.mark.sim


def test_probe_of_an_unknown_backend_gives_the_reason():
    reason = gl.probe_gl("nonsense")
    assert reason is not None and reason.startswith("MUJOCO_GL=nonsense: ")


def test_configure_gl_keeps_a_backend_already_chosen(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "OSMesa ")
    assert gl.configure_gl() == "osmesa"


def test_configure_gl_refuses_once_mujoco_is_imported_without_a_choice(monkeypatch):
    import mujoco  # noqa: F401

    monkeypatch.delenv("MUJOCO_GL", raising=False)
    with pytest.raises(gl.RenderError, match=r"mujoco is already imported without MUJOCO_GL"):
        gl.configure_gl()


def test_choosing_the_backend_does_not_import_mujoco():
    # configure_gl() must run before mujoco loads, so importing it must not load mujoco.
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}
    code = "import sys\nfrom inkarm.sim.gl import configure_gl\nprint('mujoco' in sys.modules)"
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False"
