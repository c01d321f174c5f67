"""OpenGL without a display: choosing MuJoCo's offscreen backend, and :class:`RenderError`.

MuJoCo chooses its backend from ``MUJOCO_GL`` once, when ``mujoco`` is first imported;
:func:`configure_gl` (call it before that import, e.g. first thing in a CLI command) keeps a
value already set or else picks the first of EGL and OSMesa that works here, each probed in a
subprocess. A process that renders nothing imports MuJoCo with no backend at all
(:func:`import_mujoco_without_gl`: MuJoCo otherwise loads glfw, 25 ms of `inkarm draw`'s
start-up). This module imports neither ``mujoco`` nor anything that does. System packages
(Debian 12 / Ubuntu names; PyOpenGL comes from pip with mujoco):

- ``MUJOCO_GL=egl``: ``libegl1`` (the GLVND EGL loader), ``libopengl0`` and ``libgl1``, plus
  an EGL vendor: ``libegl-mesa0`` with ``libgl1-mesa-dri`` renders in software on a machine
  without a GPU (Mesa's surfaceless platform); on an NVIDIA GPU the driver's own EGL is used.
- ``MUJOCO_GL=osmesa``: ``libosmesa6`` (software rendering only):
  ``apt-get install -y libosmesa6``.
- ``MUJOCO_GL=glfw`` (MuJoCo's default): needs a display (X11/Wayland), not for servers.

Checked on Debian 12 (bookworm), mujoco 4.0.0, no GPU: EGL worked with the packages already
there (libegl1 1.6.0, libegl-mesa0 and libgl1-mesa-dri 22.3.6: Mesa's llvmpipe); OSMesa
worked after ``apt-get install -y libosmesa6`` (which also upgraded the Mesa packages to
22.3.6-1+deb12u2). Both rendered in software at about the same speed: 70 to 140 ms per
640 x 480 frame of the arm cell on a busy 2-core machine.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterable

from inkarm.errors import InkarmError

GL_BACKENDS = ("egl", "osmesa")
GL_ADVICE = (
    "Set MUJOCO_GL=egl (Debian packages libegl1 libegl-mesa0 libgl1-mesa-dri) or "
    "MUJOCO_GL=osmesa (libosmesa6) in the environment before starting Python"
)

_PROBE = (
    "import mujoco\n"
    "m = mujoco.MjModel.from_xml_string('<mujoco><worldbody><geom size=\"1\"/></worldbody></mujoco>')\n"
    "r = mujoco.Renderer(m, 8, 8)\n"
    "r.update_scene(mujoco.MjData(m))\n"
    "r.render()\n"
    "r.close()\n"
)


class RenderError(InkarmError):
    """Offscreen rendering or video encoding is unavailable or was misused."""


def probe_gl(backend: str, timeout_s: float = 60.0) -> str | None:
    """None if MuJoCo renders offscreen with ``MUJOCO_GL=backend`` here, else the reason (the
    last line of the error), checked in a subprocess so a failing backend cannot poison this
    process's OpenGL state."""
    env = dict(os.environ, MUJOCO_GL=backend)
    env.pop("PYOPENGL_PLATFORM", None)
    try:
        done = subprocess.run(
            [sys.executable, "-c", _PROBE],
            check=False,
            env=env,
            capture_output=True,
            text=True,
            timeout=timeout_s,
        )
    except subprocess.TimeoutExpired:
        return f"MUJOCO_GL={backend}: the probe did not finish in {timeout_s} s"
    if done.returncode == 0:
        return None
    lines = [line for line in done.stderr.strip().splitlines() if line.strip()]
    return f"MUJOCO_GL={backend}: {lines[-1] if lines else f'exit status {done.returncode}'}"


def configure_gl(backends: Iterable[str] = GL_BACKENDS) -> str:
    """Choose the OpenGL backend before ``mujoco`` is imported and return it: ``MUJOCO_GL`` if
    already set, else the first of ``backends`` that :func:`probe_gl` finds working (which is
    then written to ``os.environ``)."""
    chosen = os.environ.get("MUJOCO_GL", "").strip().lower()
    if chosen:
        return chosen
    if "mujoco" in sys.modules:
        raise RenderError(
            "configure_gl: mujoco is already imported without MUJOCO_GL, so its OpenGL backend "
            "is fixed (glfw, which needs a display); call configure_gl() before importing "
            "mujoco or set MUJOCO_GL=egl (or osmesa) in the environment"
        )
    reasons = []
    for backend in backends:
        reason = probe_gl(backend)
        if reason is None:
            os.environ["MUJOCO_GL"] = backend
            return backend
        reasons.append(reason)
    raise RenderError(
        "no offscreen OpenGL backend works here: "
        + "; ".join(reasons)
        + ". Install libegl1 libegl-mesa0 libgl1-mesa-dri (MUJOCO_GL=egl) or libosmesa6 "
        "(MUJOCO_GL=osmesa)"
    )


def import_mujoco_without_gl() -> None:
    """Import ``mujoco`` with OpenGL off (``MUJOCO_GL=disable`` for that import only), for a
    process that renders nothing; nothing is done when ``MUJOCO_GL`` is set or mujoco is
    loaded already. ``MUJOCO_GL`` is left unset again, so child processes choose their own
    backend; in this process :func:`configure_gl` then refuses, as after any import of mujoco
    without a choice."""
    if os.environ.get("MUJOCO_GL", "").strip() or "mujoco" in sys.modules:
        return
    os.environ["MUJOCO_GL"] = "disable"
    try:
        import mujoco  # noqa: F401
    finally:
        del os.environ["MUJOCO_GL"]
