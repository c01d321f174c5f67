"""Replaying a logged run: frame times, the drawing camera, pose and ink, its video, and the
viewer. Tests marked ``gl`` skip with the reason when no offscreen OpenGL backend works here
(tests/sim/conftest.py)."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.core.log import DrawLog
from inkarm.errors import InputError
from inkarm.ink.canvas import Canvas, MarkerInk
from inkarm.robots.registry import load_robot
from inkarm.sim import replay as R
from inkarm.sim import viewer as V
from inkarm.sim.cell import make_cell
from inkarm.sim.gl import RenderError

pytestmark = pytest.mark.sim

HOME_Q = load_robot("iiwa14").home_q
DT = 0.006  # control period of the synthetic log [s]
LINE_Y_MM = 120.0  # the synthetic stroke runs along this page height
AWAY_Q = np.array(HOME_Q) + [2.8, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]  # arm turned away from the page


def _log(rows: int = 300, touch=(50, 250), q=AWAY_Q) -> DrawLog:
    """A synthetic run: the arm held at ``q``, the tip sweeping x = 60 -> 150 mm along
    y = LINE_Y_MM, pressing 1 N on the rows touch[0] <= k < touch[1] and 0 N elsewhere."""
    k = np.arange(rows)
    tip = np.column_stack(
        [np.linspace(60.0, 150.0, rows), np.full(rows, LINE_Y_MM), np.zeros(rows)]
    )
    force = np.where((k >= touch[0]) & (k < touch[1]), 1.0, 0.0)
    zeros = np.zeros((rows, 7))
    return DrawLog(
        time=DT * k,
        q=np.tile(q, (rows, 1)),
        qd=zeros,
        torque=zeros,
        tip=tip,
        force=force,
        reference=tip,
        phase=np.zeros(rows, np.int8),
        stroke=np.zeros(rows, np.int32),
    )


def _replay(log: DrawLog, **canvas_kw):
    cell = make_cell()
    canvas = Canvas(size_mm=cell.paper_size_mm, px_per_mm=2.0, **canvas_kw)
    model = R.replay_model(cell, canvas, drawing_box_mm=R.ink_box_mm(log, 0.02))
    replay = R.LogReplay(
        model,
        log,
        canvas,
        pen_stiffness_n_per_mm=cell.pen_stiffness_n_per_mm,
        joint_names=cell.robot.joint_names,
    )
    return model, replay, canvas


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 20.0), st.floats(0.5, 120.0), st.floats(-5.0, 5.0))
def test_frame_times_last_the_run_and_end_on_its_last_row(duration, fps, t0):
    times = R.frame_times(np.array([t0, t0 + duration]), fps)
    assert len(times) == max(1, math.ceil(duration * fps - 1e-9))
    assert times[-1] == pytest.approx(t0 + duration)
    assert np.all(np.diff(times) > 0) and times[0] > t0 - 1e-12
    assert np.allclose(times[:-1], t0 + np.arange(1, len(times)) / fps)


def test_ink_box_is_where_the_pen_touched():
    log = _log()
    x0, y0, x1, y1 = R.ink_box_mm(log, 0.02)
    assert (x0, x1) == pytest.approx((log.tip[50, 0], log.tip[249, 0]))
    assert y0 == y1 == LINE_Y_MM
    assert R.ink_box_mm(_log(touch=(0, 0)), 0.02) is None


def test_drawing_camera_looks_at_the_ink_from_the_writers_side():
    import mujoco

    log = _log()
    model, replay, _ = _replay(log)
    data = replay.seek(0.0)
    cam = R.camera_id(model, R.DRAWING_CAMERA)
    origin = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "paper_origin")
    to_world = data.site_xmat[origin].reshape(3, 3)
    centre_page = np.array([105.0, LINE_Y_MM, 0.0])  # middle of the touched x range 60..150
    centre = data.site_xpos[origin] + to_world @ centre_page / 1000.0
    axes = data.cam_xmat[cam].reshape(3, 3)
    sight = centre - data.cam_xpos[cam]
    assert np.allclose(np.cross(-axes[:, 2], sight), 0.0, atol=1e-9)  # on the optical axis
    eye_page = to_world.T @ (data.cam_xpos[cam] - data.site_xpos[origin]) * 1000.0
    assert eye_page[1] < LINE_Y_MM and eye_page[2] > 0  # the robot's side, above the paper
    assert np.allclose(to_world.T @ axes[:, 0], [1.0, 0.0, 0.0])  # image right = page +x


def test_log_replay_poses_the_arm_and_compresses_the_pen_by_f_over_k():
    import mujoco

    log = _log(q=np.array(HOME_Q))
    log.q[:, 1] += np.linspace(0.0, 0.2, len(log))
    log.force[100] = 1000.0  # far beyond the pen's travel
    model, replay, _ = _replay(log)
    slide = model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "pen_slide")]
    data = replay.seek(60.5 * DT)  # between rows 60 and 61: row 60 is shown
    assert np.allclose(data.qpos[:7], log.q[60])
    assert data.qpos[slide] == pytest.approx(1.0 / 0.3 / 1000.0)  # 1 N / 0.3 N/mm, in [m]
    assert replay.seek(100 * DT).qpos[slide] == pytest.approx(0.006)  # clipped to travel
    assert replay.seek(10.0).qpos[slide] == 0.0  # no force at the end, past the log


def test_log_replay_lays_ink_only_up_to_the_time_shown():
    log = _log()
    _, replay, canvas = _replay(log, ink=MarkerInk(w0_mm=2.0, k_mm=0.0))
    replay.seek(0.4 * len(log) * DT)  # 70 of the 200 touching rows done
    half = canvas.ink_points_mm()
    reached = log.tip[int(0.4 * len(log)), 0]
    assert half.size and half[:, 0].min() >= log.tip[50, 0] - 1.5
    assert half[:, 0].max() <= reached + 1.5
    replay.seek(log.time[-1])
    done = canvas.ink_points_mm()
    assert done[:, 0].max() == pytest.approx(log.tip[249, 0], abs=1.5)
    assert np.allclose(done[:, 1], LINE_Y_MM, atol=1.5)
    assert not canvas.in_contact  # the last stroke was finished


def _project(model, data, cam: int, page_mm: np.ndarray, width: int, height: int) -> np.ndarray:
    """Pixel (column, row) of page points (N, 3) [mm] seen from camera ``cam``."""
    import mujoco

    origin = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "paper_origin")
    world = data.site_xpos[origin] + page_mm / 1000.0 @ data.site_xmat[origin].reshape(3, 3).T
    local = (world - data.cam_xpos[cam]) @ data.cam_xmat[cam].reshape(3, 3)
    focal = 0.5 * height / math.tan(math.radians(model.cam_fovy[cam]) / 2.0)
    return np.column_stack(
        [
            0.5 * width + focal * local[:, 0] / -local[:, 2],
            0.5 * height - focal * local[:, 1] / -local[:, 2],
        ]
    )


@pytest.mark.gl
def test_video_of_a_log_shows_the_ink_where_the_pen_touched(tmp_path):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    log = _log()
    width, height, fps = 64, 48, 10.0
    calls = []
    path = R.render_log_video(
        log,
        tmp_path / "run.mp4",
        px_per_mm=2.0,
        ink=MarkerInk(w0_mm=12.0, k_mm=0.0),
        fps=fps,
        camera=R.DRAWING_CAMERA,
        width=width,
        height=height,
        progress=lambda f, phase: calls.append((f, phase)),
    )
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    frames = [np.frombuffer(f, np.uint8).reshape(height, width, 3) for f in reader]
    assert meta["size"] == (width, height)
    assert len(frames) == math.ceil(log.time[-1] * fps) == 18
    assert calls[-1] == (1.0, "video") and len(calls) == 18
    model, replay, _ = _replay(log)
    data = replay.seek(0.0)
    cam = R.camera_id(model, R.DRAWING_CAMERA)
    first, last = (f.astype(float).mean(axis=2) for f in (frames[0], frames[-1]))
    touched = np.column_stack([np.linspace(75.0, 135.0, 7), np.full(7, LINE_Y_MM), np.zeros(7)])
    cols, rows = np.round(_project(model, data, cam, touched, width, height)).astype(int).T
    assert np.all(first[rows, cols] - last[rows, cols] > 40)  # ink appeared on the line
    beside = touched + [0.0, 45.0, 0.0]  # well off the line: no ink there
    cols, rows = np.round(_project(model, data, cam, beside, width, height)).astype(int).T
    assert np.all(np.abs(first[rows, cols] - last[rows, cols]) < 15)


def test_render_log_video_errors(tmp_path, monkeypatch):
    log = _log(rows=20)
    with pytest.raises(InputError, match=r"render_log_video: .*run\.avi: expected a \.mp4"):
        R.render_log_video(log, tmp_path / "run.avi")
    with pytest.raises(InputError, match=r"render_log_video: fps must be > 0, got 0"):
        R.render_log_video(log, tmp_path / "run.mp4", fps=0)
    with pytest.raises(InputError, match=r"frame size must be >= 1 x 1, got 0 x 48"):
        R.render_log_video(log, tmp_path / "run.mp4", width=0, height=48)
    with pytest.raises(InputError, match=r"LogReplay: the log has 6 joints, the robot 7"):
        R.render_log_video(DrawLog(**{**log.__dict__, "q": log.q[:, :6]}), tmp_path / "run.mp4")
    with pytest.raises(
        RenderError,
        match=r"unknown camera 'side'; the cell's cameras are paper_top, overview, drawing, "
        r"pen_cam",
    ):
        R.render_log_video(log, tmp_path / "run.mp4", camera="side")
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    with pytest.raises(
        RenderError,
        match=r"render_log_video needs the optional package imageio-ffmpeg: "
        r"pip install 'inkarm\[video\]'",
    ):
        R.render_log_video(log, tmp_path / "run.mp4")
    assert not (tmp_path / "run.mp4").exists()


_NO_GL_RUN = """
import numpy as np
from inkarm.core.log import DrawLog
from inkarm.errors import InkarmError
from inkarm.sim.replay import render_log_video
z = np.zeros((3, 7))
log = DrawLog(time=np.arange(3) * 0.1, q=z, qd=z, torque=z, tip=np.zeros((3, 3)),
              force=np.zeros(3), reference=np.zeros((3, 3)), phase=np.zeros(3, np.int8),
              stroke=np.zeros(3, np.int32))
