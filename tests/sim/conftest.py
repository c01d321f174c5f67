"""Shared by the sim tests: ``@pytest.mark.gl`` skips a test, with the reason, when offscreen
OpenGL does not work here (see inkarm.sim.gl for the system packages). MUJOCO_GL must be set
before mujoco is first imported in the test process: tests/conftest.py sets it to egl unless
the environment chose."""

from __future__ import annotations

import functools
import os

import pytest

from inkarm.sim.gl import probe_gl


def pytest_configure(config):
    config.addinivalue_line(
        "markers", "gl: needs offscreen OpenGL (skipped, with the reason, where it does not work)"
    )


@functools.cache
def _gl_skip_reason() -> str | None:
    reason = probe_gl(os.environ["MUJOCO_GL"])
    if reason is not None:
        return f"no offscreen OpenGL: {reason}"
    from mujoco.rendering.classic import gl_context

    imported_with = getattr(gl_context, "_MUJOCO_GL", os.environ["MUJOCO_GL"])
    if imported_with != os.environ["MUJOCO_GL"].lower():
        return (
            f"mujoco was imported with MUJOCO_GL={imported_with!r} before this module set "
            f"{os.environ['MUJOCO_GL']!r}; set MUJOCO_GL in the environment"
        )
    return None


def pytest_runtest_setup(item):
    if item.get_closest_marker("gl") is not None:
        reason = _gl_skip_reason()
        if reason is not None:
            pytest.skip(reason)
