"""The felt-tip marker's pen in C (inkarm/ink/_pen.c via inkarm.ink.compiled_pen) against the
canvas's Python loop: the same pen, queue, strokes and pixels, bit for bit, over random touch
sequences (lifts, zero and sub-threshold forces, repeated times, long strokes that fill the
capsule queue), fed in one call or many; the same errors from the same pen; and the Python loop
wherever the C may not run (other inks, a marker subclass, INKARM_COMPILED=0)."""

from __future__ import annotations

import logging
import sys
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import inkarm.ink
from inkarm.errors import InputError
from inkarm.ink import compiled_pen
from inkarm.ink.canvas import Canvas, MarkerInk
from tests.compiled import compiled_or_skip

SIZE_MM = (40.0, 30.0)


@pytest.fixture
def built():
    """The extension module, or a skip that says why (a failure with INKARM_REQUIRE_COMPILED=1)."""
    compiled_pen._load.cache_clear()
    return compiled_or_skip(compiled_pen.pen_module(), "the compiled pen")


def touches(rng, n: int, lift_rate: float = 0.05, repeat_rate: float = 0.05) -> np.ndarray:
    """(n, 4) rows (force [N], x [mm], y [mm], t [s]): a random walk at 1 ms steps whose force
    is often 0 (a lift) or below the marker's threshold, with some times repeated (dt = 0)."""
    force = rng.uniform(0.0, 2.0, n)
    force[rng.random(n) < lift_rate] = 0.0
    force[rng.random(n) < 0.05] = 0.04  # (below the default threshold of 0.08 N)
    xy = np.array([20.0, 15.0]) + np.cumsum(rng.normal(scale=0.15, size=(n, 2)), axis=0)
    dt = np.where(rng.random(n) < repeat_rate, 0.0, 0.001)
    return np.column_stack((force, np.clip(xy, 1.0, 29.0), np.cumsum(dt)))


def state(canvas: Canvas) -> tuple:
    return (canvas._pen, list(canvas._queue), canvas.n_strokes, canvas.revision,
            canvas.image.tobytes(), canvas.inked_box)


def drawn(rows: np.ndarray, chunks: int, compiled: bool, monkeypatch, ink=None) -> Canvas:
    monkeypatch.setenv("INKARM_COMPILED", "1" if compiled else "0")
    canvas = Canvas(SIZE_MM, px_per_mm=8.0, ink=ink or MarkerInk())
    for part in np.array_split(rows, chunks):
        canvas.touch_many(part if compiled else part.tolist())
    canvas.lift()
    return canvas


@settings(max_examples=40, deadline=None,  # (the fixture only sets INKARM_COMPILED)
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 900), chunks=st.integers(1, 7),
       w0=st.floats(0.05, 2.0), k=st.floats(0.0, 3.0), threshold=st.sampled_from([0.0, 0.08, 0.5]))
def test_the_c_pen_draws_the_python_pens_bits(built, monkeypatch, seed, n, chunks, w0, k,
                                               threshold):
    rows = touches(np.random.default_rng(seed), n)
    ink = MarkerInk(w0_mm=w0, k_mm=k, threshold_n=threshold)
    fast = drawn(rows, chunks, True, monkeypatch, ink)
    slow = drawn(rows, chunks, False, monkeypatch, ink)
    assert state(fast) == state(slow)


def test_a_long_stroke_fills_the_queue_and_a_touch_between_calls_keeps_the_pen(built,
                                                                                monkeypatch):
    """5,000 rows without a lift (the queue is rasterised mid-call several times), with single
    touch() calls (the Python loop) between the C's calls."""
    rng = np.random.default_rng(7)
    rows = touches(rng, 5000, lift_rate=0.0, repeat_rate=0.0)
    rows[:, 1:3] = np.column_stack((np.linspace(2, 38, 5000), 15 + 10 * np.sin(
        np.linspace(0, 20, 5000))))
    canvases, calls, advance = [], [], built.advance
    monkeypatch.setattr(built, "advance", lambda *a: calls.append(a[2]) or advance(*a))
    for compiled in (True, False):
        monkeypatch.setenv("INKARM_COMPILED", "1" if compiled else "0")
        canvas = Canvas(SIZE_MM, px_per_mm=8.0)
        for part in np.array_split(rows, 9):
            canvas.touch_many(part[:-1])
            force, x, y, t = part[-1].tolist()
            canvas.touch((x, y), force, t)
        canvases.append(state(canvas))
    assert canvases[0] == canvases[1]
    assert canvases[0][3] > 5000 // 256  # (revisions: the queue was rasterised many times)
    assert len(calls) > 9 and any(start > 0 for start in calls)  # (the C ran, and resumed)