try:
    render_log_video(log, {path!r})
except InkarmError as err:
    print(type(err).__name__, err)
"""


def test_render_log_video_without_opengl_says_what_to_install(tmp_path):
    pytest.importorskip("imageio_ffmpeg")
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MUJOCO_GL"] = "glfw"  # needs a display, and there is none
    done = subprocess.run(
        [sys.executable, "-c", _NO_GL_RUN.format(path=str(tmp_path / "run.mp4"))],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    message = done.stdout.strip()
    assert message.startswith("RenderError Renderer: offscreen OpenGL failed (MUJOCO_GL=glfw)")
    for needed in ("MUJOCO_GL=egl", "libegl1", "MUJOCO_GL=osmesa", "libosmesa6"):
        assert needed in message


# -- the viewer ----------------------------------------------------------------------------------


def test_viewer_ink_lays_capsules_along_the_touched_path_only():
    import mujoco

    log = _log()
    model, replay, _ = _replay(log)
    data = replay.seek(0.0)
    scene = mujoco.MjvScene(model, maxgeom=1000)
    ink = MarkerInk(w0_mm=2.0, k_mm=0.0, opacity=0.8)
    marks = V.ViewerInk(model, data, log, scene, ink)
    marks.lay_until(49)  # the pen has not touched yet
    assert scene.ngeom == 0
    marks.lay_until(len(log) - 1)
    step_mm = 90.0 / (len(log) - 1)  # tip travel per row
    spacing = math.ceil(0.5 / step_mm)  # rows per capsule: >= 0.5 mm apart
    assert scene.ngeom == 199 // spacing
    origin = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "paper_origin")
    for geom in scene.geoms[: scene.ngeom]:
        page = data.site_xmat[origin].reshape(3, 3).T @ (geom.pos - data.site_xpos[origin])
        assert page[1] * 1000.0 == pytest.approx(LINE_Y_MM) and abs(page[2]) < 1e-9
        assert log.tip[50, 0] <= page[0] * 1000.0 <= log.tip[249, 0]
        assert geom.size[0] == pytest.approx(0.001)  # radius: half the 2 mm width, in [m]
        assert geom.rgba[3] == pytest.approx(0.8)
    full = mujoco.MjvScene(model, maxgeom=5)
    V.ViewerInk(model, data, log, full, ink).lay_until(len(log) - 1)
    assert full.ngeom == 5  # a full scene takes no more


def test_viewer_without_a_display_says_so(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(
        RenderError,
        match=r"open_viewer: no display here \(neither DISPLAY nor WAYLAND_DISPLAY is set",
    ):
        V.open_viewer(_log(rows=20))


def test_viewer_on_a_display_that_cannot_be_opened_says_so(monkeypatch):
    monkeypatch.setenv("DISPLAY", ":4321")
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(
        RenderError,
        match=r"open_viewer: DISPLAY=:4321 is set but GLFW cannot open a window there: ",
    ):
        V.open_viewer(_log(rows=20))


def test_viewer_speed_must_be_positive():
    with pytest.raises(InputError, match=r"open_viewer: speed must be > 0, got -1"):
        V.open_viewer(_log(rows=20), speed=-1)
