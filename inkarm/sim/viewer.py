"""Replaying a finished run in MuJoCo's passive viewer (needs a display), the ink drawn as
capsules in the viewer's user scene (:class:`ViewerInk`)."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from typing import TYPE_CHECKING

import numpy as np

from inkarm.errors import InputError
from inkarm.sim.cell import PAPER_ORIGIN
from inkarm.sim.gl import RenderError
from inkarm.sim.render import INK_RGB
from inkarm.sim.replay import LogReplay, check_log, ink_box_mm

if TYPE_CHECKING:
    from inkarm.core.log import DrawLog
    from inkarm.ink.canvas import InkModel
    from inkarm.sim.cell import Cell

_GLFW_PROBE = "import sys, glfw\nsys.exit(0 if glfw.init() else 1)\n"
VIEWER_PERIOD_S = 1.0 / 60.0  # how often the replay moves the viewer on, [s]
VIEWER_TEARDOWN_S = 2.0  # longest wait for the viewer's window to close, [s]


def require_display(timeout_s: float = 30.0) -> None:
    """Raise RenderError unless a window can be opened here: ``DISPLAY`` or ``WAYLAND_DISPLAY``
    must be set and GLFW (MuJoCo's viewer) must initialise on it, checked in a subprocess
    (mujoco's passive viewer waits forever when GLFW fails in its thread)."""
    shown = [
        f"{name}={os.environ[name]}"
        for name in ("DISPLAY", "WAYLAND_DISPLAY")
        if os.environ.get(name)
    ]
    if not shown:
        raise RenderError(
            "open_viewer: no display here (neither DISPLAY nor WAYLAND_DISPLAY is set: a "
            "server, container or SSH session without X forwarding); render a video instead "
            "(inkarm draw --video FILE.mp4)"
        )
    try:
        done = subprocess.run(
            [sys.executable, "-c", _GLFW_PROBE],
            check=False,
            capture_output=True,
            text=True,
            timeout=timeout_s,
        )
    except subprocess.TimeoutExpired:
        reason = f"GLFW did not initialise in {timeout_s} s"
    else:
        if done.returncode == 0:
            return
        lines = [line for line in done.stderr.strip().splitlines() if "GLFWError" in line]
        reason = lines[0].split("GLFWError:", 1)[1].strip() if lines else "glfw.init() failed"
    raise RenderError(
        f"open_viewer: {', '.join(shown)} is set but GLFW cannot open a window there: "
        f"{reason}; render a video instead (inkarm draw --video FILE.mp4)"
    )


def open_viewer(
    log: DrawLog,
    cell: Cell | None = None,
    *,
    ink: InkModel | str = "marker",
    contact_threshold_n: float = 0.02,
    speed: float = 1.0,
) -> None:
    """Replay the logged run ``log`` of the cell ``cell`` in MuJoCo's passive viewer at
    ``speed`` times real time, the ink appearing behind the pen (:class:`ViewerInk`); the last
    pose stays on screen. Returns when the window is closed. Needs a display
    (:func:`require_display`)."""
    import time as _time

    from inkarm.ink.canvas import make_ink
    from inkarm.sim.cell import build_spec, make_cell

    if not speed > 0:
        raise InputError(f"open_viewer: speed must be > 0, got {speed}")
    check_log(log)
    ink = make_ink(ink) if isinstance(ink, str) else ink
    require_display()
    import mujoco
    import mujoco.viewer  # loads GLFW: only once a display is known to work

    cell = cell or make_cell()
    model = build_spec(cell).compile()
    replay = LogReplay(
        model,
        log,
        None,
        pen_stiffness_n_per_mm=cell.pen_stiffness_n_per_mm,
        joint_names=cell.robot.joint_names,
        contact_threshold_n=contact_threshold_n,
    )
    t0, t1 = float(log.time[0]), float(log.time[-1])
    data = replay.seek(t0)
    before = set(threading.enumerate())
    with mujoco.viewer.launch_passive(
        model, data, show_left_ui=False, show_right_ui=False
    ) as viewer:
        viewer_threads = [t for t in threading.enumerate() if t not in before]
        marks = ViewerInk(model, data, log, viewer.user_scn, ink, contact_threshold_n)
        with viewer.lock():
            _aim_at_ink(viewer.cam, model, data, cell, ink_box_mm(log, contact_threshold_n))
        start = _time.perf_counter()
        while viewer.is_running():
            t = min(t0 + speed * (_time.perf_counter() - start), t1)
            with viewer.lock():
                replay.seek(t)
                marks.lay_until(replay.row)
            viewer.sync()
            _time.sleep(VIEWER_PERIOD_S)
    # Let the viewer's window thread finish tearing down: Python exiting under it crashed
    # (segmentation fault or GLXBadDrawable) in tests with mujoco 4.0 on Xvfb.
    deadline = _time.perf_counter() + VIEWER_TEARDOWN_S
    for thread in viewer_threads:
        thread.join(max(0.0, deadline - _time.perf_counter()))


class ViewerInk:
    """The ink of a replayed run as capsules in the viewer's user scene (an MjvScene whose
    geoms the passive viewer draws along with the model's).

    Why not the paper texture, as offscreen: the passive viewer's ``update_texture`` waits for
    its window's render loop and, with mujoco 4.0, deadlocks the process when the window is
    closed during that wait (seen in tests on Xvfb); user-scene geoms need no upload.

    Successive touching rows are joined by capsules of the ink model's width and opacity at
    the row's force and speed, a new capsule once the tip has moved ``min_segment_mm`` (as the
    canvas does). Once the scene is full (its ``maxgeom``), later ink is not shown.
    """

    def __init__(
        self,
        model,
        data,
        log: DrawLog,
        scene,
        ink: InkModel,
        contact_threshold_n: float = 0.02,
        min_segment_mm: float = 0.5,
    ):
        import mujoco

        origin = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, PAPER_ORIGIN)
        if origin < 0:
            raise InputError("ViewerInk: the model has no site paper_origin")
        self._origin = data.site_xpos[origin].copy()
        self._to_world = data.site_xmat[origin].reshape(3, 3).copy()
        self.log = log
        self.scene = scene
        self.ink = ink
        self.min_segment_mm = float(min_segment_mm)
        self._touching = np.asarray(log.force, float) > contact_threshold_n
        self._next_row = 0
        self._laid: np.ndarray | None = None  # page (x, y) [mm] where the last capsule ended

    def lay_until(self, row: int) -> None:
        """Add the ink of the log rows up to ``row``."""
        log = self.log
        for i in range(self._next_row, row + 1):
            if not self._touching[i]:
                self._laid = None
                continue
            p = np.asarray(log.tip[i, :2], float)
            if self._laid is None:
                self._laid = p
                continue
            if np.linalg.norm(p - self._laid) < self.min_segment_mm:
                continue
            dt = float(log.time[i] - log.time[i - 1])
            speed = float(np.linalg.norm(p - log.tip[i - 1, :2])) / dt if dt > 0 else 0.0
            width, opacity = self.ink.mark(float(log.force[i]), speed)
            self._capsule(self._laid, p, width, opacity)
            self._laid = p
        self._next_row = max(self._next_row, row + 1)

    def _capsule(self, a_mm, b_mm, width_mm: float, opacity: float) -> None:
        """A capsule of diameter ``width_mm`` from page point a to b, centred on the paper."""
        import mujoco

        scene = self.scene
        if scene.ngeom >= scene.maxgeom:
            return
        a, b = (self._origin + self._to_world @ [q[0], q[1], 0.0] / 1000.0 for q in (a_mm, b_mm))
        rgba = np.array([*(c / 255.0 for c in INK_RGB), opacity], np.float32)
        geom = scene.geoms[scene.ngeom]
        mujoco.mjv_initGeom(
            geom, mujoco.mjtGeom.mjGEOM_CAPSULE, np.zeros(3), np.zeros(3), np.eye(3).ravel(), rgba
        )
        mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_CAPSULE, width_mm / 2000.0, a, b)
        scene.ngeom += 1


def _aim_at_ink(camera, model, data, cell: Cell, box_mm) -> None:
    """Point the free MjvCamera ``camera`` at the centre of ``box_mm`` (page [mm]; the page's
    centre when None) as the :data:`DRAWING_CAMERA` does: from the writer's side, 35 deg above
    the paper, far enough back to show the wrist and pen too."""
    import mujoco

    width_mm, height_mm = cell.paper_size_mm
    x0, y0, x1, y1 = box_mm if box_mm is not None else (0.0, 0.0, width_mm, height_mm)
    origin = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, PAPER_ORIGIN)
    centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2, 0.0]) / 1000.0
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = data.site_xpos[origin] + data.site_xmat[origin].reshape(3, 3) @ centre
    camera.distance = 0.5
    camera.azimuth = cell.paper_yaw_deg  # looking along the page's +y
    camera.elevation = -35.0
