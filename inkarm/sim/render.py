"""Offscreen frames and video of the drawing cell, with the ink visible on the paper.

The ink reaches the picture through a texture: :func:`add_paper_texture` gives the ``paper``
geom (a box or plane whose local x and y axes are the page's x and y, centred on the page) a
material whose RGB texture is a block-averaged copy of the canvas; :class:`Renderer` copies the
changed part of the canvas into ``model.tex_data`` and re-uploads the texture before each frame
(:func:`upload`). Texture row 0 is the top of the page (high y), as in the canvas raster.

OpenGL without a display. MuJoCo chooses its backend from ``MUJOCO_GL`` once, when ``mujoco``
is first imported; :func:`configure_gl` (call it before that import, e.g. first thing in a CLI
command) keeps a value already set or else picks the first of EGL and OSMesa that works here,
each probed in a subprocess. System packages (Debian 12 / Ubuntu names; PyOpenGL comes from pip
with mujoco):

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

Video: :func:`write_video` encodes H.264 MP4 with the ffmpeg binary that the optional
``imageio-ffmpeg`` package ships (``pip install 'inkarm[video]'``).

Replays. :func:`render_log_video` (offscreen video) and :func:`open_viewer` (MuJoCo's passive
viewer, needs a display) play a finished run back from its :class:`DrawLog` rather than
rendering during the simulation, which keeps the control loop's timing free of OpenGL: the
logged joint angles pose a fresh cell model, the pen spring is compressed by F / k, and the ink
is laid again from the logged tip and force (:class:`LogReplay`): on a fresh canvas shown by
the paper texture offscreen, as capsules in the viewer's user scene (:class:`ViewerInk`). The
video's model has one more camera, ``drawing`` (:func:`add_drawing_camera`), close on the ink.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import threading
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Self

import numpy as np

from inkarm.errors import InkarmError, InputError
from inkarm.sim.cell import PAPER, PAPER_ORIGIN

if TYPE_CHECKING:  # mujoco must not be imported before configure_gl() has run
    from inkarm.core.log import DrawLog
    from inkarm.ink.canvas import InkModel
    from inkarm.sim.cell import Cell

PAPER_TEXTURE = "paper_ink"
PAPER_RGB = (246, 244, 236)  # off-white paper
INK_RGB = (20, 22, 48)  # blue-black ink
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


def texture_shape(canvas, max_texture_px: int = 1024) -> tuple[int, int, int]:
    """(height, width, block) of the paper texture for ``canvas``: the raster averaged over
    block x block pixels, the smallest integer block that keeps both sides <= max_texture_px."""
    if max_texture_px < 1:
        raise InputError(f"max_texture_px: expected >= 1, got {max_texture_px}")
    n_rows, n_cols = canvas.shape
    long_texels = math.ceil(max(n_rows, n_cols) / math.ceil(max(n_rows, n_cols) / max_texture_px))
    block = _block_size(canvas.shape, long_texels)
    return math.ceil(n_rows / block), math.ceil(n_cols / block), block


def _block_size(shape: tuple[int, int], long_texels: int) -> int:
    """The smallest block that fits the raster's long side into ``long_texels`` texels."""
    return math.ceil(max(shape) / long_texels)


def add_paper_texture(
    spec,
    canvas,
    *,
    geom_name: str = PAPER,
    max_texture_px: int = 1024,
    paper_rgb: tuple[int, int, int] = PAPER_RGB,
) -> None:
    """Give the geom ``geom_name`` of the MjSpec ``spec`` a material textured with the blank
    page of ``canvas`` (texture and material both named :data:`PAPER_TEXTURE`). The geom must
    be a box or plane spanning the page, its local x, y axes along the page's x, y."""
    import mujoco

    geom = spec.geom(geom_name)
    if geom is None:
        raise InputError(f"add_paper_texture: the spec has no geom named {geom_name!r}")
    height, width, _ = texture_shape(canvas, max_texture_px)
    texture = spec.add_texture(
        name=PAPER_TEXTURE,
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        width=width,
        height=height,
        nchannel=3,
    )
    texture.data = np.broadcast_to(np.asarray(paper_rgb, np.uint8), (height, width, 3)).tobytes()
    material = spec.add_material(name=PAPER_TEXTURE)
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = PAPER_TEXTURE
    geom.material = PAPER_TEXTURE
    geom.rgba = [1.0, 1.0, 1.0, 1.0]  # the texture colour, not tinted


def set_offscreen_size(spec, width: int, height: int) -> None:
    """Grow the model's offscreen framebuffer to at least width x height pixels (MuJoCo's
    default is 640 x 480; a Renderer cannot be larger)."""
    visual = spec.visual.global_
    visual.offwidth = max(int(visual.offwidth), int(width))
    visual.offheight = max(int(visual.offheight), int(height))


