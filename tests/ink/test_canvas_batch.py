"""Canvas.touch_many against touch and lift one at a time: the same canvas, exactly (issue 22)."""

from __future__ import annotations

import numpy as np
import pytest

from inkarm.errors import InputError
from inkarm.ink.canvas import Canvas
from inkarm.ink.capsules import rasterise


def _steps(seed: int, n: int = 600) -> list[tuple[float, float, float, float]]:
    """(force [N], x [mm], y [mm], t [s]) of a pen wandering over a 20 x 15 mm page: contact
    runs broken by lifts (force <= 0), forces under the marker's threshold, jumps longer than
    a segment, repeated times (dt = 0) and uneven steps."""
    rng = np.random.default_rng(seed)
    x, y, t, steps = 10.0, 7.0, 0.0, []
    for _ in range(n):
        t += float(rng.choice([0.002, 0.002, 0.002, 0.0, 0.0013]))
        jump = 3.0 if rng.random() < 0.05 else 0.15
        x = float(np.clip(x + rng.normal(0.0, jump), -1.0, 21.0))
        y = float(np.clip(y + rng.normal(0.0, jump), -1.0, 16.0))
        roll = rng.random()
        force = (0.0 if roll < 0.08 else -0.1 if roll < 0.1 else 0.04 if roll < 0.2
                 else float(rng.uniform(0.1, 3.0)))
        steps.append((force, x, y, t))
    return steps


def _one_at_a_time(canvas: Canvas, steps) -> None:
    """The compiled plant's feed before touch_many: touch while the force is positive, lift
    when contact ends."""
    touching = False
    for force, x, y, t in steps:
        if force > 0.0:
            touching = True
            canvas.touch((x, y), force, t)
        elif touching:
            touching = False
            canvas.lift()


def _assert_same(a: Canvas, b: Canvas) -> None:
    np.testing.assert_array_equal(a.image, b.image)
    assert (a.n_strokes, a.revision, a.in_contact) == (b.n_strokes, b.revision, b.in_contact)
    assert a._pen == b._pen


@pytest.mark.parametrize(("ink", "seed"), [("marker", 0), ("marker", 1), ("brush", 2),
                                         ("pencil", 3)])
def test_touch_many_gives_the_canvas_of_touch_and_lift_one_at_a_time(ink, seed):
    steps = _steps(seed)
    rng = np.random.default_rng(seed + 10)
    single, batched, read = (Canvas(size_mm=(20.0, 15.0), ink=ink) for _ in range(3))
    i = 0
    while i < len(steps):
        n = int(rng.integers(1, 6))  # periods of 1 to 5 physics steps
        batched.touch_many(steps[i : i + n])
        read.touch_many(steps[i : i + n])
        if rng.random() < 0.1:  # a reader mid-stroke (a viewer): the image composited early
            read.image.sum()
        i += n
    _one_at_a_time(single, steps)
    _assert_same(single, batched)
    _assert_same(single, read)
    assert single.take_dirty_box() == batched.take_dirty_box()
    assert single.n_strokes > 5 and np.count_nonzero(single.image) > 500  # it drew
    for canvas in (single, batched, read):
        canvas.lift()
    _assert_same(single, batched)
    _assert_same(single, read)


def test_touch_many_refuses_a_bad_step_as_touch_does_and_keeps_what_came_before():
    steps = [(1.0, 5.0, 5.0, 0.0), (1.0, 5.6, 5.0, 0.002), (1.0, float("inf"), 5.0, 0.004)]
    single, batched = Canvas(size_mm=(10.0, 10.0)), Canvas(size_mm=(10.0, 10.0))
    with pytest.raises(InputError, match=r"Canvas.touch: non-finite p_mm \(inf, 5.0\)"):
        batched.touch_many(steps)
    for force, x, y, t in steps[:2]:
        single.touch((x, y), force, t)
    _assert_same(single, batched)
    with pytest.raises(InputError, match=r"force_n must be finite and >= 0, got inf"):
        batched.touch_many([(float("inf"), 5.0, 5.0, 0.006)])
    with pytest.raises(InputError, match=r"time went backwards, t = 0.001 < previous 0.002"):
        batched.touch_many([(1.0, 5.0, 5.0, 0.001)])
    rest = [(1.0, 6.0, 5.5, 0.006), (0.0, 6.0, 5.5, 0.008)]
    batched.touch_many(rest)
    _one_at_a_time(single, rest)
    _assert_same(single, batched)
    assert single.n_strokes == 1


def test_capsules_refuse_a_raster_they_could_not_write_in_place():
    caps = np.array([[1.0, 1.0, 0.5, 2.0, 2.0, 0.5, 1.0]])
    with pytest.raises(ValueError, match="rasterise: the stroke raster must be C-contiguous"):
        rasterise(np.zeros((40, 40), np.float32)[:, ::2], caps, 10.0, 64, 1 << 20)
    stroke = np.zeros((40, 40), np.float32)
    assert rasterise(stroke, caps, 10.0, 64, 1 << 20)[1] == 1 and stroke.max() == 1.0