@pytest.mark.parametrize(("column", "value", "words"), [
    (1, float("nan"), "non-finite p_mm"),
    (3, float("inf"), "non-finite p_mm"),
    (0, float("inf"), "force_n must be finite and >= 0, got inf"),
    (3, -1.0, "time went backwards"),
])
def test_a_refused_row_raises_the_python_message_from_the_same_pen(built, monkeypatch, column,
                                                                   value, words):
    rows = touches(np.random.default_rng(3), 60, lift_rate=0.0)
    rows[40, column] = value
    outcomes = []
    for compiled in (True, False):
        monkeypatch.setenv("INKARM_COMPILED", "1" if compiled else "0")
        canvas = Canvas(SIZE_MM, px_per_mm=8.0)
        with pytest.raises(InputError, match=words) as caught:
            canvas.touch_many(rows if compiled else rows.tolist())
        outcomes.append((str(caught.value), state(canvas)))
    assert outcomes[0] == outcomes[1]


@dataclass(frozen=True)
class _WiderMarker(MarkerInk):
    """A marker whose law is not the C one (a subclass: the canvas must use its mark)."""

    def mark(self, force_n: float, speed_mm_s: float) -> tuple[float, float]:
        width, opacity = super().mark(force_n, speed_mm_s)
        return 2.0 * width, opacity


@pytest.mark.parametrize("ink", [_WiderMarker(), "brush", "pencil"])
def test_other_inks_run_the_python_loop(built, monkeypatch, ink):
    """The C is never handed an ink whose law it does not hold: calls to it would fail."""
    rows = touches(np.random.default_rng(5), 300)
    monkeypatch.setattr(built, "advance", None, raising=False)  # (the pen must not be used)
    canvas = drawn(rows, 3, True, monkeypatch, ink)
    assert canvas.n_strokes >= 1


def test_switched_off_or_not_built_means_the_python_loop(monkeypatch, caplog):
    monkeypatch.setenv("INKARM_COMPILED", "0")
    assert compiled_pen.pen_module() is None
    monkeypatch.setenv("INKARM_COMPILED", "1")
    monkeypatch.delattr(inkarm.ink, "_pen", raising=False)
    monkeypatch.setitem(sys.modules, "inkarm.ink._pen", None)  # (its import fails)
    compiled_pen._load.cache_clear()
    try:
        with caplog.at_level(logging.DEBUG, logger="inkarm.ink.compiled_pen"):
            assert compiled_pen.pen_module() is None
            canvas = Canvas(SIZE_MM, px_per_mm=8.0)
            canvas.touch_many(touches(np.random.default_rng(2), 50))
    finally:
        compiled_pen._load.cache_clear()
    assert "compiled pen not used (the extension is not built" in caplog.text
    assert canvas.in_contact or canvas.n_strokes > 0  # (the Python loop drew)


def test_bad_rows_are_refused_by_the_extension_itself(built):
    """The C takes only what the canvas hands it: a (n, 4) float64 array and the pen tuple."""
    pen, law, motion = (False,) + (0.0,) * 16, (0.3, 0.5, 1.0, 1.0, 0.08), (0.02, 8.0, 0.25)
    with pytest.raises(TypeError, match=r"\(n, 4\) float64"):
        built.advance(pen, np.zeros((3, 3)), 0, law, motion, [], 1792)
    with pytest.raises(TypeError, match="17-tuple"):
        built.advance(pen[:5], np.zeros((3, 4)), 0, law, motion, [], 1792)