def texture_pixels(
    darkness: np.ndarray,
    block: int,
    ink_rgb: tuple[int, int, int] = INK_RGB,
    paper_rgb: tuple[int, int, int] = PAPER_RGB,
) -> np.ndarray:
    """RGB texels (ceil(rows/block), ceil(cols/block), 3) uint8 of a darkness raster: the mean
    darkness d of each block x block tile (zero-padded at the bottom and right) mixed as
    (1 - d) paper + d ink."""
    n_rows, n_cols = darkness.shape
    pad_rows, pad_cols = (-n_rows) % block, (-n_cols) % block
    tiles = np.pad(darkness, ((0, pad_rows), (0, pad_cols)))
    d = tiles.reshape(tiles.shape[0] // block, block, tiles.shape[1] // block, block).mean((1, 3))
    paper = np.asarray(paper_rgb, np.float32)
    ink = np.asarray(ink_rgb, np.float32)
    return (paper + d[..., None] * (ink - paper) + 0.5).astype(np.uint8)


def write_texture(
    model,
    canvas,
    *,
    full: bool = False,
    ink_rgb: tuple[int, int, int] = INK_RGB,
    paper_rgb: tuple[int, int, int] = PAPER_RGB,
    caller: str = "write_texture",
) -> int | None:
    """Copy the part of ``canvas`` changed since the last call (everything when ``full``) into
    the paper texture in ``model.tex_data``; return the texture id when anything changed (the
    texture then needs uploading to the GPU), else None.

    Consumes the canvas's dirty box (:meth:`Canvas.take_dirty_box`): use one writer per canvas
    (one :class:`Renderer`, switching cameras, rather than several)."""
    import mujoco

    tex_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXTURE, PAPER_TEXTURE)
    if tex_id < 0:
        raise RenderError(
            f"{caller}: the model has no texture {PAPER_TEXTURE!r}; call "
            "inkarm.sim.render.add_paper_texture(spec, canvas) before compiling it"
        )
    height, width = int(model.tex_height[tex_id]), int(model.tex_width[tex_id])
    long_texels = height if canvas.shape[0] >= canvas.shape[1] else width
    block = _block_size(canvas.shape, long_texels)
    if (math.ceil(canvas.shape[0] / block), math.ceil(canvas.shape[1] / block)) != (height, width):
        raise RenderError(
            f"{caller}: the model's paper texture is {height} x {width} texels, which no block "
            f"size maps onto the canvas's {canvas.shape[0]} x {canvas.shape[1]} pixels; "
            "build the texture with add_paper_texture(spec, canvas) from this canvas"
        )
    box = canvas.take_dirty_box()
    if full:
        box = (0, canvas.shape[0], 0, canvas.shape[1])
    if box is None:
        return None
    r0, r1 = box[0] // block, math.ceil(box[1] / block)
    c0, c1 = box[2] // block, math.ceil(box[3] / block)
    darkness = canvas.image[r0 * block : r1 * block, c0 * block : c1 * block]
    adr = int(model.tex_adr[tex_id])
    texels = model.tex_data[adr : adr + height * width * 3].reshape(height, width, 3)
    texels[r0:r1, c0:c1] = texture_pixels(darkness, block, ink_rgb, paper_rgb)
    return tex_id


def upload(
    model,
    context,
    canvas,
    *,
    full: bool = False,
    ink_rgb: tuple[int, int, int] = INK_RGB,
    paper_rgb: tuple[int, int, int] = PAPER_RGB,
) -> bool:
    """:func:`write_texture`, then upload the changed texture to the MjrContext ``context``,
    whose OpenGL context must be current. Returns whether anything was uploaded."""
    import mujoco

    tex_id = write_texture(
        model, canvas, full=full, ink_rgb=ink_rgb, paper_rgb=paper_rgb, caller="upload"
    )
    if tex_id is None:
        return False
    mujoco.mjr_uploadTexture(model, context, tex_id)
    return True


def look_at_paper(
    model,
    data,
    *,
    geom_name: str = PAPER,
    azimuth_deg: float = 90.0,
    elevation_deg: float = -60.0,
    distance_scale: float = 1.3,
):
    """A free MjvCamera aimed at the centre of the paper geom from ``distance_scale`` times
    its diagonal, at the given azimuth and elevation in [deg]."""
    import mujoco

    geom_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, geom_name)
    if geom_id < 0:
        raise InputError(f"look_at_paper: the model has no geom named {geom_name!r}")
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = data.geom_xpos[geom_id]
    camera.distance = distance_scale * 2.0 * float(np.linalg.norm(model.geom_size[geom_id][:2]))
    camera.azimuth = azimuth_deg
    camera.elevation = elevation_deg
    return camera


