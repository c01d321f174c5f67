"""Replaying a finished run from its :class:`DrawLog`, and the run's offscreen video.

:func:`render_log_video` (offscreen video) and :func:`inkarm.sim.viewer.open_viewer` (MuJoCo's
passive viewer, needs a display) play a finished run back from its :class:`DrawLog` rather than
rendering during the simulation, which keeps the control loop's timing free of OpenGL: the
logged joint angles pose a fresh cell model, the pen spring is compressed by F / k, and the ink
is laid again from the logged tip and force (:class:`LogReplay`): on a fresh canvas shown by
the paper texture offscreen, as capsules in the viewer's user scene
(:class:`inkarm.sim.viewer.ViewerInk`). The video's model has one more camera, ``drawing``
(:func:`add_drawing_camera`), close on the ink.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inkarm.errors import InputError
from inkarm.sim.gl import RenderError
from inkarm.sim.render import (
    Renderer,
    add_paper_texture,
    require_ffmpeg,
    set_offscreen_size,
    write_video,
)

if TYPE_CHECKING:
    from inkarm.core.log import DrawLog
    from inkarm.ink.canvas import InkModel
    from inkarm.sim.cell import Cell

DRAWING_CAMERA = "drawing"


def replay_model(
    cell: Cell | None,
    canvas,
    *,
    width: int = 640,
    height: int = 480,
    max_texture_px: int = 1024,
    drawing_box_mm: tuple[float, float, float, float] | None = None,
):
    """The drawing cell of ``cell`` (default: :func:`inkarm.sim.cell.make_cell`) compiled with its paper
    textured for ``canvas``, an offscreen buffer of at least width x height pixels and a
    camera :data:`DRAWING_CAMERA` framing ``drawing_box_mm`` (:func:`add_drawing_camera`)."""
    from inkarm.sim.cell import build_spec, make_cell

    cell = cell or make_cell()
    spec = build_spec(cell)
    add_paper_texture(spec, canvas, max_texture_px=max_texture_px)
    add_drawing_camera(spec, cell, drawing_box_mm)
    set_offscreen_size(spec, width, height)
    return spec.compile()


def ink_box_mm(
    log: DrawLog, contact_threshold_n: float
) -> tuple[float, float, float, float] | None:
    """(x_min, y_min, x_max, y_max) in page [mm] of the tip where ``log`` says the pen touched
    (force > ``contact_threshold_n``), or None when it never did."""
    touching = np.asarray(log.force, float) > contact_threshold_n
    if not touching.any():
        return None
    tip = np.asarray(log.tip, float)[touching, :2]
    return (*tip.min(axis=0).tolist(), *tip.max(axis=0).tolist())


def add_drawing_camera(
    spec,
    cell: Cell,
    box_mm: tuple[float, float, float, float] | None = None,
    *,
    elevation_deg: float = 35.0,
    fovy_deg: float = 45.0,
    margin: float = 3.0,
) -> None:
    """Add the camera :data:`DRAWING_CAMERA` to the cell's MjSpec: from the writer's side of
    the page (its -y edge, where the robot stands), ``elevation_deg`` above the paper, it looks
    at the centre of ``box_mm`` (page [mm]; the whole page when None) from the distance where
    ``margin`` times the box (at least 40 mm) fills its field of view. Writing reads upright
    (image right = page +x), and the camera sits below the forearm, which comes down from the
    top of the picture to the pen. A fill light shines from the camera, casting no shadow."""
    import mujoco

    from inkarm.sim.cell import paper_rotation

    width_mm, height_mm = cell.paper_size_mm
    x0, y0, x1, y1 = box_mm if box_mm is not None else (0.0, 0.0, width_mm, height_mm)
    centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2, 0.0])
    span = margin * max(x1 - x0, y1 - y0, 40.0)
    distance = span / (2.0 * math.tan(math.radians(fovy_deg) / 2.0))
    e = math.radians(elevation_deg)
    # Camera axes in the page frame (MuJoCo cameras look along their -z).
    back = np.array([0.0, -math.cos(e), math.sin(e)])
    up = np.array([0.0, math.sin(e), math.cos(e)])
    right = np.cross(up, back)
    rotation = paper_rotation(cell.paper_yaw_deg)  # page axes -> robot base frame
    offset = np.array([width_mm / 2, height_mm / 2, -cell.paper_thickness_mm])
    eye_mm = centre + distance * back - offset  # relative to the paper's centre
    world_centre = np.array([*cell.paper_centre_mm, 0.0])
    camera_axes = rotation @ np.column_stack([right, up, back])
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(camera_axes).ravel())
    eye = (world_centre + rotation @ eye_mm) / 1000.0
    spec.worldbody.add_camera(name=DRAWING_CAMERA, pos=eye, quat=quat, fovy=fovy_deg)
    # The cell's light is overhead, so the arm's shadow lies on the ink: a fill light from the
    # camera, casting no shadow, keeps the page readable.
    spec.worldbody.add_light(
        name=f"{DRAWING_CAMERA}_fill",
        pos=eye,
        dir=-camera_axes[:, 2],
        type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
        castshadow=False,
        diffuse=[0.8, 0.8, 0.8],
    )


def camera_id(model, name: str, caller: str = "camera_id") -> int:
    """The id of the camera ``name`` in ``model``; the error lists the cameras there are."""
    import mujoco

    cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, str(name))
    if cam < 0:
        names = ", ".join(model.camera(i).name for i in range(model.ncam)) or "none"
        raise RenderError(f"{caller}: unknown camera {name!r}; the cell's cameras are {names}")
    return cam


class LogReplay:
    """A logged run played back into the cell's MjData and onto a fresh canvas.

    :meth:`seek` to a time t in [s] shows the last log row at or before t:

    * arm joints: the logged q;
    * pen slide: the static deflection of the pen spring under the logged contact force,
      compression = F / k [mm] (Hooke's law, k the cell's
      ``pen_stiffness_n_per_mm``), clipped to the pen's travel; 0 where F is NaN;
    * ink: every row up to t is fed to the canvas in order, ``touch(tip[:2], F, time)`` while
      F > ``contact_threshold_n`` and ``lift()`` otherwise, so the ink appears behind the pen.

    The log holds one row per control period (3 physics steps in the default cell) where the
    plant inked every physics step: the replayed ink is the same path joined by capsules three
    times longer, a chord error of (v T)^2 / (8 R), 0.02 mm at 100 mm/s on a 2 mm radius.
    Time only moves forwards: seeking back keeps the ink already laid.

    Args:
        model: A cell model (:func:`replay_model`) with joints ``joint1..7`` and ``pen_slide``.
        log: The run's :class:`inkarm.core.log.DrawLog` (time, q, tip, force are used).
        canvas: The canvas the ink goes to (blank at first), or None for no ink.
        pen_stiffness_n_per_mm: Pen spring rate k in [N/mm].
        contact_threshold_n: Force in [N] above which the pen counts as touching.
    """

    def __init__(
        self,
        model,
        log: DrawLog,
        canvas,
        *,
        pen_stiffness_n_per_mm: float,
        joint_names,
        contact_threshold_n: float = 0.02,
    ):
        import mujoco

        from inkarm.sim.cell import HOME_KEY, PEN_SLIDE

        check_log(log)
        if not pen_stiffness_n_per_mm > 0:
            raise InputError(
                f"LogReplay: pen_stiffness_n_per_mm must be > 0, got {pen_stiffness_n_per_mm}"
            )
        joints = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n) for n in joint_names]
        slide = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, PEN_SLIDE)
        if min(joints) < 0 or slide < 0:
            raise InputError(
                f"LogReplay: the model needs the joints {', '.join(joint_names)} and {PEN_SLIDE}"
            )
        if np.shape(log.q)[1] != len(joint_names):
            raise InputError(f"LogReplay: the log has {np.shape(log.q)[1]} joints, the robot "
                             f"{len(joint_names)} ({', '.join(joint_names)})")
        self.model = model
        self.data = mujoco.MjData(model)
        self.log = log
        self.canvas = canvas
        self.contact_threshold_n = float(contact_threshold_n)
        self._qpos_adr = np.array([model.jnt_qposadr[j] for j in joints])
        self._slide_adr = int(model.jnt_qposadr[slide])
        force = np.nan_to_num(np.asarray(log.force, float), nan=0.0)
        travel_m = float(model.jnt_range[slide][1]) if model.jnt_limited[slide] else np.inf
        # Hooke: compression [mm] = F / k, in [m] for MuJoCo.
        self._slide_m = np.clip(force / pen_stiffness_n_per_mm / 1000.0, 0.0, travel_m)
        self._touching = np.asarray(log.force, float) > self.contact_threshold_n
        self._next_row = 0  # the first row not yet fed to the canvas
        self.row = 0  # the log row shown
        key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, HOME_KEY)
        if key >= 0:
            mujoco.mj_resetDataKeyframe(model, self.data, key)

    def seek(self, t: float):
        """Pose and ink at time ``t`` in [s] (clamped to the log); returns the MjData."""
        import mujoco

        log = self.log
        row = max(0, int(np.searchsorted(log.time, t, side="right")) - 1)
        if self.canvas is not None:
            for i in range(self._next_row, row + 1):
                if self._touching[i]:
                    self.canvas.touch(log.tip[i, :2], float(log.force[i]), float(log.time[i]))
                else:
                    self.canvas.lift()
            if row + 1 == len(log):  # the run is over: finish the last stroke
                self.canvas.lift()
        self._next_row = max(self._next_row, row + 1)
        self.row = row
        self.data.qpos[self._qpos_adr] = log.q[row]
        self.data.qpos[self._slide_adr] = self._slide_m[row]
        self.data.time = float(log.time[row])
        mujoco.mj_forward(self.model, self.data)
        return self.data


def check_log(log: DrawLog) -> None:
    """Raise InputError unless ``log`` has rows, time, q, tip and force of matching lengths
    and finite, non-decreasing times."""
    n = len(np.asarray(log.time))
    if n < 1:
        raise InputError("DrawLog: the log has no rows")
    expected = {"time": (n,), "q": (n, np.shape(log.q)[-1]), "tip": (n, 3), "force": (n,)}
    for name, shape in expected.items():
        got = np.shape(getattr(log, name))
        if got != shape:
            raise InputError(f"DrawLog.{name}: expected shape {shape}, got {got}")
    time = np.asarray(log.time, float)
    if not np.isfinite(time).all() or np.any(np.diff(time) < 0):
        raise InputError("DrawLog.time: expected finite, non-decreasing times")


def frame_times(time_s: np.ndarray, fps: float) -> np.ndarray:
    """Times in [s] shown by the frames of a video of a run logged at ``time_s``: frame k shows
    the end of its interval, t0 + (k + 1) / fps clamped to the end of the log, for
    k < ceil(duration fps) (at least one frame), so that the video lasts the run, rounded up
    to a whole frame, and its last frame shows the finished page."""
    if not fps > 0:
        raise InputError(f"fps must be > 0, got {fps}")
    t0, t1 = float(time_s[0]), float(time_s[-1])
    count = max(1, math.ceil((t1 - t0) * fps - 1e-9))
    return np.minimum(t0 + np.arange(1, count + 1) / fps, t1)


def render_log_video(
    log: DrawLog,
    path: str | Path,
    cell: Cell | None = None,
    *,
    px_per_mm: float = 10.0,
    ink: InkModel | str = "marker",
    fps: float = 30.0,
    camera: str = DRAWING_CAMERA,
    width: int = 640,
    height: int = 480,
    contact_threshold_n: float = 0.02,
    progress: Callable[[float, str], None] | None = None,
) -> Path:
    """Render the logged run ``log`` of the cell ``cell`` offscreen as an H.264 MP4 at ``path``
    and return the path.

    The run is replayed after the fact (:class:`LogReplay`) into a fresh cell model whose paper
    shows a fresh canvas of ``px_per_mm`` [px/mm] with ``ink``, so each frame has the ink laid
    so far. ``fps`` frames per simulated second (:func:`frame_times`), width x height pixels
    (an odd size is padded by a pixel, see :func:`write_video`), seen from ``camera``:
    ``drawing`` (close on the ink, from the writer's side: :func:`add_drawing_camera`), or the
    cell's ``overview`` (the whole cell: the arm, but the ink is too thin to see), ``paper_top``
    (the arm hides most of the page) or ``pen_cam`` (on the wrist, following the pen).
    ``progress(fraction, "video")`` is called after each frame.

    Needs offscreen OpenGL (``MUJOCO_GL=egl`` or ``osmesa`` set before ``mujoco`` is
    imported: :func:`configure_gl`) and the optional ``imageio-ffmpeg``.
    """
    from inkarm.ink.canvas import Canvas
    from inkarm.sim.cell import make_cell

    path = Path(path)
    if path.suffix.lower() != ".mp4":
        raise InputError(f"render_log_video: {path}: expected a .mp4 file name")
    if not fps > 0:
        raise InputError(f"render_log_video: fps must be > 0, got {fps}")
    if int(width) < 1 or int(height) < 1:
        raise InputError(f"render_log_video: frame size must be >= 1 x 1, got {width} x {height}")
    require_ffmpeg("render_log_video")
    check_log(log)
    cell = cell or make_cell()
    canvas = Canvas(size_mm=cell.paper_size_mm, px_per_mm=px_per_mm, ink=ink)
    box = ink_box_mm(log, contact_threshold_n)
    model = replay_model(cell, canvas, width=width, height=height, drawing_box_mm=box)
    cam = camera_id(model, camera, "render_log_video")
    replay = LogReplay(
        model,
        log,
        canvas,
        pen_stiffness_n_per_mm=cell.pen_stiffness_n_per_mm,
        joint_names=cell.robot.joint_names,
        contact_threshold_n=contact_threshold_n,
    )
    times = frame_times(np.asarray(log.time, float), fps)
    path.parent.mkdir(parents=True, exist_ok=True)
    with Renderer(model, canvas, height=int(height), width=int(width), camera=cam) as renderer:

        def frames():
            for k, t in enumerate(times):
                yield renderer.render(replay.seek(t))
                if progress is not None:
                    progress((k + 1) / len(times), "video")

        return write_video(frames(), path, fps)
