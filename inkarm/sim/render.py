"""Offscreen frames and video of the drawing cell, with the ink visible on the paper.

The ink reaches the picture through a texture: :func:`add_paper_texture` gives the ``paper``
geom (a box or plane whose local x and y axes are the page's x and y, centred on the page) a
material whose RGB texture is a block-averaged copy of the canvas; :class:`Renderer` copies the
changed part of the canvas into ``model.tex_data`` and re-uploads the texture before each frame
(:func:`upload`). Texture row 0 is the top of the page (high y), as in the canvas raster.

Offscreen OpenGL must be chosen before ``mujoco`` is imported: :mod:`inkarm.sim.gl`.

Video: :func:`write_video` encodes H.264 MP4 with the ffmpeg binary that the optional
``imageio-ffmpeg`` package ships (``pip install 'inkarm[video]'``).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Self

import numpy as np

from inkarm.errors import InputError
from inkarm.sim.cell import PAPER
from inkarm.sim.gl import GL_ADVICE, RenderError

PAPER_TEXTURE = "paper_ink"
PAPER_RGB = (246, 244, 236)  # off-white paper
INK_RGB = (20, 22, 48)  # blue-black ink


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