class Renderer:
    """Offscreen RGB frames of a model whose paper shows the ink of ``canvas``.

    Args:
        model: The compiled MjModel (with :func:`add_paper_texture` applied when ``canvas`` is
            given).
        canvas: The ink raster shown on the paper, or None for no ink.
        height, width: Frame size in pixels (at most the model's offscreen buffer, see
            :func:`set_offscreen_size`).
        camera: Camera id, name or MjvCamera used when :meth:`render` is given none
            (-1: MuJoCo's default free camera).
    """

    def __init__(self, model, canvas=None, *, height: int = 480, width: int = 640, camera=-1):
        import mujoco

        if canvas is not None and (
            mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXTURE, PAPER_TEXTURE) < 0
        ):
            raise RenderError(
                f"Renderer: the model has no texture {PAPER_TEXTURE!r} to show the ink on; "
                "call inkarm.sim.render.add_paper_texture(spec, canvas) before compiling"
            )
        try:
            self._renderer = mujoco.Renderer(model, height, width)
        except ValueError as err:
            raise RenderError(f"Renderer: {err}") from None
        except Exception as err:  # the GL backends raise assorted types
            raise RenderError(
                f"Renderer: offscreen OpenGL failed (MUJOCO_GL="
                f"{os.environ.get('MUJOCO_GL', '<unset>')}): {err}. {GL_ADVICE}"
            ) from err
        self.model = model
        self.canvas = canvas
        self.camera = camera
        self._uploaded_once = False

    def render(self, data, camera=None) -> np.ndarray:
        """The frame (height, width, 3) uint8 of ``data`` seen from ``camera`` (default: the
        constructor's), the paper showing the canvas as it is now."""
        self._renderer.update_scene(data, camera=self.camera if camera is None else camera)
        if self.canvas is not None:
            # mujoco.Renderer exposes no public handle on its contexts; uploading needs both.
            gl_context = self._renderer._gl_context
            if gl_context is not None:
                gl_context.make_current()
            upload(
                self.model, self._renderer._mjr_context, self.canvas, full=not self._uploaded_once
            )
            self._uploaded_once = True
        return self._renderer.render()

    def close(self) -> None:
        """Free the OpenGL context. Idempotent."""
        self._renderer.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def require_ffmpeg(caller: str = "write_video"):
    """The optional ``imageio_ffmpeg`` module (its ffmpeg binary encodes the video), or a
    RenderError saying how to install it."""
    try:
        import imageio_ffmpeg
    except ImportError:
        raise RenderError(
            f"{caller} needs the optional package imageio-ffmpeg: "
            "pip install 'inkarm[video]' (or pip install imageio-ffmpeg)"
        ) from None
    return imageio_ffmpeg


def write_video(frames: Iterable[np.ndarray], path: str | Path, fps: float = 30.0) -> Path:
    """Encode RGB frames (each (H, W, 3) uint8, all the same size) as an H.264 MP4 at ``fps``
    frames per second and return the path. An odd height or width is padded by one row or
    column (yuv420p needs even sizes). Needs the optional ``imageio-ffmpeg`` package."""
    imageio_ffmpeg = require_ffmpeg("write_video")
    if not fps > 0:
        raise InputError(f"write_video: fps must be > 0, got {fps}")
    path = Path(path)
    writer = None
    shape = None
    try:
        for index, frame in enumerate(frames):
            frame = np.asarray(frame)
            if frame.ndim != 3 or frame.shape[2] != 3 or frame.dtype != np.uint8:
                raise InputError(
                    f"write_video: frame {index} must be (H, W, 3) uint8, "
                    f"got {frame.dtype} {frame.shape}"
                )
            if shape is None:
                shape = frame.shape
                even = (frame.shape[1] + frame.shape[1] % 2, frame.shape[0] + frame.shape[0] % 2)
                writer = imageio_ffmpeg.write_frames(
                    str(path),
                    even,
                    fps=fps,
                    codec="libx264",
                    pix_fmt_out="yuv420p",
                    macro_block_size=1,
                    ffmpeg_log_level="error",
                )
                writer.send(None)
            elif frame.shape != shape:
                raise InputError(
                    f"write_video: frame {index} has shape {frame.shape}, frame 0 had {shape}"
                )
            pad = ((0, frame.shape[0] % 2), (0, frame.shape[1] % 2), (0, 0))
            writer.send(np.ascontiguousarray(np.pad(frame, pad, mode="edge")))
    finally:
        if writer is not None:
            writer.close()
    if shape is None:
        raise InputError("write_video: no frames")
    return path


# -- replaying a logged run ----------------------------------------------------------------------


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
        log: The run's :class:`inkarm.control.loop.DrawLog` (time, q, tip, force are used).
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

        _check_log(log)
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


def _check_log(log: DrawLog) -> None:
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
    _check_log(log)
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


# -- the interactive viewer ----------------------------------------------------------------------

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
    _check_log(log)
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
