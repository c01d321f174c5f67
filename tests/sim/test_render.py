"""Rendering: paper texture layout, ink upload, frames, video. Tests marked ``gl`` skip with
the reason when no offscreen OpenGL backend works here (tests/sim/conftest.py)."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inkarm.errors import InputError
from inkarm.ink.canvas import Canvas, MarkerInk
from inkarm.sim import render as R

pytestmark = pytest.mark.sim

PAGE_MM = (60.0, 90.0)


def _cell(canvas: Canvas, textured: bool = True):
    """A page-sized paper box (page centre at the origin) under a top-down camera whose image
    up is the page's +y."""
    import mujoco

    spec = mujoco.MjSpec()
    w, h = (v / 1000.0 for v in PAGE_MM)
    spec.worldbody.add_geom(
        name="paper", type=mujoco.mjtGeom.mjGEOM_BOX, size=[w / 2, h / 2, 0.0005]
    )
    spec.worldbody.add_light(pos=[0.0, 0.0, 1.0], dir=[0.0, 0.0, -1.0])
    spec.worldbody.add_camera(name="top", pos=[0.0, 0.0, 0.12])
    if textured:
        R.add_paper_texture(spec, canvas, max_texture_px=256)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def _draw(canvas: Canvas, p0, p1, t0: float = 0.0) -> None:
    for k, s in enumerate(np.linspace(0.0, 1.0, 60)):
        canvas.touch(np.asarray(p0) + s * np.subtract(p1, p0), 1.0, t0 + 0.001 * k)
    canvas.lift()


def test_texture_shape_of_a4_at_10_px_per_mm():
    assert R.texture_shape(Canvas()) == (990, 700, 3)


@settings(max_examples=30, deadline=None)
@given(st.integers(1, 400), st.integers(1, 400), st.integers(1, 300))
def test_texture_shape_covers_the_raster_within_the_size_limit(rows, cols, limit):
    canvas = Canvas(size_mm=(cols, rows), px_per_mm=1.0)
    height, width, block = R.texture_shape(canvas, limit)
    assert max(height, width) <= limit
    assert height * block >= rows > (height - 1) * block
    assert width * block >= cols > (width - 1) * block


def test_texture_pixels_average_blocks_and_mix_paper_with_ink():
    darkness = np.zeros((4, 5), np.float32)
    darkness[:2, :2] = 1.0  # a full top-left block
    darkness[2:, 4] = 1.0  # half of the padded bottom-right block
    texels = R.texture_pixels(darkness, 2, ink_rgb=(0, 0, 0), paper_rgb=(200, 100, 50))
    assert texels.shape == (2, 3, 3) and texels.dtype == np.uint8
    assert texels[0, 0].tolist() == [0, 0, 0]
    assert texels[0, 1].tolist() == [200, 100, 50]
    assert texels[1, 2].tolist() == [100, 50, 25]


def test_add_paper_texture_needs_the_paper_geom():
    import mujoco

    with pytest.raises(InputError, match=r"add_paper_texture: the spec has no geom named 'paper'"):
        R.add_paper_texture(mujoco.MjSpec(), Canvas(size_mm=(10, 10)))


def test_paper_texture_is_blank_paper_at_first():
    canvas = Canvas(size_mm=PAGE_MM)
    model, _ = _cell(canvas)
    assert (model.tex_height[0], model.tex_width[0]) == (225, 150)
    assert np.all(model.tex_data.reshape(-1, 3) == R.PAPER_RGB)


@pytest.mark.gl
def test_ink_shows_on_the_paper_where_it_is_on_the_page():
    canvas = Canvas(size_mm=PAGE_MM, ink=MarkerInk(w0_mm=4.0, k_mm=0.0))
    model, data = _cell(canvas)
    with R.Renderer(model, canvas, height=240, width=240, camera="top") as renderer:
        blank = renderer.render(data).astype(float).mean(axis=2)
        _draw(canvas, [8.0, 8.0], [22.0, 8.0])  # along the bottom, left half of the page
        frame = renderer.render(data).astype(float).mean(axis=2)
    darkened = (blank - frame) > 60
    rows, cols = np.nonzero(darkened)
    assert rows.size > 20
    assert rows.min() > 120 and cols.max() < 120  # lower-left quadrant of the image


@pytest.mark.gl
def test_upload_sends_only_changes_and_keeps_the_texture_in_step():
    canvas = Canvas(size_mm=PAGE_MM)
    model, data = _cell(canvas)
    with R.Renderer(model, canvas, height=64, width=64, camera="top") as renderer:
        renderer.render(data)
        context = renderer._renderer._mjr_context
        assert not R.upload(model, context, canvas)
        _draw(canvas, [30.0, 45.0], [40.0, 60.0])
        assert R.upload(model, context, canvas)
        assert not R.upload(model, context, canvas)
    height, width, block = R.texture_shape(canvas, 256)
    texels = model.tex_data.reshape(height, width, 3)
    expected = R.texture_pixels(np.asarray(canvas.image), block)
    assert np.array_equal(texels, expected)


@pytest.mark.gl
def test_upload_rejects_a_texture_built_for_another_canvas():
    model, _ = _cell(Canvas(size_mm=PAGE_MM))
    other = Canvas(size_mm=(200.0, 30.0))
    with (
        R.Renderer(model, other, height=32, width=32) as renderer,
        pytest.raises(
            R.RenderError, match=r"upload: the model's paper texture is 225 x 150 texels"
        ),
    ):
        renderer.render(_cell(other, textured=False)[1])


def test_renderer_needs_the_paper_texture_to_show_ink():
    canvas = Canvas(size_mm=PAGE_MM)
    model, _ = _cell(canvas, textured=False)
    with pytest.raises(R.RenderError, match=r"the model has no texture 'paper_ink'"):
        R.Renderer(model, canvas)


@pytest.mark.gl
def test_renderer_larger_than_the_offscreen_buffer_is_refused():
    model, _ = _cell(Canvas(size_mm=PAGE_MM))
    with pytest.raises(R.RenderError, match=r"Image width 2000 > framebuffer width 640"):
        R.Renderer(model, height=100, width=2000)



def test_write_video_round_trip_pads_odd_sizes(tmp_path):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    frames = [np.full((31, 45, 3), 10 * k, np.uint8) for k in range(12)]
    path = R.write_video(frames, tmp_path / "clip.mp4", fps=24)
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    decoded = list(reader)
    assert meta["size"] == (46, 32) and meta["fps"] == pytest.approx(24.0)
    assert len(decoded) == 12


def test_write_video_errors(tmp_path, monkeypatch):
    pytest.importorskip("imageio_ffmpeg")
    good = np.zeros((16, 16, 3), np.uint8)
    with pytest.raises(InputError, match=r"write_video: no frames"):
        R.write_video([], tmp_path / "a.mp4")
    with pytest.raises(
        InputError, match=r"write_video: frame 1 has shape \(8, 16, 3\), frame 0 had \(16, 16, 3\)"
    ):
        R.write_video([good, good[:8]], tmp_path / "b.mp4")
    with pytest.raises(
        InputError, match=r"write_video: frame 0 must be \(H, W, 3\) uint8, got float64"
    ):
        R.write_video([good.astype(float)], tmp_path / "c.mp4")
    with pytest.raises(InputError, match=r"write_video: fps must be > 0, got 0"):
        R.write_video([good], tmp_path / "d.mp4", fps=0)
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    with pytest.raises(R.RenderError, match=r"pip install 'inkarm\[video\]'"):
        R.write_video([good], tmp_path / "e.mp4")
